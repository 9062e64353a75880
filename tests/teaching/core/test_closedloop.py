"""Closed-loop teaching: the belief, the next example and the replay.

* On a likelihood matrix written by hand, the best next example after a check answer is worked out by
  hand, and the answer changes it.
* Without checks the closed loop shows the open-loop greedy sequence (selection.greedy), on a real
  table, for every learner model: the belief is then the model's own posterior.
* Simulated participants (who learn by their own model, through teaching.core.choice) go through the
  loop; their stored events and decisions, as JSON, replay to the same decisions, and an altered
  answer is caught.
"""
import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from teaching.core.answers import Question, questions_of
from teaching.core.choice import choice_probabilities
from teaching.core.closedloop import (
    CHECK,
    DONE,
    EXAMPLE,
    FEEDBACK,
    ClosedLoop,
    ClosedLoopError,
    ClosedLoopSpec,
    Decision,
    Event,
    answer_likelihood,
    check_questions,
    run_learner,
    select_checks,
)
from teaching.core.closedloop_pack import load_pack, write_pack
from teaching.core.closedloop_pilot import loop_pilot
from teaching.core.evaluation import ideal_user_matrix
from teaching.core.fitting import choice_table, option_distances
from teaching.core.learners import Distances, make_model, model_names
from teaching.core.selection import greedy, showable
from teaching.core.simulate import SimulatedLearner
from teaching.core.table import TrajectoryTable
from teaching.core.testset import select_test_set
from teaching.domains.driving.synthetic import synthetic_table

# Four θ (θ0 = θ*), four environments.  E0 rules θ3 out; E1 and E2 each make one of θ1, θ2 five times
# less likely; E3 (the check's environment) tells nothing.
LIK = np.array([[1, 1, 1, 0],
                [1, 0.2, 1, 1],
                [1, 1, 0.2, 1],
                [1, 1, 1, 1]], np.float32)
# The check's two options: option 0 is what θ1 would do, option 1 what θ2 would do; θ0 and θ3 take
# neither, so they guess.
CHECK_OPTIONS = np.array([[0, 1, 0, 0], [0, 0, 1, 0]], np.float64)


def hand_loop(**settings) -> ClosedLoop:
    settings.setdefault("example_lapse", 0.0)  # the hand values below take every example in full
    spec = ClosedLoopSpec(model="prob-euclidean", value=1.0, lapse=0.1, max_examples=3, check_every=1, **settings)
    return ClosedLoop(spec, LIK, [Question(3, (1, 2))], [answer_likelihood(CHECK_OPTIONS, 0.1)],
                      eligible=np.array([True, True, True, False]))


def test_answer_likelihood_is_the_choice_model_of_a_learner_certain_of_theta():
    rng = np.random.default_rng(0)
    lik = rng.uniform(size=(4, 6)) * (rng.uniform(size=(4, 6)) > 0.3)
    lik[:, 2] = 0  # no option fits θ2: a guess
    p = answer_likelihood(lik, 0.15)
    for n in range(6):
        np.testing.assert_allclose(p[:, n], choice_probabilities(np.eye(6)[n], lik, 0.15))
    np.testing.assert_allclose(p[:, 2], 0.25)
    np.testing.assert_allclose(p.sum(0), 1.0)


def test_the_best_next_example_by_hand():
    loop = hand_loop(feedback=True)
    # step 0: E0 gives P(θ*) = 1/3, E1 and E2 1/3.2
    d = loop.decide([])
    assert (d.kind, d.env_index) == (EXAMPLE, 0)
    assert dict(d.candidates)[0] == pytest.approx(1 / 3) and dict(d.candidates)[1] == pytest.approx(1 / 3.2)
    assert d.p_theta_star == pytest.approx(0.25) and d.entropy_bits == pytest.approx(2.0)
    shown = [Event(EXAMPLE, 0)]
    d = loop.decide(shown)
    assert (d.kind, d.env_index, d.question) == (CHECK, 3, 0)
    assert d.p_theta_star == pytest.approx(1 / 3)
    # The participant picks θ2's option: P(1 | θ) = 0.5, 0.05, 0.95, 0.5 (θ0 and θ3 guess; ε = 0.1, K = 2),
    # so b ∝ (0.5, 0.05, 0.95, 0) and E2, which speaks against θ2, is best: 0.5 / (0.5 + 0.05 + 0.19).
    answered = shown + [Event(CHECK, 3, question=0, answer=1)]
    d = loop.decide(answered)
    assert (d.kind, d.env_index) == (FEEDBACK, 3)
    assert d.p_theta_star == pytest.approx(0.5 / 1.5)
    assert dict(d.top_thetas) == pytest.approx({2: 0.95 / 1.5, 0: 0.5 / 1.5, 1: 0.05 / 1.5, 3: 0.0})
    d = loop.decide(answered + [Event(FEEDBACK, 3)])
    assert (d.kind, d.env_index) == (EXAMPLE, 2)
    assert dict(d.candidates) == pytest.approx({2: 0.5 / 0.74, 1: 0.5 / 1.46, 0: 0.5 / 1.5})
    # Had they picked θ1's option, E1 would come next; with no check at all, the open loop's E1 (a tie
    # at 1 / 2.2 broken by the lower row).
    d = loop.decide(shown + [Event(CHECK, 3, question=0, answer=0), Event(FEEDBACK, 3)])
    assert (d.kind, d.env_index) == (EXAMPLE, 1)
    no_checks = ClosedLoop(ClosedLoopSpec(model="prob-euclidean", value=1.0, check_every=0, max_examples=3,
                                          example_lapse=0.0),
                           LIK, [], [], eligible=np.array([True, True, True, False]))
    d = no_checks.decide(shown)
    assert (d.kind, d.env_index, d.candidates[0][1]) == (EXAMPLE, 1, pytest.approx(1 / 2.2))


def test_the_schedule_without_feedback_and_when_it_stops():
    loop = hand_loop(feedback=False)
    events = [Event(EXAMPLE, 0), Event(CHECK, 3, 0, 1)]
    d = loop.decide(events)
    assert d.kind == EXAMPLE  # no feedback step
    events += [Event(EXAMPLE, d.env_index)]
    d = loop.decide(events)
    assert d.kind == EXAMPLE  # only one check question was reserved: no second check
    events += [Event(EXAMPLE, d.env_index)]
    d = loop.decide(events)
    assert (d.kind, d.reason) == (DONE, "3 examples shown")
    # stop_at: done as soon as the participant's P(θ*) reaches it
    d = hand_loop(feedback=False, stop_at=0.3).decide([Event(EXAMPLE, 0), Event(CHECK, 3, 0, 1),
                                                        Event(EXAMPLE, 2)])
    assert d.kind == DONE and d.reason.startswith("P(θ*) 0.676 reached")
    # nothing left to teach: no environment tells θ* from θ1
    lik = np.array([[1, 1, 0], [1, 1, 0.5]], np.float32)
    loop = ClosedLoop(ClosedLoopSpec(check_every=0, example_lapse=0.0), lik, [], [], np.array([True, True]))
    assert loop.decide([]).env_index == 0
    d = loop.decide([Event(EXAMPLE, 0)])
    assert (d.kind, d.reason, d.p_theta_star) == (DONE, "no example raises P(θ*)", 0.5)
    # and once every θ but θ* is ruled out, P(θ*) = 1 reaches any stop_at
    lik = np.array([[1, 0, 0]], np.float32)
    d = ClosedLoop(ClosedLoopSpec(check_every=0, example_lapse=0.0), lik, [], [],
                   np.array([True])).decide([Event(EXAMPLE, 0)])
    assert (d.kind, d.reason) == (DONE, "P(θ*) 1.000 reached 1")


def test_with_an_example_lapse_a_wrong_answer_brings_back_a_ruled_out_theta():
    """η = 0.1: E0 leaves θ3 a tenth of its weight, b ∝ (1, 1, 1, 0.1); a check whose option 1 only θ3 would
    pick, answered 1, multiplies by P(1 | θ) = (0.05, 0.5, 0.5, 0.95): θ3 is back at 0.095 / 1.145.  With
    η = 0 it stays at 0, whatever the answer."""
    options = np.array([[1, 0, 0, 0], [0, 0, 0, 1]], np.float64)
    events = [Event(EXAMPLE, 0), Event(CHECK, 3, question=0, answer=1)]
    for eta, theta3 in ((0.1, 0.095 / 1.145), (0.0, 0.0)):
        spec = ClosedLoopSpec(model="prob-euclidean", value=1.0, lapse=0.1, example_lapse=eta, max_examples=3,
                              check_every=1, feedback=False)
        loop = ClosedLoop(spec, LIK, [Question(3, (0, 3))], [answer_likelihood(options, 0.1)],
                          eligible=np.array([True, True, True, False]))
        d0 = loop.decide([])
        assert dict(d0.candidates)[1] == pytest.approx(1 / (0.9 * 3.2 + 0.1 * 4) if eta else 1 / 3.2)
        assert loop.decide(events[:1]).p_theta_star == pytest.approx(1 / 3.1 if eta else 1 / 3)
        assert dict(loop.decide(events).top_thetas).get(3, 0.0) == pytest.approx(theta3)


@pytest.mark.parametrize("settings, message", [
    (dict(model="nobody"), "nobody"),
    (dict(lapse=0.0), "lapse rate must lie in (0, 1]"),
    (dict(lapse=1.5), "lapse rate must lie in (0, 1]"),
    (dict(max_examples=0), "max_examples must be a whole number from 1 to 30"),
    (dict(max_examples=2.5), "max_examples must be a whole number"),
    (dict(check_every=7), "check_every must be a whole number from 0"),
    (dict(stop_at=0), "stop_at must lie in (0, 1]"),
    (dict(example_lapse=1.0), "example lapse rate must lie in [0, 1)"),
    (dict(model="prob-euclidean", value=-1), "hyperparameter must be a finite number > 0"),
])
def test_a_bad_specification_is_one_line(settings, message):
    with pytest.raises(ClosedLoopError, match=re.escape(message)):
        ClosedLoopSpec(**settings)
    with pytest.raises(ClosedLoopError, match="unknown closed-loop setting"):
        ClosedLoopSpec.from_dict({"modle": "exact"})


def test_bad_events_are_refused():
    loop = hand_loop()
    for events, message in [([Event("lecture", 0)], "unknown kind"), ([Event(EXAMPLE, 9)], "not in the table"),
                            ([Event(CHECK, 3, question=4, answer=0)], "no check question"),
                            ([Event(CHECK, 3, question=0, answer=2)], "not an option")]:
        with pytest.raises(ClosedLoopError, match=message):
            loop.decide(events)


@pytest.mark.parametrize("model", model_names())
def test_without_checks_the_closed_loop_is_the_open_loop_greedy_sequence(tiny_table, model):
    table = TrajectoryTable.load(tiny_table)
    dist = Distances(table)
    spec = ClosedLoopSpec(model=model, check_every=0, max_examples=10, example_lapse=0.0)
    loop = ClosedLoop.build(table, spec, checks=(), dist=dist)
    seq, _ = greedy(loop.lik, max_examples=10, eligible=showable(table))
    events = []
    while (d := loop.decide(events)).kind != DONE:
        events.append(Event(d.kind, d.env_index))
    assert [e.env_index for e in events] == seq.envs
    assert seq.envs  # the tiny table teaches something to every model


def test_the_pilot_of_a_loop_without_checks_is_the_ideal_user_matrix_of_its_one_sequence(tiny_table):
    """With no checks every simulated participant takes the greedy path, so the closed loop's pilot row is the
    open-loop pilot (evaluation.ideal_user_matrix, the P(θ*) of an ideal user) of that one sequence, and its
    choices are the fit's choice table of it: computed apart, through selection.greedy."""
    table = TrajectoryTable.load(tiny_table)
    dist = Distances(table)
    models = {m: make_model(m) for m in ("exact", "det-euclidean", "prob-reward")}
    loop = ClosedLoop.build(table, ClosedLoopSpec(model="det-euclidean", check_every=0, max_examples=4,
                                                  example_lapse=0.0), checks=(), dist=dist)
    tests = select_test_set(table, [], seed=0, min_distance=0.1)
    row = loop_pilot(loop, table, models, tests, n=5, dist=dist)
    seq, _ = greedy(loop.lik, max_examples=4, eligible=showable(table))
    direct = ideal_user_matrix(models, {"loop": seq.envs}, dist, sequence_names=["loop"], user_names=list(models))
    assert [row["p"][m] for m in models] == pytest.approx(direct[0].tolist(), abs=1e-12)
    questions, _ = questions_of(table, tests)
    for m, model in models.items():
        expected = choice_table(model, dist, option_distances(table, questions), [seq.envs])[0]
        assert np.array(row["choice"][m]) == pytest.approx(expected, abs=1e-6)


@pytest.fixture(scope="module")
def demo_loop(demo_table):
    table = TrajectoryTable.load(demo_table)
    dist = Distances(table)
    tests = select_test_set(table, [], seed=0)
    checks = select_checks(table, tests)
    loop = ClosedLoop.build(table, ClosedLoopSpec(max_examples=6, check_every=2), check_questions(table, checks),
                            exclude=[t["env_index"] for t in tests], dist=dist)
    return table, dist, tests, loop


def test_simulated_participants_replay_from_their_stored_answers(demo_loop):
    table, dist, tests, loop = demo_loop
    assert not {q.env_index for q in loop.checks} & {t["env_index"] for t in tests}
    # the demo table leaves each of its 6 test clusters a check question (docs/teaching.md says so)
    assert len(loop.checks) == len(tests) == len(table.domain.test_clusters) == 6
    rng = np.random.default_rng(7)
    seen_answers, caught = set(), 0
    for learner in (SimulatedLearner("det-euclidean", lapse=0.3), SimulatedLearner("prob-reward", 1.0, 0.5),
                    SimulatedLearner("exact", lapse=0.9)):
        for _ in range(4):
            events, decisions = run_learner(loop, table, learner, rng, dist)
            kinds = [e.kind for e in events]
            assert kinds.count(EXAMPLE) <= 6 and kinds.count(CHECK) == kinds.count(FEEDBACK) <= 3
            assert not {e.env_index for e in events if e.kind == EXAMPLE} & {t["env_index"] for t in tests}
            seen_answers.update(e.answer for e in events if e.kind == CHECK)
            # stored as JSON, read back: every decision recomputed from the events alone
            stored = json.loads(json.dumps({"events": [e.as_dict() for e in events],
                                            "decisions": [d.as_dict() for d in decisions]}))
            ev = [Event.from_dict(e) for e in stored["events"]]
            de = [Decision.from_dict(d) for d in stored["decisions"]]
            assert loop.replay(ev, de) == []
            # another answer to a check is caught by the replay, wherever it would have changed the belief
            # (where every θ still believed in guesses on a check, its answer cannot matter)
            for i, e in enumerate(ev):
                if e.kind != CHECK:
                    continue
                for other in set(range(len(loop.checks[e.question].options))) - {e.answer}:
                    altered = [*ev[:i], Event(CHECK, e.env_index, e.question, other), *ev[i + 1:]]
                    if loop.decide(altered[:i + 1]) != de[i + 1]:
                        assert loop.replay(altered, de)
                        caught += 1
    assert len(seen_answers) > 1 and caught > 10  # the answers did vary, and mattered


def test_the_comparison_bench_writes_its_section_from_its_own_figures(tmp_path):
    """bench/closedloop.py on a small synthetic table: a row per distinct learner model, and the document's
    section rewritten between its markers from the JSON it printed."""
    synthetic_table(200, 40, n_candidates=6, seed=8).save(tmp_path / "table")
    doc = tmp_path / "results.md"
    doc.write_text("# Results\n\nkept\n\n<!-- bench/closedloop.py: begin -->\nold\n<!-- bench/closedloop.py: end -->\n")
    bench = Path(__file__).resolve().parents[3] / "bench" / "closedloop.py"
    out = subprocess.run([sys.executable, str(bench), "--table", str(tmp_path / "table"), "--participants", "4",
                          "--json", str(tmp_path / "cl.json"), "--update-doc", str(doc)],
                         capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    fig = json.loads((tmp_path / "cl.json").read_text())
    assert [r["model"] for r in fig["rows"]] == ["exact", "det-reward", "det-euclidean", "det-strategy",
                                                 "prob-reward", "prob-euclidean", "hierarchical"]
    for r in fig["rows"]:
        assert 0.25 * 0.1 <= r["approx*"] <= 1 and all(0 <= c["mean"] <= 1 for c in r["closed"].values())
        assert all(c["sequences"] >= 1 for c in r["closed"].values())
    text = doc.read_text()
    assert "kept" in text and "old" not in text and "## Closed-loop teaching on simulated learners" in text
    first = fig["rows"][0]
    assert f"| {first['learner']} | {first['approx*']:.3f} | {first['coverage-approx*']:.3f} |" in text
    assert f"p95 {fig['latency_ms']['p95']:.2f} ms" in text


def test_a_pack_on_disk_decides_as_the_loop_it_was_written_from(tiny_table, tmp_path):
    """What a web worker maps (closedloop_pack): the same decisions, θ*'s own trajectories, read-only maps."""
    table = TrajectoryTable.load(tiny_table)
    dist = Distances(table)
    tests = select_test_set(table, [], seed=0, skip_missing=True)
    loop = ClosedLoop.build(table, ClosedLoopSpec(model="prob-reward", value=1.0, max_examples=4, check_every=1),
                            check_questions(table, select_checks(table, tests)),
                            exclude=[t["env_index"] for t in tests], dist=dist)
    assert write_pack(tmp_path / "pack", table, loop) == table.meta["content_hash"]
    pack = load_pack(tmp_path / "pack", expected_hash=table.meta["content_hash"])
    assert isinstance(pack.loop.lik, np.memmap) and not pack.loop.lik.flags.writeable
    rng = np.random.default_rng(3)
    for _ in range(5):
        events, decisions = run_learner(loop, table, SimulatedLearner("prob-euclidean", 1.0, 0.3), rng, dist)
        assert pack.loop.replay(events, decisions) == []
    star = table.theta_star_index
    for i in (0, 7, table.n_envs - 1):
        np.testing.assert_array_equal(pack.star_states[i], table.states(i, star))
        assert pack.row_of(int(table.env_ids[i])) == i and pack.star_cluster[i] == table.strategy[i, star]
    with pytest.raises(ClosedLoopError, match="built on table"):
        load_pack(tmp_path / "pack", expected_hash="0" * 64)
    with pytest.raises(ClosedLoopError, match="no closed-loop condition at"):
        load_pack(tmp_path / "nothing")
    (tmp_path / "pack" / "lik.npy").unlink()
    with pytest.raises(ClosedLoopError, match="incomplete or corrupt"):
        load_pack(tmp_path / "pack")
