"""Tests where the participant shows the way (Study.test_kind "show"), on a grid world written only as a
file (tests/teaching/domains/worlds/key-room.toml): the study is built from its table, the page carries
the world and its rules but never θ*'s way, a shown way is stored as its moves with its regret, and a
way the world does not allow is refused with nothing written.

Regrets are checked against an independent reference (tests/teaching/domains/worlds/brute.py: its own
transition rules, the best reward by enumerating every action sequence), not the planner's fronts."""
from __future__ import annotations

import csv
import io
import json

import numpy as np
import pytest
from django.http import QueryDict
from django.urls import reverse

from studyapp.analysis.data import analyze_study
from studyapp.analysis.report import render_fragment
from studyapp.data.exports import long_csv
from studyapp.models import Answer, Participant, StepKind, Study
from studyapp.participant import closedloop, flow
from studyapp.participant.assignment import assign
from studyapp.researcher.specschema import SpecError
from studyapp.researcher.studies import build_study, spec_from_teach
from teaching.api import TrajectoryTable
from tests.conftest import answer_payload
from tests.studyapp.helpers import answer_url, record, snapshot, step_url
from tests.teaching.domains.worlds import brute, key_room
from tests.teaching.domains.worlds.shipped import NAMES, shipped, teach_show


@pytest.fixture
def show_study(db, tmp_path_factory):
    """A key-room study whose tests ask to show the way, in the environments of its teach output's tests."""
    with key_room.registered() as domain:
        _, teach_dir = key_room.built(tmp_path_factory)
        spec = spec_from_teach(teach_dir)
        spec.update(slug="key-room-show", name="Key room, shown",
                    test_set=[{"env_id": t["env_id"], "kind": "show"} for t in spec["test_set"]])
        study = build_study(spec)
        yield study, domain


def reference_regret(world, variant: int, start, actions: list[str], horizon: int) -> float:
    """θ*'s best reward from start state `start` of `variant` (brute force) minus the reward of `actions`
    replayed by brute's own rules."""
    state, total = start, np.zeros(len(world.features))
    for a in actions:
        state, add, _ = brute.step(world, variant, state, a)
        total += add
    theta = np.asarray(world.theta_star, float)
    return float(brute.best_rewards(world, variant, start, theta[None], horizon)[0] - total @ theta)


def at_first_test(study) -> Participant:
    p = assign(study, Participant.ANONYMOUS, "")
    first = next(s.index for s in flow.steps_for(p) if s.kind == StepKind.TEST)
    Participant.objects.filter(pk=p.pk).update(position=first)
    p.refresh_from_db()
    return p


def test_a_show_study_stores_theta_stars_way_on_the_server_and_no_options(show_study):
    study, domain = show_study
    assert study.test_kind == Study.SHOW and study.test_set
    for test in study.test_set:
        assert test["kind"] == "show" and "options" not in test
        rows = test["robot"]
        reward = domain.score_shown(test["env_id"], brute.actions_of(domain.world, rows))["reward"]
        assert test["optimum"] == pytest.approx(reward, abs=1e-9)  # θ*'s way earns the stored optimum


def test_the_page_draws_the_world_and_its_rules_but_never_theta_stars_way(show_study, client):
    study, domain = show_study
    p = at_first_test(study)
    page = client.get(step_url(p))
    assert page.status_code == 200
    assert [t.name for t in page.templates][0] == "studyapp/step_show.html"
    test = study.test_set[0]
    assert page.context["scene"] == domain.page_scene(test) and "robot" not in page.context["scene"]
    assert page.context["rules"]["blocked"] == domain.world.blocked(test["variant"]).tolist()
    html = page.content.decode()
    assert 'data-move="up"' in html and 'name="moves"' in html and 'data-action="undo"' in html
    assert '"robot"' not in html and "optimum" not in html


def test_a_shown_way_is_stored_as_its_moves_with_the_regret_the_reference_finds(show_study):
    study, domain = show_study
    test = study.test_set[0]
    horizon = domain.max_moves + 2
    best = brute.actions_of(domain.world, test["robot"])
    # a detour: one step back and forth first, which costs θ* two more steps
    detour = next(([a, b] for a, b in (("right", "left"), ("left", "right"), ("up", "down"), ("down", "up"))
                   if not _refused(domain, test["env_id"], [a, b, *best])), None)
    assert detour, "the start has no free neighbour"
    for moves, optimal in ((best, True), ([*detour, *best], False)):
        p = at_first_test(study)
        step = p.position
        p = record(p, step, moves=" ".join(moves))
        answer = Answer.objects.get(participant=p, step=step)
        assert answer.data == {"env_id": test["env_id"], "moves": moves}
        assert answer.correct is optimal and answer.chosen_option is None and answer.confidence_score is None
        want = reference_regret(domain.world, *domain.environment(test["env_id"]), moves, horizon)
        assert answer.regret == pytest.approx(want, abs=1e-9)
        assert (want == pytest.approx(0, abs=1e-9)) is optimal


def _refused(domain, env_id, moves) -> bool:
    try:
        domain.score_shown(env_id, moves)
    except ValueError:
        return True
    return False


def _wall_walk(domain, test) -> list[str]:
    """From the start, straight in some direction until the next cell is off the grid or blocked, then one
    more step: a way that leaves the grid or walks into a wall."""
    world = test["world"]
    col, row = world["start"]
    blocked = domain.world.blocked(test["variant"])
    for name, (dc, dr) in (("up", (0, -1)), ("left", (-1, 0)), ("down", (0, 1)), ("right", (1, 0))):
        moves, c, r = [], col, row
        goals = {(f.at[1], f.at[0]) for f in domain.world.features if f.counts == "reach"}
        while 0 <= c + dc < domain.world.width and 0 <= r + dr < domain.world.height and not blocked[r + dr, c + dc]:
            c, r = c + dc, r + dr
            moves.append(name)
            if (c, r) in goals:
                break
        else:
            return [*moves, name]
    raise AssertionError("every direction reaches a goal")


@pytest.mark.parametrize("case", ["off the grid or into a wall", "stops before the end", "not an action",
                                  "after the end", "too long", "missing"])
def test_a_way_the_world_does_not_allow_is_refused_with_nothing_written(show_study, client, case):
    study, domain = show_study
    test = study.test_set[0]
    best = brute.actions_of(domain.world, test["robot"])
    moves = {"off the grid or into a wall": lambda: " ".join(_wall_walk(domain, test)),
             "stops before the end": lambda: " ".join(best[:-1]),
             "not an action": lambda: "right jump",
             "after the end": lambda: " ".join([*best, "right"]),
             "too long": lambda: " ".join(["right", "left"] * (2 * domain.max_moves + 1)),
             "missing": lambda: None}[case]()
    p = at_first_test(study)
    client.get(step_url(p))
    before = snapshot()
    response = client.post(answer_url(p, p.position), {} if moves is None else {"moves": moves},
                           HTTP_ACCEPT="application/json")
    assert response.status_code == 400
    error = response.json()["error"]
    assert error.startswith("This way") or error.startswith("Please show the way"), error
    assert "Traceback" not in error and "\n" not in error
    assert snapshot() == before


def test_show_tests_are_refused_mixed_with_choice_tests(show_study):
    study, domain = show_study
    spec = {"slug": "mixed", "table": study.source["table"], "conditions": [{"name": "a", "env_ids": [0]}],
            "test_set": [{"env_id": 1, "kind": "show"}, {"env_id": 2, "options": []}]}
    with pytest.raises(SpecError, match="mixes 'show' tests"):
        build_study(spec)


def test_the_car_cannot_show_the_way(db, tiny_table):
    ids = [int(i) for i in TrajectoryTable.load(tiny_table).env_ids[:2]]
    with pytest.raises(SpecError, match="has no 'show the way' tests"):
        build_study({"slug": "car-show", "table": str(tiny_table), "conditions": [{"name": "a", "env_ids": ids[:1]}],
                     "test_set": [{"env_id": ids[1], "kind": "show"}]})


def test_a_participant_of_a_show_study_completes_it(show_study, complete):
    study, _ = show_study
    p = complete(assign(study, Participant.ANONYMOUS, ""))
    assert p.completed_at is not None
    tests = Answer.objects.filter(participant=p, kind=StepKind.TEST).order_by("item")
    assert [a.item for a in tests] == list(range(len(study.test_set)))
    assert all(a.correct and a.regret == pytest.approx(0, abs=1e-9) for a in tests)


def test_the_stimulus_sheet_shows_theta_stars_way_for_each_show_test(show_study, staff_client):
    study, _ = show_study
    page = staff_client.get(reverse("dashboard_stimuli", args=[study.slug]))
    assert page.status_code == 200
    rows = page.context["tests"]
    assert len(rows) == len(study.test_set)
    for row, test in zip(rows, study.test_set, strict=True):
        assert [(o["letter"], o["is_theta_star"], o["robot"]) for o in row["options"]] == [
            ("θ*'s way", True, test["robot"])]


@pytest.mark.parametrize("name", NAMES)
def test_a_study_of_each_shipped_world_runs_end_to_end_from_its_teach_output(name, db, tmp_path_factory, complete):
    with shipped(name) as domain:
        _, teach_dir = teach_show(tmp_path_factory, domain)
        study = build_study({**spec_from_teach(teach_dir), "slug": f"{name}-show"})
        assert study.test_kind == Study.SHOW and study.is_open
        p = complete(assign(study, Participant.ANONYMOUS, ""))
        assert p.completed_at is not None
        tests = list(Answer.objects.filter(participant=p, kind=StepKind.TEST).order_by("item"))
        assert [a.data["env_id"] for a in tests] == [t["env_id"] for t in study.test_set]
        assert all(a.correct and a.regret == pytest.approx(0, abs=1e-9) for a in tests)
        # the report names θ*'s L1 norm, for regrets in Lee et al.'s units (their params.py: θ* / ‖θ*‖₁)
        analysis = analyze_study(study)
        assert analysis.theta_star_l1 == pytest.approx({"taxi": 30, "two-goal": 18.75, "skateboard": 10.3}[name])
        assert f"‖θ*‖₁ = {analysis.theta_star_l1:g}" in render_fragment(analysis)


LOOP = {"model": "prob-euclidean", "value": 1.0, "lapse": 0.2, "max_examples": 3, "check_every": 1}


@pytest.fixture
def loop_study(db, tmp_path_factory, settings, tmp_path):
    """A key-room study whose tests show the way, with a closed-loop condition: its checks show the way too."""
    settings.VAR_DIR = tmp_path
    with key_room.registered() as domain:
        _, teach_dir = key_room.built(tmp_path_factory)
        spec = spec_from_teach(teach_dir)
        spec.update(slug="key-room-loop", test_set=[{"env_id": t["env_id"], "kind": "show"} for t in spec["test_set"]],
                    conditions=[spec["conditions"][0], {"name": "loop", "closed_loop": LOOP}])
        yield build_study(spec), domain


def loop_participant(study, n: int) -> Participant:
    arrivals = [assign(study, Participant.PROLIFIC, f"loop-{n}-{i}") for i in range(2)]
    return next(p for p in arrivals if p.condition.name == "loop")


def advance(p: Participant, until: StepKind) -> Participant:
    """Answer p's steps as conftest's answer_payload does (θ*'s way in a show step) until p stands on `until`;
    a closed loop's steps are decided as p reaches them, so they are read one at a time."""
    while (step := flow.current_step(p)).kind != until:
        q = QueryDict(mutable=True)
        for k, v in answer_payload(p, step).items():
            q.setlist(k, v)
        p = flow.record(p, step.index, q)
    return p


def test_a_closed_loop_checks_by_a_shown_way_and_replays(loop_study, client):
    study, domain = loop_study
    checks = study.conditions.get(name="loop").closed_loop["checks"]
    assert checks and all(c["kind"] == "show" and "options" not in c and c["ways"] for c in checks)
    assert not {c["env_id"] for c in checks} & {t["env_id"] for t in study.test_set}
    for c in checks:  # θ*'s way is the first of the ways, and every way is a different trajectory
        assert c["ways"][0]["robot"] == c["robot"] and c["ways"][0]["theta_index"] == 0
        assert len({json.dumps(w["robot"]) for w in c["ways"]}) == len(c["ways"])
    # each participant answers the first check with a way of the table's (each in turn) or none of them
    check = checks[0]
    answers = [(k, brute.actions_of(domain.world, w["robot"])) for k, w in enumerate(check["ways"])]
    detour = brute.actions_of(domain.world, check["robot"])
    answers.append((len(check["ways"]), ["right", "left", *detour] if not _refused(
        domain, check["env_id"], ["right", "left", *detour]) else ["up", "down", *detour]))
    for n, (want, moves) in enumerate(answers):
        p = loop_participant(study, n)
        p = advance(p, StepKind.CHECK)
        page = client.get(step_url(p))
        assert [t.name for t in page.templates][0] == "studyapp/step_show.html"
        assert page.context["scene"]["world"] == check["world"] and "ways" not in page.content.decode()
        p = record(p, p.position, moves=" ".join(moves))
        answer = Answer.objects.get(participant=p, kind=StepKind.CHECK)
        assert answer.chosen_option == want and answer.data["moves"] == moves
        score = domain.score_shown(check["env_id"], moves)
        assert answer.regret == pytest.approx(score["regret"]) and answer.correct is score["optimal"]
        p = advance(p, StepKind.DONE)
        assert p.completed_at is not None and closedloop.replay(p) == []
    # a changed way no longer replays: the decisions depend on the way shown, replayed again
    answer = Answer.objects.get(participant=p, kind=StepKind.CHECK)
    Answer.objects.filter(pk=answer.pk).update(data={**answer.data, "moves": answers[0][1]})
    assert closedloop.replay(p)
    rows = [r for r in csv.DictReader(io.StringIO(long_csv(study))) if r["kind"] == "check"]
    assert len(rows) == len(answers) and all(r["moves"] and r["regret"] != "" for r in rows)
