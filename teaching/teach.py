"""Command line: teaching sequences, test set and ideal-user analysis for one table.

    python -m teaching teach --table var/tables/demo --out var/teaching/demo

writes to --out (the format: teaching/core/teachout.py, which also reads it):
    sequences.json             every condition's environment ids, P(θ*) curve, chosen τ/λ and sweeps
    test_set.json              the 6 test environments and their 4 options (with --test-difficulty,
                               each test's difficulty, exact BEC size and the tertiles it was graded
                               by, also printed one line a test);
                               with --tests show, one "show the way" environment per test cluster
                               (teaching/core/showtests.py) and no options
    matrix.json                ideal-user matrix P_M(θ* | sequence for M'), rows = sequences
    examples_per_cluster.json  2 × 4 cluster grids per sequence
    sim_users.png, examples_shown.png

--selector NAME[:KEY=VALUE,...] (repeatable) adds a registered selector's sequence to the
conditions under that label (with its selector and parameters), to the extended matrix, the
cluster grids and the pilot's predictions; the test set keeps clear of it too.

Bad input (unknown model, τ/λ <= 0, a table without θ*, no environments,
an unreadable table, a table with no valid test set, a selector with nothing to choose) prints one
line to stderr and exits with status 2; an unknown
selector or a bad parameter is refused by the argument parser (one line, status 2).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from .core.bec import BECError
from .core.conditions import teach
from .core.difficulty import DIFFICULTIES, describe
from .core.evaluation import SEQUENCE_NAMES, USER_NAMES, examples_per_cluster, grid_layout, ideal_user_matrix
from .core.learners import Distances, model_names, parse_hyperparameters
from .core.selection import APPROX_STAR, CONDITIONS, COVERAGE_EPSILON, SelectionSettings, theta_star_clusters
from .core.selectors import parse_selector, selector_names
from .core.showtests import SHOW, select_show_tests
from .core.simulate import pilot_predictions
from .core.table import TableError, TrajectoryTable
from .core.teachout import TEST_KINDS, write_json
from .core.testset import MIN_REGRET, TestSetError, select_test_set

EXIT_BAD_INPUT = 2


class InputError(ValueError):
    """Bad command-line input: reported in one line, exit status 2."""


DESCRIPTION = __doc__.split("\n\n")[0].removeprefix("Command line: ")


def add_arguments(p: argparse.ArgumentParser) -> None:
    """The teach command's options, on `python -m teaching teach`'s sub-parser."""
    p.add_argument("--table", required=True, help="trajectory table directory")
    p.add_argument("--out", required=True, help="output directory")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--approx-star", default=APPROX_STAR, help="model that coverage-approx* augments")
    p.add_argument("--hyper", action="append", default=[], metavar="MODEL=VALUE",
                   help="fix τ or λ of a model instead of sweeping (repeatable)")
    p.add_argument("--epsilon", type=float, default=COVERAGE_EPSILON, help="coverage gain threshold ε")
    p.add_argument("--min-regret", type=float, default=MIN_REGRET)
    p.add_argument("--min-option-distance", type=float, default=None,
                   help="test options at least this far apart (default: the table's domain's; the car: 0.5)")
    p.add_argument("--selector", action="append", default=[], type=_selector, metavar="NAME[:KEY=VALUE,...]",
                   help="add the sequence of a registered selector to the conditions, e.g. scot, bec-scaffold:k=2, "
                        f"highlights:k=5 (repeatable; one of {', '.join(selector_names())})")
    p.add_argument("--test-difficulty", choices=DIFFICULTIES, default=None,
                   help="draw every test among environments of this difficulty: tertiles of the exact BEC size of "
                        "the eligible test environments, low = large BEC = easy (docs/teaching.md, 'Test set'); "
                        "each test then records its difficulty and BEC size, choice and show tests alike")
    p.add_argument("--tests", choices=TEST_KINDS, default="choose",
                   help="choose: each test asks which of 4 trajectories the robot takes; show: each test asks the "
                        "participant to move the robot, scored by its regret under θ* (docs/teaching.md, "
                        "'Show-the-way tests')")
    p.add_argument("--no-progress", action="store_true")


def parse_args(argv=None) -> argparse.Namespace:
    p = argparse.ArgumentParser(prog="python -m teaching teach", description=DESCRIPTION)
    add_arguments(p)
    return p.parse_args(argv)


def _selector(spec: str) -> tuple[str, str, dict]:
    """--selector NAME[:KEY=VALUE,...] -> (label, name, parameters); argparse reports a bad one in one line."""
    try:
        return parse_selector(spec)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def parse_hyper(items: list[str]) -> dict[str, float]:
    """--hyper MODEL=VALUE items (teaching.core.learners.parse_hyperparameters), bad ones as InputError."""
    try:
        return parse_hyperparameters(items)
    except ValueError as exc:
        raise InputError(str(exc)) from None


def check_table(table) -> None:
    """Refuse tables the selectors cannot use."""
    if table.n_envs == 0:
        raise InputError("the table has no environments (empty environment set)")
    if table.n_thetas == 0:
        raise InputError("the table has no candidate objectives θ (it must contain θ* as theta 0)")
    expected = np.asarray(table.meta.get("theta_star", table.domain.theta_star), np.float64)
    if not np.allclose(np.asarray(table.thetas[0]), expected):
        raise InputError(f"the table does not contain θ* as theta 0: "
                         f"thetas[0] = {np.asarray(table.thetas[0]).tolist()}, θ* = {expected.tolist()}")


def run(args) -> dict:
    hyper = parse_hyper(args.hyper)
    if args.approx_star not in model_names():
        raise InputError(f"--approx-star: unknown learner model {args.approx_star!r}; "
                         f"choose from {', '.join(model_names())}")
    if not args.epsilon > 0:
        raise InputError(f"--epsilon must be > 0, got {args.epsilon}")
    try:
        table = TrajectoryTable.load(args.table)
    except TableError as exc:
        raise InputError(str(exc)) from None
    check_table(table)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)

    dist = Distances(table)
    added = {label: (name, params) for label, name, params in args.selector}
    try:
        result = teach(table, seed=args.seed, approx_star=args.approx_star, hyperparameters=hyper,
                       settings=SelectionSettings(epsilon=args.epsilon), progress=not args.no_progress, dist=dist,
                       added=added)
    except ValueError as exc:
        raise InputError(str(exc)) from None
    conditions = CONDITIONS + tuple(added)
    ids = np.asarray(table.env_ids)
    envs = {k: s.envs for k, s in result.sequences.items()}
    seq_json = {
        "table": {"path": str(args.table), "content_hash": table.meta.get("content_hash"),
                  "envs": table.n_envs, "thetas": table.n_thetas},
        "seed": args.seed, "approx_star": args.approx_star, "epsilon": args.epsilon,
        "conditions": {**{k: _seq_json(result.sequences[k], ids) for k in CONDITIONS},
                       **{k: {**_seq_json(result.sequences[k], ids), "selector": name, "params": params}
                          for k, (name, params) in added.items()}},
        "model_sequences": {k: _seq_json(result.sequences[k], ids) for k in USER_NAMES},
        "hyperparameters": {k: {"param": m.param, "value": m.value, "rule_met": result.rule_met.get(k),
                                "fixed": k in hyper,
                                "sweep": [{"value": r.value, "n_examples": len(r.sequence.envs),
                                           "n_unique": r.sequence.n_unique, "p": r.sequence.p}
                                          for r in result.sweeps.get(k, [])]}
                            for k, m in result.models.items()},
    }
    write_json(out / "sequences.json", seq_json)

    try:
        # disjoint from what the study's conditions train on (the paper's nine and every --selector;
        # every learner's sequence but the hierarchical one is a condition's: adding that learner left
        # the test set as it was)
        training = [ids[envs[c]].tolist() for c in conditions]
        if args.tests == SHOW:
            tests = select_show_tests(table, training, seed=args.seed, min_regret=args.min_regret,
                                      difficulty=args.test_difficulty)
        else:
            tests = select_test_set(table, training, seed=args.seed, min_regret=args.min_regret,
                                    min_distance=args.min_option_distance, difficulty=args.test_difficulty)
        for line in describe(tests):  # the levels, with the sizes and tertiles they come from
            print(line)
    except TestSetError as exc:
        tests = {"error": str(exc)}
    except BECError as exc:  # grading needs θ*'s sign-constrained space
        raise InputError(f"--test-difficulty: {exc}") from None
    write_json(out / "test_set.json", tests)

    matrix = ideal_user_matrix(result.models, envs, dist)
    ext_names = SEQUENCE_NAMES + ("coverage-approx*", "coverage-random") + tuple(added)
    extended = ideal_user_matrix(result.models, envs, dist, sequence_names=ext_names)
    pilot = {"sequence_names": list(SEQUENCE_NAMES), "user_names": list(USER_NAMES),
             "matrix": matrix.tolist(), "extended_sequence_names": list(ext_names),
             "extended_matrix": extended.tolist(), "models": {k: str(m) for k, m in result.models.items()}}
    # what learners of each model choose among a test's options, for a study's pilot (a show test has none)
    if "error" not in tests and args.tests == "choose":
        pilot["predicted"] = pilot_predictions(table, {u: result.models[u] for u in USER_NAMES},
                                               {n: envs[n] for n in ext_names}, tests, dist)
    write_json(out / "matrix.json", pilot)
    domain = table.domain
    grids = examples_per_cluster(theta_star_clusters(table), envs, ext_names, class_of_cluster=domain.class_of_cluster)
    write_json(out / "examples_per_cluster.json", {"layout": grid_layout(domain),
                                               "grids": {n: g.tolist() for n, g in zip(ext_names, grids, strict=True)}})
    # matplotlib loads only when figures are drawn
    from .core.plots import plot_examples_shown, plot_ideal_users  # noqa: PLC0415

    plot_ideal_users(matrix, SEQUENCE_NAMES, USER_NAMES, out / "sim_users.png")
    plot_examples_shown(grids[:len(SEQUENCE_NAMES)], SEQUENCE_NAMES, out / "examples_shown.png", domain)
    if "error" in tests:  # everything else is written; the study cannot run without tests
        raise InputError(f"test set: {tests['error']} (other outputs were written to {out})")
    return {"sequences": seq_json, "test_set": tests, "matrix": matrix}


def _seq_json(seq, ids) -> dict:
    return {"env_ids": [int(i) for i in ids[seq.envs]], "p_theta_star": seq.p,
            "added_for_coverage": [int(i) for i in ids[seq.added_for_coverage]]}


def command(args: argparse.Namespace) -> int:
    """`python -m teaching teach`: run, then exit status 0, or 2 with one line for bad input."""
    try:
        run(args)
    except InputError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    print(f"wrote {args.out}")
    return 0


def main(argv=None) -> int:
    return command(parse_args(argv))


if __name__ == "__main__":  # the older spelling, `python -m teaching.teach`, which saved outputs still quote
    sys.exit(main())
