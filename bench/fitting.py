"""Benchmark: model and parameter recovery on a study's design, and the cost of fitting every model.

    .venv/bin/python bench/fitting.py --table var/tables/demo --paper-table var/tables/paper \\
        [--reps 25] [--json docs/bench_fitting.json] [--update-doc docs/analysis.md]
    .venv/bin/python bench/fitting.py --paper-only --paper-table var/tables/paper --json docs/bench_fitting.json
        # adds the paper table's figures to an earlier run's recovery figures (that table takes ~50 min to build)
    .venv/bin/python bench/fitting.py --merge A.json B.json --json docs/bench_fitting.json --update-doc docs/analysis.md
        # joins runs of disjoint --generators (e.g. run on two machines) into one set of figures

The design is what a study built on --table gets (teaching.build_sequences' nine conditions and
select_test_set's test set, seed 0).  Every distinct learner model generates --reps simulated studies of
161 (the paper's analysed participants) and 500 participants at the τ / λ the paper's rule picks and a
lapse rate of 0.15 (teaching.core.recovery); each study is fitted with every model.  Then 500 participants
on --paper-table are fitted with every model in a child process on this machine's cores, timed, with its
peak resident memory (bars: <= 60 s on 2 cores, <= 4 GB).
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench.doc_section import rewrite_section
from teaching.core.answers import questions_of
from teaching.core.conditions import teach
from teaching.core.fitting import fit_models
from teaching.core.learners import Distances
from teaching.core.recovery import LAPSE_TOLERANCE, VALUE_TOLERANCE, model_recovery
from teaching.core.selection import CONDITIONS, fitted_model
from teaching.core.simulate import SimulatedLearner, simulate_answers
from teaching.core.table import TrajectoryTable
from teaching.core.testset import select_test_set

LAPSE = 0.15
SIZES = (161, 500)
# one generator per distinct model: prob-strategy predicts exactly what det-strategy does
GENERATORS = ("exact", "det-reward", "det-euclidean", "det-strategy", "prob-reward", "prob-euclidean", "hierarchical")
BEGIN, END = "<!-- bench/fitting.py: begin -->", "<!-- bench/fitting.py: end -->"


def design(table):
    """(sequences {condition: table rows}, tests [Question]) of a study built on `table` with seed 0."""
    result = teach(table)
    sequences = {c: result.sequences[c].envs for c in CONDITIONS}
    ids = np.asarray(table.env_ids)
    test_set = select_test_set(table, [[int(ids[e]) for e in s] for s in sequences.values()], 0)
    return sequences, list(questions_of(table, test_set)[0]), result


def generators(table, result) -> dict[str, SimulatedLearner]:
    """Each distinct model at the τ / λ the paper's rule picks on this table (hierarchical: swept the same way)."""
    dist = Distances(table)
    out = {}
    for name in GENERATORS:
        model = result.models.get(name) or fitted_model(name, dist, {})[0]
        out[name] = SimulatedLearner(name, model.value if model.param else None, LAPSE)
    return out


def recovery_figures(table, reps: int, only=None) -> dict:
    """Recovery of every generator, or of those named in `only` (the studies of a subset that starts with the
    first generator are the ones a full run draws for it: one random generator per size, in this order)."""
    sequences, tests, result = design(table)
    gens = {k: v for k, v in generators(table, result).items() if not only or k in only}
    out = {"table": table.meta["content_hash"], "reps": reps, "lapse": LAPSE,
           "generators": {k: str(v) for k, v in gens.items()}, "sizes": {}}
    for n in SIZES:
        t0 = time.perf_counter()
        rec = model_recovery(table, sequences, tests, gens, n, reps, seed=n)
        out["sizes"][str(n)] = {
            "seconds": time.perf_counter() - t0, "fitted": rec.fitted, "confusion": rec.confusion.tolist(),
            "unfitted": rec.unfitted, "ties": {g: [list(t) for t in rec.ties[g]] for g in gens},
            "recovered": {g: rec.recovered(g) for g in gens},
            "lapse_recovered": {g: rec.lapse_recovered(g) for g in gens},
            "value_recovered": {g: rec.value_recovered(g) for g in gens},
            "median_lapse": {g: float(np.median(rec.lapses[g])) if rec.lapses[g] else None for g in gens},
            "median_value": {g: float(np.median(rec.values[g])) if rec.values.get(g) else None for g in gens},
            "confused": rec.confused(),
        }
        print_recovery(n, out["sizes"][str(n)], gens)
    return out


def merge_recovery(parts: list[dict]) -> dict:
    """One figure set from runs of disjoint generators (--generators) on the same table, size and lapse
    rate, in the order given.  A subset run draws its studies from the same seeded stream as a full run
    only for the generators it starts with: the studies differ from a full run's, the design does not."""
    first = parts[0]
    for part in parts[1:]:
        for key in ("table", "reps", "lapse"):
            if part[key] != first[key]:
                raise SystemExit(f"--merge: the runs differ in {key} ({first[key]} != {part[key]})")
        if set(part["generators"]) & set(first["generators"]) or set(part["sizes"]) != set(first["sizes"]):
            raise SystemExit("--merge: the runs must be of disjoint generators at the same sizes")
    out = {k: first[k] for k in ("table", "reps", "lapse")}
    out["generators"] = {g: d for part in parts for g, d in part["generators"].items()}
    out["sizes"] = {}
    for n in first["sizes"]:
        sizes = [part["sizes"][n] for part in parts]
        merged = {"seconds": sum(s["seconds"] for s in sizes), "fitted": sizes[0]["fitted"],
                  "confusion": [row for s in sizes for row in s["confusion"]],
                  "confused": [c for s in sizes for c in s["confused"]]}
        for key in ("unfitted", "ties", "recovered", "lapse_recovered", "value_recovered", "median_lapse",
                    "median_value"):
            merged[key] = {g: v for s in sizes for g, v in s[key].items()}
        out["sizes"][n] = merged
    return out


def studies(fig: dict, g: str, row) -> int:
    """How many studies a generator's row stands for: won outright, tied at the top or fitted by none."""
    return sum(row) + fig["unfitted"][g] + len(fig.get("ties", {}).get(g, []))


def tie_summary(ties: list[list[str]]) -> str:
    """'exact, det-reward (3); ...': the sets of models tied at the top, with how many studies each."""
    counts = {}
    for t in ties:
        counts[", ".join(t)] = counts.get(", ".join(t), 0) + 1
    return "; ".join(f"{k} ({v})" for k, v in sorted(counts.items(), key=lambda kv: -kv[1]))


def print_recovery(n: int, fig: dict, gens) -> None:
    first = next(iter(gens))
    print(f"\nmodel recovery, {n} participants, {studies(fig, first, fig['confusion'][0])} studies per generator "
          f"({fig['seconds']:.0f} s): share of studies each fitted model won outright, and tied at the top")
    short = [label.replace(" = prob-strategy", "=") for label in fig["fitted"]]
    print(f"{'generated by':16s}" + "".join(f"{s[:13]:>14s}" for s in short) + f"{'tied':>8s}")
    for g, row in zip(gens, fig["confusion"], strict=True):
        reps = studies(fig, g, row)
        print(f"{g:16s}" + "".join(f"{c / reps:14.2f}" for c in row) + f"{len(fig['ties'][g]) / reps:8.2f}")
    for g in gens:
        if fig["ties"][g]:
            print(f"  {g}: tied at the top: {tie_summary(fig['ties'][g])}")
    print(f"\nparameter recovery (share within ±{LAPSE_TOLERANCE} of ε = {LAPSE}, "
          f"within {VALUE_TOLERANCE:g} decade of τ / λ):")
    for g, learner in gens.items():
        v = fig["value_recovered"][g]
        print(f"  {g:16s} ε {fig['lapse_recovered'][g]:.2f} (median {fig['median_lapse'][g]:.3f})   "
              + (f"{learner.learner_model.param} {v:.2f} (true {learner.value:g}, median "
                 f"{fig['median_value'][g]:.3g})" if v is not None else "no τ / λ"))
    for g, f, share in fig["confused"]:
        print(f"  cannot tell apart: {g} won by {f} in {share:.0%} of its studies")


def paper_fit(table_path: str) -> dict:
    """Simulate 500 det-euclidean participants on the paper table; time fitting every model (child)."""
    table = TrajectoryTable.load(table_path)
    sequences, tests, result = design(table)
    learner = SimulatedLearner("det-euclidean", result.models["det-euclidean"].value, LAPSE)
    answers = simulate_answers(table, learner, sequences, tests, 500, np.random.default_rng(0))
    t0 = time.perf_counter()
    fits = fit_models(table, answers)
    seconds = time.perf_counter() - t0
    return {"seconds": seconds, "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
            "models": len(fits), "best": fits[0].label, "cores": len(os.sched_getaffinity(0)),
            "table": table.meta["content_hash"], "n_envs": table.n_envs, "n_thetas": table.n_thetas}


def markdown(fig: dict) -> str:
    lines = [BEGIN, "", f"Generated by `bench/fitting.py` on the demo table ({fig['recovery']['table']}), "
             f"{fig['recovery']['reps']} simulated studies per generating model and size, lapse rate "
             f"{fig['recovery']['lapse']}:", ""]
    for n, s in fig["recovery"]["sizes"].items():
        labels = s["fitted"]
        lines += [f"**{n} participants** — share of studies each model won outright, and share whose best models "
                  "tied (cross-validated log-likelihoods within 1e-6: won by none; rows: the model that generated "
                  "them)", "",
                  "| generated by | " + " | ".join(labels) + " | tied | ε recovered | τ / λ recovered |",
                  "|---|" + "---|" * (len(labels) + 3)]
        for g, row in zip(fig["recovery"]["generators"], s["confusion"], strict=True):
            reps = studies(s, g, row)
            v = s["value_recovered"][g]
            lines.append(f"| {g} | " + " | ".join(f"{c / reps:.2f}" for c in row)
                         + f" | {len(s['ties'][g]) / reps:.2f} | {s['lapse_recovered'][g]:.2f} | "
                         + f"{'—' if v is None else f'{v:.2f}'} |")
        confused = "; ".join(f"{g} → {f} ({share:.0%})" for g, f, share in s["confused"]) or "none"
        tied = "; ".join(f"{g}: {tie_summary(s['ties'][g])}" for g in fig["recovery"]["generators"] if s["ties"][g])
        lines += ["", f"Pairs this design cannot tell apart at {n} (a wrong model wins ≥ 25 %): {confused}.",
                  f"Tied at the top (studies): {tied or 'none'}.", ""]
    p = fig.get("paper")
    if p:
        lines += [f"Fitting every model to 500 participants on the paper table ({p['n_envs']:,} × {p['n_thetas']:,}, "
                  f"{p['table']}) took **{p['seconds']:.1f} s** on {p['cores']} cores with a peak of "
                  f"**{p['peak_rss_mb'] / 1024:.2f} GB** resident (bars: 60 s, 4 GB).", ""]
    return "\n".join(lines + [END])


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--table", default="var/tables/demo")
    p.add_argument("--paper-table", default=None)
    p.add_argument("--reps", type=int, default=25)
    p.add_argument("--generators", default=None,
                   help="comma-separated generators to simulate (default: every one; such a run: its own --json)")
    p.add_argument("--json", default=None)
    p.add_argument("--update-doc", default=None, help="rewrite this document's generated section from --json")
    p.add_argument("--paper-only", action="store_true",
                   help="keep the recovery figures of --json and (re)measure only the paper table's fit")
    p.add_argument("--merge", nargs="+", metavar="JSON", default=None,
                   help="no run: join the recovery figures of --generators runs into --json (keeping the paper "
                        "table's figures --json already holds)")
    p.add_argument("--paper-child", default=None, help=argparse.SUPPRESS)
    args = p.parse_args()
    if args.merge:
        if not args.json:
            p.error("--merge needs --json, the file to write")
        parts = [json.loads(Path(f).read_text())["recovery"] for f in args.merge]
        figures = {"recovery": merge_recovery(parts)}
        earlier = json.loads(Path(args.json).read_text()) if Path(args.json).exists() else {}
        if "paper" in earlier:
            figures["paper"] = earlier["paper"]
        Path(args.json).write_text(json.dumps(figures, indent=1))
        if args.update_doc:
            rewrite_section(Path(args.json), Path(args.update_doc), BEGIN, END, markdown, "model fitting")
        return
    if args.paper_child:
        print(json.dumps(paper_fit(args.paper_child)))
        return
    if args.paper_only and not (args.json and Path(args.json).exists() and args.paper_table):
        p.error("--paper-only needs --paper-table and an earlier run's --json")
    figures = ({"recovery": json.loads(Path(args.json).read_text())["recovery"]} if args.paper_only
               else {"recovery": recovery_figures(TrajectoryTable.load(args.table), args.reps,
                                                  args.generators.split(",") if args.generators else None)})
    if args.paper_table:
        child = subprocess.run([sys.executable, __file__, "--paper-child", args.paper_table], check=True,
                               capture_output=True, text=True)
        figures["paper"] = json.loads(child.stdout.strip().splitlines()[-1])
        f = figures["paper"]
        print(f"\npaper table: every model fitted to 500 participants in {f['seconds']:.1f} s on {f['cores']} cores, "
              f"peak RSS {f['peak_rss_mb'] / 1024:.2f} GB (bars 60 s, 4 GB); best: {f['best']}")
    if args.json:
        Path(args.json).write_text(json.dumps(figures, indent=1))
        if args.update_doc:
            rewrite_section(Path(args.json), Path(args.update_doc), BEGIN, END, markdown, "model fitting")


if __name__ == "__main__":
    main()
