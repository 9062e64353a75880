"""A closed-loop condition through the participant flow: built from a spec on the
tiny table, decided step by step from the participant's answers, each decision stored once whatever the
browser does (reload, Back, a second tab, a double submit), pages that do not give θ*'s option away, and
every stored decision recomputed from the stored answers alone."""
import threading

import pytest
from django.db import connection
from django.test import Client
from django.urls import reverse

from studyapp.analysis.data import analyze_study
from studyapp.analysis.simulate import simulate
from studyapp.models import Answer, LoopStep, StepKind
from studyapp.participant import assignment, closedloop, flow
from studyapp.researcher.studies import SpecError, build_study, table_spec
from tests.conftest import SMALL_SEQUENCES, TINY_TEST_SET

pytestmark = pytest.mark.django_db

LOOP = {"model": "prob-euclidean", "value": 1.0, "lapse": 0.2, "max_examples": 4, "check_every": 1}


@pytest.fixture
def loop_study(tiny_table, settings, tmp_path):
    settings.VAR_DIR = tmp_path
    spec = table_spec(tiny_table, slug="loop", sequences={"alpha": SMALL_SEQUENCES["alpha"]}, **TINY_TEST_SET)
    spec["conditions"].append({"name": "closed-loop", "closed_loop": LOOP})
    spec.update(name="Closed loop", completion_code="LOOP2026", target_per_condition=10)
    return build_study(spec)


@pytest.fixture
def looper(loop_study):
    """A participant of the closed-loop condition, through the real assignment (balanced: of two
    arrivals, one gets each condition)."""
    arrivals = [assignment.assign(loop_study, "prolific", f"loop{i}") for i in range(2)]
    return next(p for p in arrivals if p.condition.name == "closed-loop")


def url(p, step=None):
    return (reverse("step", args=[p.study.slug, p.token]) if step is None
            else reverse("answer", args=[p.study.slug, p.token, step]))


def walk(client, p, answer_for, until=StepKind.DONE, choose=None):
    """Answer every step with the page (GET, then POST) until the participant stands on `until`;
    `choose(step)`: the option index to pick in a check (default θ*'s)."""
    while True:
        p.refresh_from_db()
        r = client.get(url(p))
        assert r.status_code == 200
        step = flow.current_step(p)
        if step.kind == until:
            return step
        body = answer_for(p, step)
        if step.kind == StepKind.CHECK and choose is not None:
            body["choice"] = [letter for letter, k in flow.option_letters(p, step.item, step.kind)
                              if k == choose(step)]
        r = client.post(url(p, step.index), body)
        assert r.status_code == 302, r.content[:300]


def test_the_condition_is_built_with_its_checks_and_pack(loop_study):
    c = loop_study.conditions.get(name="closed-loop")
    assert c.training == [] and c.closed_loop["settings"]["max_examples"] == 4
    tests = {t["env_id"] for t in loop_study.test_set}
    checks = c.closed_loop["checks"]
    assert checks and not {q["env_id"] for q in checks} & tests
    assert all(sum(o["is_theta_star"] for o in q["options"]) == 1 and len(q["options"]) == 4 for q in checks)
    pack = closedloop.pack_of_data(c.closed_loop)
    assert pack.meta["table_hash"] == loop_study.source["content_hash"]
    assert loop_study.is_open and "scene_view" in loop_study.source


def test_a_participant_goes_through_the_loop_and_it_replays(client, looper, answer_for):
    walk(client, looper, answer_for, choose=lambda step: 1)  # often not θ*'s option: the loop reacts
    looper.refresh_from_db()
    assert looper.completed_at is not None
    steps = list(looper.loop_steps.all())
    kinds = [s.kind for s in steps]
    assert kinds[-1] == LoopStep.DONE and kinds.count(LoopStep.EXAMPLE) <= 4
    assert kinds.count(LoopStep.CHECK) == kinds.count(LoopStep.FEEDBACK) >= 1
    tests = {t["env_id"] for t in looper.study.test_set}
    assert not {s.env_id for s in steps if s.kind == LoopStep.EXAMPLE} & tests
    # every stored decision recomputed from the stored answers alone
    assert closedloop.replay(looper) == []
    checks = Answer.objects.filter(participant=looper, kind=StepKind.CHECK)
    assert checks.count() == kinds.count(LoopStep.CHECK) and all(a.correct is not None for a in checks)
    # its final tests are the study's, scored as every condition's are
    assert Answer.objects.filter(participant=looper, kind=StepKind.TEST).count() == len(looper.study.test_set)
    # a changed answer no longer replays: the decisions depend on it
    a = checks.first()
    a.data = {**a.data, "choice": (a.data["choice"] + 1) % 4}
    a.save()
    assert closedloop.replay(looper)


def test_reload_back_second_tab_and_double_submit_give_one_decision_per_step(client, looper, answer_for):
    step = walk(client, looper, answer_for, until=StepKind.CHECK)
    first = LoopStep.objects.get(participant=looper, index=step.item)
    for _ in range(3):  # reloads and a second tab (another browser session of the same link)
        assert client.get(url(looper)).status_code == 200
        assert Client().get(url(looper)).status_code == 200
    assert LoopStep.objects.filter(participant=looper).count() == step.item + 1
    assert LoopStep.objects.get(participant=looper, index=step.item).option_order == first.option_order
    body = answer_for(looper, step)
    assert client.post(url(looper, step.index), body).status_code == 302
    assert client.post(url(looper, step.index), body).status_code == 302  # the double submit: a no-op
    looper.refresh_from_db()
    # Back to the check page: it shows where the participant is now, and the next decision once
    r = client.get(url(looper))
    assert r.status_code == 200
    n = LoopStep.objects.filter(participant=looper).count()
    assert client.get(url(looper)).status_code == 200 and LoopStep.objects.filter(participant=looper).count() == n
    other = dict(body, choice=[letter for letter, _ in flow.option_letters(looper, step.item, step.kind)
                               if letter != body["choice"][0]][:1])
    r = client.post(url(looper, step.index), other)  # the old page's other answer: refused, nothing changes
    assert r.status_code in (302, 409)
    assert Answer.objects.get(participant=looper, step=step.index).data["choice"] == \
        dict(flow.option_letters(looper, step.item, step.kind))[body["choice"][0]]
    assert closedloop.replay(looper) == []


@pytest.mark.django_db(transaction=True)
def test_two_tabs_deciding_at_once_store_one_decision(looper, answer_for):
    """Two requests for the same undecided step at the same moment: one LoopStep, both see it."""
    p = looper
    for _ in range(2):  # consent, instructions
        step = flow.current_step(p)
        client = Client()
        assert client.post(url(p, step.index), answer_for(p, step)).status_code == 302
        p.refresh_from_db()
    assert not LoopStep.objects.filter(participant=p).exists()
    barrier, seen = threading.Barrier(4), []

    def load():
        barrier.wait()
        r = Client().get(url(p))
        seen.append((r.status_code, r.context["step"].index if r.context else None))
        connection.close()

    threads = [threading.Thread(target=load) for _ in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert [code for code, _ in seen] == [200] * 4
    assert LoopStep.objects.filter(participant=p).count() == 1


def test_check_and_feedback_pages_do_not_give_the_answer_away(client, looper, answer_for):
    step = walk(client, looper, answer_for, until=StepKind.CHECK)
    r = client.get(url(looper))
    assert r.context["options"] == ["A", "B", "C", "D"]
    for leak in (b"is_theta_star", b"theta_index", b"cluster", b"env_id"):
        assert leak not in r.content
    assert b"Check question 1" in r.content
    assert 0 < r.context["progress"] < 50  # the bar counts the most the loop may still show, not 100 %
    client.post(url(looper, step.index), answer_for(looper, step))
    looper.refresh_from_db()
    assert flow.current_step(looper).kind == StepKind.FEEDBACK
    r = client.get(url(looper))
    assert b"The answer to the check question" in r.content
    for leak in (b"is_theta_star", b"theta_index", b"cluster", b"env_id"):
        assert leak not in r.content
    check = looper.condition.closed_loop["checks"][0]
    assert r.context["env"]["robot"] == next(o["robot"] for o in check["options"] if o["is_theta_star"])


@pytest.mark.parametrize("condition, message", [
    ({"name": "cl", "closed_loop": {"lapse": 0}}, "lapse rate must lie in"),
    ({"name": "cl", "closed_loop": {"modle": "exact"}}, "unknown closed-loop setting"),
    ({"name": "cl", "closed_loop": "yes"}, "'closed_loop' must be an object"),
    ({"name": "cl", "closed_loop": {}, "env_ids": [500]}, "chooses its own examples"),
])
def test_a_bad_closed_loop_condition_is_one_line(tiny_table, settings, tmp_path, condition, message):
    settings.VAR_DIR = tmp_path
    spec = table_spec(tiny_table, slug="bad", sequences={"alpha": SMALL_SEQUENCES["alpha"]}, **TINY_TEST_SET)
    spec["conditions"].append(condition)
    with pytest.raises(SpecError, match=message):
        build_study(spec)


def test_simulated_participants_complete_it_and_the_analysis_counts_it_as_a_condition(loop_study):
    """Bots through the real flow (analysis/simulate.py): the closed-loop condition's participants finish, their
    decisions replay, and the analysis compares the condition like any other."""
    simulate(loop_study, n_per_condition=4, fail_every=100)
    people = list(loop_study.participants.filter(condition__name="closed-loop"))
    assert len(people) >= 3 and all(p.completed_at is not None for p in people)  # one may replace a failed check
    assert all(closedloop.replay(p) == [] for p in people)
    result = analyze_study(loop_study)
    assert set(result.participants["condition"]) == {"alpha", "closed-loop"}
    assert {"alpha", "closed-loop"} <= set(result.summary.reset_index().astype(str).stack())
    named = analyze_study(loop_study, extra_comparisons=[("closed-loop", "alpha")])  # a researcher's Welch test
    row = named.welch[(named.welch["a"] == "closed-loop") & (named.welch["b"] == "alpha")]
    analysed = sum(p.completed_at is not None and not p.excluded for p in people)
    assert len(row) == 1 and row.iloc[0]["n_a"] == analysed > 0 and 0 <= row.iloc[0]["p_holm"] <= 1
