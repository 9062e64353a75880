"""Closed-loop checks where the participant shows the way (teaching.core.closedloop, Question.shown), on
the augmented taxi's tiny table (a world from a file, tests/teaching/domains/worlds/shipped.py).

* A shown check's options are every distinct trajectory the table's θ take there, found here by grouping
  the stored trajectories in plain Python.
* Showing one of them updates the belief exactly as choosing that option among all of them (the choice
  model's likelihood, computed here from answer_likelihood on the same options); a way none of them takes
  leaves the belief as it was.
* A pack with shown checks of different sizes decides as the loop it was written from, and simulated
  participants replay.
"""
from __future__ import annotations

import numpy as np
import pytest

from teaching.core.choice import OptionDistances
from teaching.core.closedloop import (
    CHECK,
    ClosedLoop,
    ClosedLoopSpec,
    Event,
    answer_likelihood,
    check_questions,
    distinct_ways,
    run_learner,
    select_show_checks,
)
from teaching.core.closedloop_pack import load_pack, write_pack
from teaching.core.learners import Distances
from teaching.core.showtests import select_show_tests
from teaching.core.simulate import SimulatedLearner
from teaching.core.table import TrajectoryTable
from tests.teaching.domains.worlds.shipped import shipped, tiny_table

SPEC = ClosedLoopSpec(model="prob-euclidean", value=1.0, lapse=0.1, max_examples=4, check_every=1)


@pytest.fixture(scope="module")
def taxi(tmp_path_factory):
    with shipped("taxi") as domain:
        table = TrajectoryTable.load(tiny_table(tmp_path_factory, domain))
        finals = select_show_tests(table, [], seed=0)
        checks = select_show_checks(table, finals)
        yield table, finals, checks


def test_a_shown_checks_options_are_the_distinct_trajectories_there(taxi):
    table, finals, checks = taxi
    assert checks and not {c["env_id"] for c in checks} & {t["env_id"] for t in finals}
    for row in range(table.n_envs):
        first_of = {}
        for theta in range(table.n_thetas):
            first_of.setdefault(tuple(np.asarray(table.controls[row, theta]).ravel().tolist()), theta)
        assert distinct_ways(table, row) == tuple(sorted(first_of.values()))
        assert distinct_ways(table, row)[0] == table.theta_star_index


def test_showing_a_way_updates_the_belief_as_choosing_it_and_an_unknown_way_not_at_all(taxi):
    table, finals, checks = taxi
    questions = check_questions(table, checks)
    assert all(q.shown for q in questions)
    loop = ClosedLoop.build(table, SPEC, questions, exclude=[])
    q = questions[0]
    p = answer_likelihood(SPEC.learner_model.likelihood(OptionDistances(table, q.env_index, q.options)), SPEC.lapse)
    assert len(loop.check_lik[0]) == len(q.options) + 1
    example = [Event("example", int(np.flatnonzero(loop.eligible)[0]))]
    before = loop.weights(example).astype(np.float64)
    for k in range(len(q.options)):
        after = loop.weights([*example, Event(CHECK, q.env_index, 0, k)]).astype(np.float64)
        want = before * p[k]
        np.testing.assert_allclose(after / after.sum(), want / want.sum(), rtol=1e-5)
    unknown = loop.weights([*example, Event(CHECK, q.env_index, 0, len(q.options))]).astype(np.float64)
    np.testing.assert_allclose(unknown / unknown.sum(), before / before.sum(), rtol=1e-6)
    with pytest.raises(ValueError, match="is not an option"):
        loop.decide([*example, Event(CHECK, q.env_index, 0, len(q.options) + 1)])


def test_a_pack_with_shown_checks_decides_as_its_loop(taxi, tmp_path):
    table, finals, checks = taxi
    dist = Distances(table)
    row = {int(e): i for i, e in enumerate(np.asarray(table.env_ids))}
    loop = ClosedLoop.build(table, SPEC, check_questions(table, checks), exclude=[row[t["env_id"]] for t in finals],
                            dist=dist)
    write_pack(tmp_path / "pack", table, loop)
    pack = load_pack(tmp_path / "pack", expected_hash=table.meta["content_hash"])
    assert [q.shown for q in pack.loop.checks] == [True] * len(checks)
    assert [len(c) for c in pack.loop.check_lik] == [len(c) for c in loop.check_lik]
    rng = np.random.default_rng(5)
    for _ in range(4):
        events, decisions = run_learner(loop, table, SimulatedLearner("prob-euclidean", 1.0, 0.2), rng, dist)
        assert any(e.kind == CHECK for e in events)
        assert pack.loop.replay(events, decisions) == []
    unknown = [Event(d.kind, d.env_index, d.question, len(loop.checks[d.question].options) if d.kind == CHECK
                     else None) for d in decisions[:-1]]
    assert [d.kind for d in (pack.loop.decide(unknown[:i]) for i in range(len(unknown)))] == \
        [d.kind for d in (loop.decide(unknown[:i]) for i in range(len(unknown)))]
