"""Shared fixtures.  Django is configured by pytest-django (pytest.ini sets
DJANGO_SETTINGS_MODULE); the teaching tests use none of these fixtures, and
every Django import here happens inside a fixture so they stay Django-free.
"""
from __future__ import annotations

import os
import sys

import pytest

from teaching import teach
from teaching.build import PRESETS, build_table

SMALL_SEQUENCES = {"alpha": [100, 5000, 12000], "beta": [7000, 15000], "gamma": [300, 20000]}


@pytest.fixture(autouse=True)
def _fresh_rate_limits():
    """Every test starts with fresh rate-limit counters (the limits stay on): the suite sends
    thousands of requests from 127.0.0.1 within minutes, which no participant does.  Only when
    studyapp.security is loaded, so the teaching tests stay Django-free."""
    security = sys.modules.get("studyapp.security")
    if security is not None:
        security.reset_rate_limits()


@pytest.fixture
def make_study(db):
    """Factory: a placeholder-trajectory study with the given conditions (default: 3 short ones)."""
    # Django only in fixtures: the teaching tests stay Django-free
    from studyapp.studies import build_study  # noqa: PLC0415

    def make(slug="s1", sequences=None, **extra):
        sequences = sequences or SMALL_SEQUENCES
        extra.setdefault("completion_code", "TEST2026")  # Prolific arrivals need one (views.entry)
        spec = {"slug": slug, "name": f"Study {slug}", "target_per_condition": 10,
                "conditions": [{"name": n, "env_ids": ids} for n, ids in sequences.items()], **extra}
        return build_study(spec)

    return make


@pytest.fixture
def study(make_study):
    return make_study()


@pytest.fixture
def staff_client(client, django_user_model):
    user = django_user_model.objects.create_user("staff", password="pw-staff-123", is_staff=True)
    client.force_login(user)
    return client


def answer_payload(participant, step):
    """A valid POST body (dict of lists) for `step` of `participant` (theta*'s option chosen, rated 6)."""
    # Django only when called: the teaching tests stay Django-free
    from studyapp.flow import option_letters  # noqa: PLC0415
    from studyapp.models import StepKind  # noqa: PLC0415

    if step.kind == StepKind.CONSENT:
        return {"consent": ["yes"]}
    if step.kind == StepKind.INSTRUCTIONS:
        return {"ack": ["1"]}
    if step.kind == StepKind.TRAINING:
        return {"played": ["1"]}
    if step.kind == StepKind.TEST:  # options go by the letters the participant sees (flow.option_letters)
        options = participant.study.test_set[step.item]["options"]
        shown = option_letters(participant, step.item)
        star = next(letter for letter, k in shown if options[k]["is_theta_star"])
        body = {"choice": [star], "played": [letter for letter, _ in shown]}
        body.update({f"rating_{letter}": ["6" if letter == star else "2"] for letter, _ in shown})
        return body
    if step.kind == StepKind.ATTENTION:
        return {"goals": ["merge", "forward"]}
    if step.kind == StepKind.DEMOGRAPHICS:
        return {"age": ["34"], "gender": ["female"]}
    raise ValueError(step.kind)


@pytest.fixture
def answer_for():
    return answer_payload


def complete_flow(participant, choices=None, attentive=True, stop_before=None):
    """Record valid answers for every step of `participant` up to the completion page.

    choices: the option picked in each test (default theta*'s); attentive=False fails the
    attention check (only one of the two goals); stop_before: a step kind to stop at.
    """
    # Django only in fixtures: the teaching tests stay Django-free
    from django.http import QueryDict  # noqa: PLC0415

    from studyapp import flow  # noqa: PLC0415
    from studyapp.models import StepKind  # noqa: PLC0415

    for step in flow.steps_for(participant)[:-1]:
        if stop_before and step.kind == stop_before:
            break
        body = answer_payload(participant, step)
        if step.kind == StepKind.TEST and choices:  # choices are option indices; the page posts letters
            body["choice"] = [letter for letter, k in flow.option_letters(participant, step.item)
                              if k == choices[step.item]]
        if step.kind == StepKind.ATTENTION and not attentive:
            body = {"goals": ["forward"]}
        q = QueryDict(mutable=True)
        for k, v in body.items():
            q.setlist(k, v)
        participant = flow.record(participant, step.index, q)
    return participant


@pytest.fixture
def complete():
    return complete_flow


@pytest.fixture(scope="session")
def ci() -> bool:
    """CI sets CI=true; a service a test needs (PostgreSQL, Redis) must then be there: the
    test fails instead of skipping.  One definition, so no test reads the variable differently."""
    return os.environ.get("CI", "").strip().lower() in ("1", "true", "yes")


@pytest.fixture
def require_service(ci):
    """require_service(ok, what): a test whose service (tests/services.py) is missing fails under
    CI and is skipped elsewhere, with `what` as the reason."""
    def require(ok: bool, what: str) -> None:
        if not ok:
            if ci:
                pytest.fail(f"CI is set but {what}")
            pytest.skip(f"{what} (allowed only outside CI)")

    return require


# --- real tables ----------------------------------------------------------------------------
@pytest.fixture(scope="session")
def demo_table(tmp_path_factory):
    """The `demo` preset built for real (1,200 environments × 200 θ, ~30 s), once per run."""
    out = tmp_path_factory.mktemp("demo-table")
    build_table(PRESETS["demo"], out)
    return out


@pytest.fixture(scope="session")
def demo_teach(demo_table, tmp_path_factory):
    """`python -m teaching.teach` run on the demo table: sequences.json, test_set.json, ..."""
    out = tmp_path_factory.mktemp("demo-teach")
    assert teach.main(["--table", str(demo_table), "--out", str(out), "--no-progress"]) == 0
    return out
