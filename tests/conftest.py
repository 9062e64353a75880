"""Shared fixtures.  Django is configured by pytest-django (pytest.ini sets
DJANGO_SETTINGS_MODULE); the teaching tests use none of these fixtures, and
every Django import here happens inside a fixture so they stay Django-free.
"""
from __future__ import annotations

import functools
import json
import os
import sys
from pathlib import Path

import pytest

from teaching import teach
from teaching.core.build import PRESETS, build_table
from tests import builds, services

# each test module's seconds in a profiled run of `make test` (scripts/module_durations.py writes it)
DURATIONS = json.loads((Path(__file__).parent / "durations.json").read_text())


def pytest_collection_modifyitems(items):
    """The longest modules first (DURATIONS; one not in it last): pytest-xdist hands tests out in this
    order, and a long module collected last would run alone at the end while the other workers idle.
    A module's tests keep their order and stay together, so its module-scoped fixtures are not built
    again for every other module a worker runs in between."""
    first_seen: dict[str, int] = {}
    for item in items:
        first_seen.setdefault(item.nodeid.split("::")[0], len(first_seen))

    def key(item):
        module = item.nodeid.split("::")[0]
        return -DURATIONS.get(module, 0), first_seen[module]

    items.sort(key=key)

# Environments of the `tiny` table (48 environments × 24 θ, built once per run by `tiny_table`).
SMALL_SEQUENCES = {"alpha": [500, 5780, 12165], "beta": [7107, 15245], "gamma": [586, 20132]}
# The paper's nine condition names over environments of the tiny table (fixed picks: the analysis
# tests need the names and real trajectories, not what selection would choose on 24 θ).
PAPER_SEQUENCES = {
    "exact": [500, 11271, 9857], "det-reward": [586, 15655, 5780, 14251, 7157],
    "det-euclidean": [18151, 15655, 1149, 586, 12825, 13520], "det-strategy": [16137, 1149, 5780, 20293],
    "prob-reward": [13520, 16137, 7107, 11271, 14251], "prob-euclidean": [5780, 16137, 11271, 1149, 20278, 12825],
    "random": [20293, 16137, 9857, 15655, 7107, 20278, 18151, 14251],
    "coverage-approx*": [1149, 500, 7107, 16137, 13520, 12825, 5780, 586],
    "coverage-random": [1149, 14251, 586, 20293, 12825, 16137]}
# The test set's thresholds on the tiny table: with 24 θ few environments have three alternatives
# 0.5 apart (the study default), so the app's tests accept options 0.1 apart; the selection itself
# is the real one (teaching.core.testset.select_test_set).
TINY_TEST_SET = {"min_distance": 0.1}


@pytest.fixture(autouse=True)
def _fresh_rate_limits():
    """Every test starts with fresh rate-limit counters (the limits stay on): the suite sends
    thousands of requests from 127.0.0.1 within minutes, which no participant does.  Only when
    studyapp.guards.security is loaded, so the teaching tests stay Django-free."""
    security = sys.modules.get("studyapp.guards.security")
    if security is not None:
        security.reset_rate_limits()


@pytest.fixture(autouse=True, scope="session")
def _fast_password_hashing():
    """Passwords made in the tests are hashed with MD5 (Django's advice for test suites): the real
    hasher's million PBKDF2 rounds cost a quarter of a second per user made and per login tried, a
    minute of the suite's CPU.  PBKDF2 stays in the list, so a password a subprocess (a real server,
    a management command) hashed the production way still verifies here.  Only in this process: what
    the tests check about logins (the throttle, the lock) does not depend on the hash's cost."""
    from django.conf import settings  # noqa: PLC0415
    from django.test import override_settings  # noqa: PLC0415
    fast = override_settings(PASSWORD_HASHERS=["django.contrib.auth.hashers.MD5PasswordHasher",
                                               *settings.PASSWORD_HASHERS])
    fast.enable()
    yield
    fast.disable()


@pytest.fixture(scope="session")
def django_db_modify_db_settings(django_db_modify_db_settings_parallel_suffix):
    """The SQLite test database commits without waiting for the disk (PRAGMA synchronous=OFF).  Every
    test that needs committed rows (the live server, the in-process worker) commits twice per answer,
    and each commit's fsync on this disk costs more than the answer itself: simulating a study's
    participants spent three quarters of its time there.  What the tests check does not depend on
    it: locking, transactions and what a killed process leaves behind are as before; only an
    operating-system crash could lose the last commits of a database thrown away after the run."""
    from django.conf import settings  # noqa: PLC0415
    db = settings.DATABASES["default"]
    if db["ENGINE"] == "django.db.backends.sqlite3":
        db.setdefault("OPTIONS", {})["init_command"] = "PRAGMA synchronous=OFF"


@pytest.fixture(scope="session")
def tiny_table(tmp_path_factory):
    """The `tiny` preset built for real (48 environments × 24 θ, a few seconds), once per run, by the command a
    researcher runs (`python -m teaching build`, whose output tests/teaching/test_cli.py reads: tests/builds.py
    build_output): every study the app's tests make draws its trajectories from it."""
    return built_once(tmp_path_factory, builds.TINY_TABLE,
                      lambda out: builds.wait_build(builds.start_tiny_build(out), "the tiny table"))


@pytest.fixture
def make_study(db, tiny_table):
    """Factory: a study on the tiny table with the given conditions (default: 3 short ones), its
    trajectories and test set from the real pipeline (studies.table_spec)."""
    # Django only in fixtures: the teaching tests stay Django-free
    from studyapp.researcher.studies import build_study, table_spec  # noqa: PLC0415

    def make(slug="s1", sequences=None, **extra):
        extra.setdefault("completion_code", "TEST2026")  # Prolific arrivals need one (views.entry)
        spec = table_spec(tiny_table, slug=slug, sequences=sequences or SMALL_SEQUENCES, **TINY_TEST_SET)
        spec.update({"name": f"Study {slug}", "target_per_condition": 10, **extra})
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
    from studyapp.models import StepKind  # noqa: PLC0415
    from studyapp.participant.flow import option_letters, question_of  # noqa: PLC0415

    if step.kind == StepKind.CONSENT:
        return {"consent": ["yes"]}
    if step.kind == StepKind.INSTRUCTIONS:
        return {"ack": ["1"]}
    if step.kind == StepKind.COMPREHENSION:  # every question's right choices, as the next attempt
        from studyapp.participant.comprehension import questions_of  # noqa: PLC0415

        body = {"attempt": [str(participant.comprehension_attempts.count() + 1)]}
        body.update({f"q{i}": [str(k) for k in q["right"]] for i, q in enumerate(questions_of(participant.study))})
        return body
    if step.kind in (StepKind.TRAINING, StepKind.FEEDBACK):
        return {"played": ["1"]}
    if step.kind in (StepKind.TEST, StepKind.CHECK) and participant.study.test_kind == "show":  # θ*'s way
        from teaching.api import get_domain  # noqa: PLC0415
        from tests.teaching.domains.worlds.brute import actions_of  # noqa: PLC0415

        test = question_of(participant, step.kind, step.item)
        return {"moves": [" ".join(actions_of(get_domain(participant.study.domain).world, test["robot"]))]}
    if step.kind in (StepKind.TEST, StepKind.CHECK):  # options go by the letters the participant sees
        options = question_of(participant, step.kind, step.item)["options"]
        shown = option_letters(participant, step.item, step.kind)
        star = next(letter for letter, k in shown if options[k]["is_theta_star"])
        body = {"choice": [star], "played": [letter for letter, _ in shown]}
        body.update({f"rating_{letter}": ["6" if letter == star else "2"] for letter, _ in shown})
        return body
    if step.kind == StepKind.ATTENTION:  # exactly the study's domain's right answers
        from teaching.api import get_domain  # noqa: PLC0415

        return {"goals": sorted(get_domain(participant.study.domain).texts.attention_correct)}
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

    from studyapp.models import StepKind  # noqa: PLC0415
    from studyapp.participant import flow  # noqa: PLC0415

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
    return functools.partial(services.require_service, ci=ci)


# --- real tables ----------------------------------------------------------------------------
def built_once(tmp_path_factory, name: str, build) -> Path:
    """The directory `name`, filled by build(out) once per run and read-only afterwards (tests/builds.py).
    Under pytest-xdist (make test: -n 3) the workers share it, and `make test`'s two pytest runs share
    one directory, $TEST_BUILDS_DIR, made afresh for that command (where tests/prebuild.py has already
    built the demo table before either run starts)."""
    root = tmp_path_factory.getbasetemp()
    if os.environ.get("TEST_BUILDS_DIR"):
        root = Path(os.environ["TEST_BUILDS_DIR"])
    elif os.environ.get("PYTEST_XDIST_WORKER"):
        root = root.parent  # this run's directory, above every worker's own
    return builds.built_in(root, name, build)


def _teach(table: Path):
    def run(out):
        assert teach.main(["--table", str(table), "--out", str(out), "--no-progress"]) == 0
    return run


@pytest.fixture(scope="session")
def demo_table(tmp_path_factory):
    """The `demo` preset built for real (1,200 environments × 200 θ, ~30 s), once per run."""
    return built_once(tmp_path_factory, "demo-table", functools.partial(build_table, PRESETS["demo"]))


@pytest.fixture(scope="session")
def gridworld_table(tmp_path_factory):
    """The `gridworld` preset (1,200 yards x 200 θ, a few seconds), once per run."""
    return built_once(tmp_path_factory, "gridworld-table", functools.partial(build_table, PRESETS["gridworld"]))


# Both domains' tiny presets and the directories each is built in, once per run (tiny-table is also the
# one tiny_table and tests/prebuild.py build, by the command line: the same table).
TINY_PRESETS = {"tiny": builds.TINY_TABLE, "gridworld-tiny": "gridworld-tiny-table"}


def tiny_preset_table(tmp_path_factory, preset: str) -> Path:
    """The directory of the table of `preset` (a key of TINY_PRESETS), built once per run (built_once)."""
    return built_once(tmp_path_factory, TINY_PRESETS[preset], functools.partial(build_table, PRESETS[preset]))


@pytest.fixture(scope="session")
def gridworld_tiny_table(tmp_path_factory):
    """The `gridworld-tiny` preset, once per run."""
    return tiny_preset_table(tmp_path_factory, "gridworld-tiny")


@pytest.fixture(scope="session")
def skateboard_tiny_table(tmp_path_factory):
    """The `skateboard-tiny` preset (Lee et al.'s skateboard world from its file, 48 x 24), once per run (not among
    TINY_PRESETS, whose every table the recorded selections and test sets are checked on)."""
    return built_once(tmp_path_factory, "skateboard-tiny-table", functools.partial(build_table,
                                                                                    PRESETS["skateboard-tiny"]))


@pytest.fixture(scope="session")
def gridworld_teach(gridworld_table, tmp_path_factory):
    """`python -m teaching teach` on the gridworld table."""
    return built_once(tmp_path_factory, "gridworld-teach", _teach(gridworld_table))


@pytest.fixture(scope="session")
def demo_teach(demo_table, tmp_path_factory):
    """`python -m teaching teach` run on the demo table: sequences.json, test_set.json, ..."""
    return built_once(tmp_path_factory, "demo-teach", _teach(demo_table))
