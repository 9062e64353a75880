"""Fuzzing the participant endpoints with Hypothesis, through the real views and middleware.

Properties, for arbitrary form fields (names, values, repeats, encodings), step indices, tokens,
Origin headers and entry-link query strings:

* no response is a server error (status < 500);
* a response that is not a success wrote nothing (answers, participants' positions and flags);
* a success wrote at most what one valid request may: one answer to the step the participant
  stood on, or one participant at an entry link.

Deterministic (derandomize, no example database) and quick: a few hundred requests in all.
"""
from contextlib import contextmanager
from urllib.parse import quote, urlencode

import pytest
from django.db import transaction
from django.http import QueryDict
from django.test import Client
from django.urls import reverse
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from studyapp.guards import security
from studyapp.models import Participant, StepKind
from studyapp.participant import assignment, flow
from tests.studyapp.helpers import snapshot

pytestmark = pytest.mark.django_db

FUZZ = settings(max_examples=150, deadline=None, derandomize=True, database=None,
                suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
ANSWER_FIELDS = ["consent", "ack", "played", "choice", "rating_A", "rating_B", "rating_C", "rating_D",
                 "rating_E", "rating_0", "rating_-1", "goals", "age", "gender", "gender_text", "csrfmiddlewaretoken"]
ENTRY_FIELDS = ["PROLIFIC_PID", "STUDY_ID", "SESSION_ID", "workerId", "assignmentId", "hitId", "turkSubmitTo"]
ORIGINS = {"same": {"HTTP_ORIGIN": "http://testserver"}, "referer": {"HTTP_REFERER": "http://testserver/s/x/"},
           "cross": {"HTTP_ORIGIN": "https://evil.example"}, "none": {}}

text = st.text(st.characters(exclude_categories=("Cs",)), max_size=40)  # any character a browser can send
tricky = st.text(st.sampled_from("\x00\t\n\r <>'\"&=+-@%\\é\u202e\ufeff"), min_size=1, max_size=6)
values = st.one_of(
    text,
    tricky,
    st.tuples(text, tricky, text).map("".join),
    st.integers(-10**30, 10**30).map(str),
    st.sampled_from(["", " ", "0", "1", "2", "3", "6", "7", "8", "-1", "-5", "A", "B", "C", "D", "E", "a",
                     "yes", "no", "merge", "forward",
                     "park", "female", "other", "undisclosed", "34", "017", "1e3", "NaN", "inf", "٥", "５",
                     "1_0", " 6 ", "<script>alert(1)</script>", "' OR 1=1 --", "\x00", "ASSIGNMENT_ID_NOT_AVAILABLE",
                     "https://www.mturk.com", "https://workersandbox.mturk.com/x", "http://[", "javascript:x",
                     "9" * 5000, "x" * 101, "y" * 20000]),
)
answer_names = st.one_of(st.sampled_from(ANSWER_FIELDS), text)
entry_names = st.one_of(st.sampled_from(ENTRY_FIELDS), text)
submit_to = st.builds(  # an address on an MTurk host or not, of ordinary or excessive length, or junk
    lambda kind, host, path, long_path, junk: {"url": f"https://{host}/{path}", "long": f"https://{host}/{long_path}",
                                               "junk": junk}[kind],
    st.sampled_from(["url", "long", "junk"]),
    st.sampled_from(["www.mturk.com", "workersandbox.mturk.com", "evil.example"]),
    text, st.text(min_size=280, max_size=400), values)
entry_links = st.one_of(  # a Prolific link, an MTurk link, or any mix of the fields
    st.fixed_dictionaries({"PROLIFIC_PID": values}, optional={"STUDY_ID": values, "SESSION_ID": values}),
    st.fixed_dictionaries({"workerId": values}, optional={"assignmentId": values, "hitId": values,
                                                          "turkSubmitTo": submit_to}),
    st.fixed_dictionaries({}, optional={name: values for name in ENTRY_FIELDS}),
)


def valid_pairs(p, answer_for) -> list[tuple[str, str]]:
    """A valid answer for the participant's current step, as (field, value) pairs."""
    step = flow.current_step(p)
    if step.kind == StepKind.DONE:
        return []
    if step.kind == StepKind.DEMOGRAPHICS:  # the one free-text field, so that mutations reach it
        return [("age", "34"), ("gender", "other"), ("gender_text", "self-described")]
    return [(k, v) for k, vs in answer_for(p, step).items() for v in vs]


# A mutation recipe is drawn independently of the database, then applied to the valid answer of
# whatever step the participant stands on (Hypothesis needs draws that do not depend on state).
recipes = st.fixed_dictionaries({
    "start": st.sampled_from(["valid", "mutated", "mutated", "noise"]),
    "keep": st.lists(st.integers(0, 4).map(bool), min_size=12, max_size=12),  # drop about one in five
    "swap": st.lists(st.tuples(st.integers(0, 50), values), max_size=3),    # replace a field's value
    "repeat": st.lists(st.tuples(st.integers(0, 50), values), max_size=2),  # a second value for a field
    "noise": st.lists(st.tuples(answer_names, values), max_size=8),
    "order": st.randoms(use_true_random=False),
})


def apply(recipe, valid) -> list[tuple[str, str]]:
    if recipe["start"] == "valid":  # unchanged but for the order: the request that must succeed
        pairs = list(valid)
        recipe["order"].shuffle(pairs)
        return pairs
    pairs = [pair for i, pair in enumerate(valid) if recipe["keep"][i % 12]] if recipe["start"] == "mutated" else []
    for i, value in recipe["swap"]:
        if pairs:
            pairs[i % len(pairs)] = (pairs[i % len(pairs)][0], value)
    for i, value in recipe["repeat"]:
        pairs.append(((valid[i % len(valid)][0] if valid else ANSWER_FIELDS[i % len(ANSWER_FIELDS)]), value))
    pairs += recipe["noise"]
    recipe["order"].shuffle(pairs)
    return pairs


@contextmanager
def rolled_back():
    """Each example starts from the same database: deterministic, and a failure replays."""
    with transaction.atomic():
        yield
        transaction.set_rollback(True)


def advance(p, n, answer_for):
    """Record valid answers for the participant's first n steps (at most up to the last one)."""
    for step in flow.steps_for(p)[:-1][:n]:
        q = QueryDict(mutable=True)
        for k, v in answer_for(p, step).items():
            q.setlist(k, v)
        p = flow.record(p, step.index, q)
    return p


def post(client, url, pairs, encoding, headers):
    if encoding == "urlencoded":
        return client.post(url, urlencode(pairs), content_type="application/x-www-form-urlencoded", **headers)
    data = {}
    for k, v in pairs:
        data.setdefault(k, []).append(v)
    return client.post(url, data, **headers)


def succeeded(r) -> bool:
    if r.status_code == 302:
        return True
    if r.status_code == 200 and r["Content-Type"].startswith("application/json"):
        return r.json()["ok"] is True
    return r.status_code == 200  # the "you declined" page: a success that writes nothing


@pytest.fixture
def people(make_study):
    study = make_study("fuzz", target_per_condition=1000)
    alpha = study.conditions.get(name="alpha")  # fixed, not drawn at random: the same flow every run
    return study, [Participant.objects.create(study=study, condition=alpha, platform="prolific", platform_pid=f"fz{i}",
                                              option_orders=assignment.option_orders(study)) for i in range(3)]


@pytest.fixture
def advanced(people, answer_for):
    """advanced[n]: a participant of the study with valid answers recorded for its first n steps (up to
    the last one), made once per test: an example stands on its step without recording them again."""
    study, _ = people
    alpha = study.conditions.get(name="alpha")
    last = len(flow.steps_for(people[1][0])) - 1
    return [advance(Participant.objects.create(study=study, condition=alpha, platform="prolific",
                                               platform_pid=f"fz-advanced-{n}",
                                               option_orders=assignment.option_orders(study)), n, answer_for)
            for n in range(min(20, last) + 1)]


@FUZZ
@given(steps_done=st.integers(0, 20),  # None: the participant's own token, the step they stand on
       token=st.one_of(st.none(), st.none(), st.none(), st.one_of(text, tricky).filter(lambda t: t and "/" not in t)),
       step=st.one_of(st.none(), st.none(), st.none(), st.integers(0, 30), st.integers(0, 10**25)), recipe=recipes,
       origin=st.sampled_from(["same", "same", "referer", "cross", "none"]), json=st.booleans(),
       encoding=st.sampled_from(["urlencoded", "multipart"]))
def test_fuzzed_answers_never_500_and_bad_ones_write_nothing(people, advanced, answer_for, steps_done, token, step,
                                                              recipe, origin, json, encoding):
    security.reset_rate_limits()  # a fresh window per example: the fuzzing is of input, not of pace
    study, _ = people
    with rolled_back():
        p = advanced[min(steps_done, len(advanced) - 1)]
        token = p.token if token is None else token
        step = p.position if step is None else step
        headers = dict(ORIGINS[origin], **({"HTTP_ACCEPT": "application/json"} if json else {}))
        url = f"/s/{study.slug}/p/{quote(token, safe='')}/{step}/"
        before = snapshot()
        r = post(Client(enforce_csrf_checks=True), url, apply(recipe, valid_pairs(p, answer_for)), encoding, headers)
        assert r.status_code < 500, r.content[:500]
        after = snapshot()
        if not succeeded(r):
            assert after == before, (r.status_code, r.content[:300])
            return
        new = set(after[0]) - set(before[0])
        assert len(new) <= 1 and set(before[0]) <= set(after[0])
        if new:
            (who, step_written, _), = new
            assert (who, step_written) == (p.pk, p.position) and token == p.token and origin in ("same", "referer")
            assert Participant.objects.get(pk=p.pk).position == p.position + 1


@FUZZ
@given(known=entry_links,
       noise=st.lists(st.tuples(entry_names, values), max_size=4),
       slug=st.sampled_from(["fuzz", "fuzz", "fuzz", "no-such-study"]), json=st.booleans())
def test_fuzzed_entry_links_never_500_and_bad_ones_write_nothing(people, known, noise, slug, json):
    security.reset_rate_limits()
    params = list(known.items()) + noise
    with rolled_back():
        before = snapshot()
        headers = {"HTTP_ACCEPT": "application/json"} if json else {}
        r = Client().get(f"/s/{slug}/?{urlencode(params)}", **headers)
        assert r.status_code < 500, r.content[:500]
        after = snapshot()
        if r.status_code != 302:
            assert after == before, (r.status_code, r.content[:300])
            return
        assert set(before[1]) <= set(after[1]) and len(after[1]) - len(before[1]) <= 1
        for p in Participant.objects.filter(pk__in={row[0] for row in after[1]} - {row[0] for row in before[1]}):
            assert max(len(p.platform_pid), len(p.platform_study_id), len(p.platform_session_id)) <= 100
            assert p.platform_pid == p.platform_pid.strip() and "\x00" not in p.platform_pid + p.turk_submit_to
            assert r["Location"] == reverse("step", args=[slug, p.token])
