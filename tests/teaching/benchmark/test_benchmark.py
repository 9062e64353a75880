"""The teaching benchmark (teaching/benchmark): a cell's learning curve checked by hand, its summary's interval by
hand, a run killed with SIGKILL and resumed byte for byte against an uninterrupted one, and a selector registered
later joining it with no other change."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from teaching.benchmark.cells import CRITERION, Cell, plan_cells
from teaching.benchmark.run import Runner, examples_to_criterion, run_cells, timed
from teaching.benchmark.summary import half_width, mismatch, mismatch_markdown, summarise
from teaching.core import selectors
from teaching.core.learners import LEARNER_NAMES
from teaching.core.selection import evaluated
from teaching.core.selectors import Selector, selector_names
from teaching.core.summaries import scot_cover
from teaching.core.table import TrajectoryTable
from tests.services import wait_until
from tests.teaching.core.hand_bec_table import hand_bec_table

ROOT = Path(__file__).resolve().parents[3]
KILL_AFTER = 400  # results on disk before the run is killed: well inside it, whatever the machine's speed
HANG = 600  # seconds: a hang guard, ten times what the whole run takes here


def test_scot_teaches_the_exact_learner_of_the_hand_table_at_its_covers_size(tmp_path):
    """hand_bec_table: SCOT's cover is E2, E3.  After E2 ((3,3) against (1,6)) the exact learner keeps θ*, u2 and
    u3 (u1 = (1,.1) prefers (1,6)): P(θ*) = 1/3; E3 rules out u2 ((9,0) costs it .9) and u3 ((5,1.5) costs it 4.5,
    θ*'s 4.8): P(θ*) = 1, at the cover's size."""
    table = hand_bec_table()
    cover, _ = scot_cover(table)
    [cell] = plan_cells("hand", selectors=["scot"], learners=["exact"], seeds=1)
    [result] = run_cells(table, [cell], tmp_path)
    assert result["env_ids"] == [12, 13] and len(cover) == 2
    assert result["p_theta_star"] == pytest.approx([1 / 3, 1.0], abs=1e-12)
    assert result["examples_to_criterion"] == len(cover) == 2


def test_examples_to_criterion_and_the_interval_by_hand():
    assert CRITERION == 0.5
    assert examples_to_criterion([0.2, 0.5, 0.9]) == 2 and examples_to_criterion([0.1, 0.49]) is None
    # two seeds, 0 and 1: mean 0.5, s = √0.5, t(0.975, 1) = 12.7062: half-width 12.7062 · √0.5 / √2 = 6.3531
    assert half_width(np.array([[0.0], [1.0]]))[0] == pytest.approx(6.3531, abs=1e-4)
    assert half_width(np.array([[0.3]]))[0] == 0.0


def test_a_summary_holds_a_shorter_curve_at_its_last_value_and_reports_a_refusal():
    cell = {"selector": "s", "learner": "exact"}
    results = [{"cell": cell, "key": "a", "p_theta_star": [0.5, 1.0], "examples_to_criterion": 1},
               {"cell": cell, "key": "b", "p_theta_star": [0.25, 0.5, 0.75], "examples_to_criterion": 2},
               {"cell": {"selector": "t", "learner": "exact"}, "key": "c", "error": "nothing to teach"}]
    row, refused = summarise(results, {"a": 1.0, "b": 3.0})
    assert row.curve == pytest.approx((0.375, 0.75, 0.875)) and row.final == pytest.approx(0.875)
    assert row.to_criterion == 1.5 and row.reached == 2 and row.selection_cost == 2.0  # the mean of the costs given
    assert refused.error == "nothing to teach" and refused.seeds == 1


def test_a_killed_run_resumes_to_the_bytes_of_an_uninterrupted_one(gridworld_tiny_table, tmp_path):
    """The command killed with SIGKILL once KILL_AFTER results are on disk, then run again: every result file is
    the uninterrupted run's, byte for byte, and none is missing or extra."""
    command = [sys.executable, "-m", "teaching", "benchmark", "--table", str(gridworld_tiny_table), "--seeds", "8",
               "--no-progress"]
    killed = tmp_path / "killed"
    run = subprocess.Popen([*command, "--out", str(killed)], cwd=ROOT, stdout=subprocess.DEVNULL,
                           stderr=subprocess.DEVNULL)
    wait_until(lambda: run.poll() is not None or len(list((killed / "cells").glob("*.json"))) >= KILL_AFTER, HANG,
               f"{KILL_AFTER} benchmark results on disk", poll=0.02)
    os.kill(run.pid, signal.SIGKILL)
    run.wait()
    cut = len(list((killed / "cells").glob("*.json")))
    n_cells = len(selector_names()) * len(LEARNER_NAMES) * 8
    assert KILL_AFTER <= cut < n_cells  # killed mid-way
    subprocess.run([*command, "--out", str(killed)], cwd=ROOT, check=True, capture_output=True, timeout=HANG)
    whole = tmp_path / "whole"
    subprocess.run([*command, "--out", str(whole)], cwd=ROOT, check=True, capture_output=True, timeout=HANG)
    files = sorted(p.name for p in (whole / "cells").glob("*.json"))
    assert len(files) == n_cells and sorted(p.name for p in (killed / "cells").glob("*.json")) == files
    assert all((killed / "cells" / f).read_bytes() == (whole / "cells" / f).read_bytes() for f in files)
    assert (killed / "summary.md").read_text().split("| selector |")[1:] != []


def test_a_selector_registered_later_joins_the_benchmark(monkeypatch, gridworld_tiny_table, tmp_path):
    """A toy selector (the first two showable environments) registered in the core: its rows appear, one per
    learner, with no other change."""
    monkeypatch.setattr(selectors, "_REGISTRY", dict(selectors._REGISTRY))
    def first_two(ctx):
        return evaluated([int(e) for e in np.flatnonzero(ctx.eligible)[:2]], ctx.fitted("exact")[0], ctx.dist)

    selectors.register_selector(Selector("toy-first-two", first_two))
    table = TrajectoryTable.load(gridworld_tiny_table)
    cells = plan_cells(table.meta["content_hash"], seeds=2)
    assert {c.selector for c in cells} == set(selector_names()) and "toy-first-two" in selector_names()
    rows = summarise(run_cells(table, [c for c in cells if c.selector in ("toy-first-two", "scot")], tmp_path))
    toy = [r for r in rows if r.selector == "toy-first-two"]
    assert [r.learner for r in toy] == list(LEARNER_NAMES) and all(len(r.curve) == 2 and r.seeds == 2 for r in toy)


def test_a_cells_key_changes_with_each_of_its_parts():
    base = Cell("h", "coverage-approx*", (("model", "det-euclidean"),), "exact", 0)
    others = [Cell("h2", *list(base.__dict__.values())[1:]), Cell("h", "scot", (), "exact", 0),
              Cell("h", "coverage-approx*", (("model", "exact"),), "exact", 0),
              Cell("h", "coverage-approx*", (("model", "det-euclidean"),), "det-reward", 0),
              Cell("h", "coverage-approx*", (("model", "det-euclidean"),), "exact", 1)]
    assert len({base.key, *(c.key for c in others)}) == 6 and base.key == Cell(*base.__dict__.values()).key
    with pytest.raises(ValueError, match="unknown selector 'nope'"):
        plan_cells("h", selectors=["nope"])
    with pytest.raises(ValueError, match="--seeds must be at least 1"):
        plan_cells("h", seeds=0)


def test_the_mismatch_matrix_puts_each_learners_own_selector_on_its_diagonal():
    """Rows: the selectors named after a learner (built for it); columns: the learners; by hand from three rows."""
    def result(selector, learner, p):
        return {"cell": {"selector": selector, "learner": learner}, "key": f"{selector}-{learner}",
                "p_theta_star": [p], "examples_to_criterion": None}

    rows = summarise([result("exact", "exact", 1.0), result("exact", "det-reward", 0.25),
                      result("det-reward", "exact", 0.5), result("det-reward", "det-reward", 0.75),
                      result("scot", "exact", 1.0)])
    built, learners, matrix = mismatch(rows)
    assert built == ["exact", "det-reward"] and learners == ["exact", "det-reward"]
    np.testing.assert_array_equal(matrix, [[1.0, 0.25], [0.5, 0.75]])
    assert "| det-reward | 0.500 | **0.750** |" in mismatch_markdown(rows)


def test_the_mismatch_matrix_is_teachs_ideal_user_matrix(gridworld_tiny_table, tmp_path):
    """The benchmark's matrix (one seed) against the one teach writes (teaching.core.evaluation) on the table the
    selectors teach from (the held-out tests' environments taken out), which sums each sequence's log-likelihoods at
    once where the benchmark's curve adds them example by example: equal to 1e-9 of a probability."""
    from teaching.core.conditions import teach  # noqa: PLC0415
    from teaching.core.evaluation import ideal_user_matrix  # noqa: PLC0415
    from teaching.core.learners import Distances  # noqa: PLC0415

    table = TrajectoryTable.load(gridworld_tiny_table)
    pool = Runner(table).table
    assert pool.n_envs < table.n_envs
    taught = teach(pool)
    expected = ideal_user_matrix(taught.models, {n: s.envs for n, s in taught.sequences.items()}, Distances(pool),
                                 sequence_names=LEARNER_NAMES, user_names=LEARNER_NAMES)
    cells = plan_cells(table.meta["content_hash"], selectors=LEARNER_NAMES, seeds=1)
    built, learners, matrix = mismatch(summarise(run_cells(table, cells, tmp_path)))
    assert built == learners == list(LEARNER_NAMES)
    np.testing.assert_allclose(matrix, expected, rtol=0, atol=1e-9)


SEEDS = 2000  # random-uniform's sequences averaged for its expected curve


def test_random_uniforms_mean_curve_is_its_closed_form(tmp_path):
    """The hand table with θ* and u3 = (.6, 1) alone: u3 keeps θ*'s way optimal in E0 ((3,3) costs it 4.8, (5,2)
    5.0) and E2 (4.8 against 6.6), not in E1 ((6,1) costs 4.6) nor E3 ((5,1.5) costs 4.5).  So after t uniform draws
    (repeats allowed) the exact learner still holds u3 with probability q^t, q = 1/2, and then P(θ*) = 1/2, else 1:
    E[P_t] = 1 - q^t / 2, and P_t's standard deviation is sqrt(q^t (1 - q^t)) / 2.  The mean over seeds 0 .. SEEDS - 1
    (fixed, so the check is too) is within 4 of that standard deviation's standard errors at every t."""
    full = hand_bec_table()
    keep = [0, 3]
    table = TrajectoryTable(thetas=full.thetas[keep], env_ids=full.env_ids, controls=full.controls[:, keep],
                            features=full.features[:, keep], strategy=full.strategy[:, keep],
                            d_euclid=full.d_euclid[:, keep], normalisers=full.normalisers, meta=full.meta)
    cells = plan_cells("hand-2", selectors=["random-uniform"], learners=["exact"], seeds=SEEDS)
    results = run_cells(table, cells, tmp_path)
    curves = np.array([r["p_theta_star"] for r in results])
    t = np.arange(1, curves.shape[1] + 1)
    closed = 1 - 0.5 ** t / 2
    se = np.sqrt(0.5 ** t * (1 - 0.5 ** t)) / 2 / np.sqrt(SEEDS)
    assert curves.shape == (SEEDS, 8) and set(np.unique(curves)) <= {0.5, 1.0}
    assert np.all(np.abs(curves.mean(axis=0) - closed) <= 4 * se + 1e-12), (curves.mean(axis=0), closed, se)


def test_a_runs_time_is_recorded_where_it_computed_cells_and_kept_where_it_computed_none(gridworld_tiny_table,
                                                                                      tmp_path):
    table = TrajectoryTable.load(gridworld_tiny_table)
    cells = plan_cells(table.meta["content_hash"], selectors=["scot"], seeds=1)
    record = tmp_path / "runs" / f"{table.meta['content_hash']}.json"
    first = timed(tmp_path, table.meta["content_hash"], cells, "in one process",
                  lambda: run_cells(table, cells, tmp_path))
    written = json.loads(record.read_text())
    assert written["computed"] == written["cells"] == len(cells) == len(LEARNER_NAMES)
    assert written["runner"] == "in one process" and written["seconds"] > 0 and written["cores"] >= 1
    again = timed(tmp_path, table.meta["content_hash"], cells, "on Celery workers",
                  lambda: run_cells(table, cells, tmp_path))
    assert again == first and json.loads(record.read_text()) == written  # nothing computed: the record stays


def test_a_fixed_tau_or_lambda_makes_other_cells_and_is_the_learners_own(gridworld_tiny_table, tmp_path):
    """--hyper det-reward=3 (say, what a fit found): new keys for every cell, det-reward's learner and its greedy
    selector use τ = 3, and a learner not named keeps the value the paper's rule chose."""
    table = TrajectoryTable.load(gridworld_tiny_table)
    rule = plan_cells(table.meta["content_hash"], selectors=["det-reward"], learners=["det-reward", "prob-reward"],
                      seeds=1)
    fixed = plan_cells(table.meta["content_hash"], selectors=["det-reward"], learners=["det-reward", "prob-reward"],
                       seeds=1, hyper={"det-reward": 3.0})
    assert not {c.key for c in rule} & {c.key for c in fixed}
    assert Cell.from_description(fixed[0].describe(), fixed[0].key) == fixed[0]
    by_rule, by_fit = run_cells(table, rule, tmp_path / "rule"), run_cells(table, fixed, tmp_path / "fit")
    assert by_fit[0]["learner_value"] == 3.0 and by_rule[0]["learner_value"] != 3.0
    assert by_fit[1]["learner_value"] == by_rule[1]["learner_value"]  # prob-reward: the rule's, as before
    assert by_fit[0]["cell"]["hyper"] == {"det-reward": 3.0} and "hyper" not in by_rule[0]["cell"]
    with pytest.raises(ValueError, match="hyperparameter must be a finite number > 0"):
        plan_cells("h", hyper={"det-reward": -1.0})
