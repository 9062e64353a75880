"""Benchmark: closed-loop teaching against the open-loop approx* and coverage-approx* sequences, on
simulated learners of every model, and how long one decision takes.

    .venv/bin/python bench/closedloop.py --table var/tables/demo [--participants 200] \\
        [--json docs/bench_closedloop.json] [--update-doc docs/results.md]

The design is a study built on --table with seed 0 (python -m teaching teach's nine conditions, select_test_set's
final tests); the closed loop's check questions are select_checks' (apart from the final tests).  The robot
assumes approx* (det-euclidean at the τ the paper's rule picks) with a lapse rate of 0.1 and may show as
many examples as approx*'s open-loop sequence has, a check after every 2, with and without feedback.

Each simulated learner learns by its own model (every distinct one, at the τ / λ the paper's rule picks)
and answers with a lapse rate of 0.1 (teaching.core.simulate).  Its score in a condition is its expected
accuracy on the final tests: P(θ*'s option) by the choice model after everything it was shown (examples
and feedback), averaged over the tests.  The open-loop sequences are the same for everyone, so their score
is exact; the closed loop depends on the check answers drawn, so it is averaged over --participants
simulated participants (± its standard error).  Decision latency: every decision the closed-loop
participants needed, timed one by one in this process (p50 / p95 / max), with the likelihood matrix's
size: the shared read-only array each web worker would map.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench.doc_section import rewrite_section
from bench.fitting import design, generators
from teaching.core.closedloop import (
    CHECK,
    DONE,
    EXAMPLE,
    FEEDBACK,
    ClosedLoop,
    ClosedLoopSpec,
    check_questions,
    run_learner,
    select_checks,
)
from teaching.core.learners import Distances
from teaching.core.selection import APPROX_STAR
from teaching.core.simulate import AnswerModel, SimulatedLearner
from teaching.core.table import TrajectoryTable

LAPSE = 0.1
CHECK_EVERY = 2
BEGIN, END = "<!-- bench/closedloop.py: begin -->", "<!-- bench/closedloop.py: end -->"


def accuracy(answers: AnswerModel, star: np.ndarray, shown) -> float:
    """Expected share of final tests answered with θ*'s option after `shown` (table rows)."""
    p = answers.probabilities(tuple(int(e) for e in shown))
    return float(p[np.arange(len(star)), star].mean())


# (the model the robot assumes, feedback, η: the chance an example was not taken in)
VARIANTS = (("det-euclidean", True, 0.1), ("det-euclidean", False, 0.1), ("prob-euclidean", True, 0.1),
            ("det-euclidean", True, 0.0))


def comparison(table, participants: int, seed: int = 0) -> dict:
    sequences, tests, result = design(table)
    ids = np.asarray(table.env_ids)
    test_dicts = [{"env_id": int(ids[t.env_index])} for t in tests]
    star = np.array([t.options.index(0) for t in tests])
    checks = check_questions(table, select_checks(table, test_dicts))
    dist = Distances(table)
    n_examples = len(sequences[APPROX_STAR])
    loops = {}
    for model, feedback, eta in VARIANTS:
        spec = ClosedLoopSpec(model=model, value=result.models[model].value, lapse=LAPSE, example_lapse=eta,
                              max_examples=n_examples, check_every=CHECK_EVERY, feedback=feedback)
        loops[variant_label(model, feedback, eta)] = ClosedLoop.build(table, spec, checks,
                                                                 exclude=[t.env_index for t in tests], dist=dist)
    learners = {name: SimulatedLearner(g.model, g.value, LAPSE) for name, g in generators(table, result).items()}
    rng = np.random.default_rng(seed)
    rows, latencies = [], []
    for name, learner in learners.items():
        answers = AnswerModel(table, learner, tests, dist)
        row = {"learner": str(learner), "model": name,
               "approx*": accuracy(answers, star, sequences[APPROX_STAR]),
               "coverage-approx*": accuracy(answers, star, sequences["coverage-approx*"]), "closed": {}}
        for label, loop in loops.items():
            scores, shown_n, checks_right, seen = [], [], [], set()
            for _ in range(participants):
                events, decisions = run_learner(loop, table, learner, rng, dist)
                shown = [e.env_index for e in events if e.kind in (EXAMPLE, FEEDBACK)]
                seen.add(tuple(shown))
                scores.append(accuracy(answers, star, shown))
                shown_n.append(sum(e.kind == EXAMPLE for e in events))
                checks_right.extend(loop.checks[e.question].options[e.answer] == 0 for e in events if e.kind == CHECK)
            row["closed"][label] = {"mean": float(np.mean(scores)),
                                    "se": float(np.std(scores, ddof=1) / np.sqrt(len(scores))),
                                    "examples": float(np.mean(shown_n)), "sequences": len(seen),
                                    "checks_right": float(np.mean(checks_right)) if checks_right else None}
        rows.append(row)
        print(f"{name:16s} approx* {row['approx*']:.3f}  coverage-approx* {row['coverage-approx*']:.3f}  "
              + "  ".join(f"{label} {c['mean']:.3f} ± {c['se']:.3f} ({c['sequences']} sequences)"
                          for label, c in row["closed"].items()))
        # the latency of every decision one participant of this learner needed, recomputed from its events
        for loop in loops.values():
            events, _ = run_learner(loop, table, learner, rng, dist)
            for s in range(len(events) + 1):
                t0 = time.perf_counter()
                d = loop.decide(events[:s])
                latencies.append(time.perf_counter() - t0)
                assert s < len(events) or d.kind == DONE
    ms = np.array(latencies) * 1e3
    first = next(iter(loops.values()))
    return {"table": table.meta["content_hash"], "n_envs": table.n_envs, "n_thetas": table.n_thetas,
            "participants": participants, "lapse": LAPSE, "check_every": CHECK_EVERY, "max_examples": n_examples,
            "robots": {label: str(loop.spec.learner_model) for label, loop in loops.items()},
            "checks": len(checks), "rows": rows,
            "latency_ms": {"n": len(ms), "p50": float(np.percentile(ms, 50)), "p95": float(np.percentile(ms, 95)),
                           "max": float(ms.max())},
            "lik_mb": first.lik.nbytes / 2**20}


def variant_label(model: str, feedback: bool, eta: float) -> str:
    return f"closed loop ({model}, {'feedback' if feedback else 'no feedback'}, η = {eta:g})"


def markdown(fig: dict) -> str:
    lat = fig["latency_ms"]
    labels = list(fig["rows"][0]["closed"])
    robots = "; ".join(f"{label}: {robot}" for label, robot in fig["robots"].items())
    lines = [BEGIN, "", "## Closed-loop teaching on simulated learners", "",
             f"Generated by `bench/closedloop.py` on the table {fig['table'][:16]} ({fig['n_envs']:,} environments × "
             f"{fig['n_thetas']:,} θ).  Each closed loop shows at most {fig['max_examples']} examples (approx\\*'s "
             f"open-loop length), with a check question after every {fig['check_every']} "
             f"({fig['checks']} reserved apart from the final tests), the robot assuming a lapse rate of "
             f"{fig['lapse']} for check answers, η for examples (the chance one was not taken in) and the learner "
             f"model named ({robots}).  Each simulated learner learns by its own "
             f"model and answers with a lapse rate of {fig['lapse']}.", "",
             f"Cells: expected accuracy on the final tests (P(θ\\*'s option)).  Closed loops: mean ± standard error "
             f"over {fig['participants']} simulated participants, then the number of distinct sequences they saw "
             f"(1: the answers never changed what the robot showed), the mean number of examples (feedback not "
             f"counted) and the share of checks answered right.", "",
             "| learner | approx\\* | coverage-approx\\* | " + " | ".join(labels) + " |",
             "|---|---|---|" + "---|" * len(labels)]
    for r in fig["rows"]:
        cells = [f"{r['approx*']:.3f}", f"{r['coverage-approx*']:.3f}"]
        for label in labels:
            c = r["closed"][label]
            right = "—" if c["checks_right"] is None else f"{c['checks_right']:.2f}"
            cells.append(f"{c['mean']:.3f} ± {c['se']:.3f} ({c['sequences']} seq., {c['examples']:.1f} ex., "
                         f"{right} right)")
        lines.append(f"| {r['learner']} | " + " | ".join(cells) + " |")
    lines += ["", f"One decision took p50 {lat['p50']:.2f} ms, p95 {lat['p95']:.2f} ms, max {lat['max']:.2f} ms "
              f"({lat['n']} decisions, one process); the likelihood matrix a web worker maps read-only is "
              f"{fig['lik_mb']:.1f} MB.", "", END]
    return "\n".join(lines)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--table", default="var/tables/demo")
    p.add_argument("--participants", type=int, default=200)
    p.add_argument("--json", default=None)
    p.add_argument("--update-doc", default=None, help="rewrite this document's generated section from --json")
    args = p.parse_args()
    figures = comparison(TrajectoryTable.load(args.table), args.participants)
    lat = figures["latency_ms"]
    print(f"decision latency: p50 {lat['p50']:.2f} ms, p95 {lat['p95']:.2f} ms, max {lat['max']:.2f} ms "
          f"over {lat['n']} decisions; likelihood matrix {figures['lik_mb']:.1f} MB")
    if args.json:
        Path(args.json).write_text(json.dumps(figures, indent=1))
        if args.update_doc:
            rewrite_section(Path(args.json), Path(args.update_doc), BEGIN, END, markdown, "closed-loop teaching")


if __name__ == "__main__":
    main()
