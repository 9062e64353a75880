"""A table's benchmark results summarised per (selector, learner) over seeds.

For each pair: how many seeds; the mean P(θ*) after the whole sequence and after each example (a sequence shorter
than the longest holds its last value: the learner has seen all it will), each with its 95 % interval over seeds
(Student's t; none from a single seed, nor where every seed agrees); the mean held-out test accuracy and show
regret after each example, where the table has such tests (heldout.py); the mean examples to criterion over the seeds
that reach it, and how many do; and the mean seconds the selection took.  A selector that refused the table is one
row saying why.
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy import stats

from .cells import CRITERION


@dataclass(frozen=True)
class Row:
    selector: str
    learner: str
    seeds: int
    final: float  # mean P(θ*) after the whole sequence
    final_ci: float  # half-width of its 95 % interval (0.0: one seed, or all alike)
    curve: tuple[float, ...]  # mean P(θ*) after each example
    curve_ci: tuple[float, ...]
    to_criterion: float | None  # mean examples to criterion over the seeds that reach it
    reached: int  # seeds that reach it
    selection_cost: float | None  # mean seconds the selection took (None: none recorded)
    error: str | None = None
    accuracy: tuple[float, ...] | None = None  # mean held-out test accuracy after each example (None: no tests)
    regret: tuple[float, ...] | None = None  # mean show-test θ*-regret after each example (None: no show tests)


def half_width(values: np.ndarray) -> np.ndarray:
    """95 % interval half-widths of the mean over axis 0 (n values each): t(0.975, n - 1) · s / √n; 0 for n = 1
    and where the n values are equal (a selector no seed changes: its float mean would give a spurious 1e-17)."""
    n = values.shape[0]
    if n < 2:
        return np.zeros(values.shape[1:])
    width = stats.t.ppf(0.975, n - 1) * values.std(axis=0, ddof=1) / np.sqrt(n)
    return np.where(np.ptp(values, axis=0) == 0, 0.0, width)


def padded(curves: list[list[float]]) -> np.ndarray:
    """(seeds, longest) each curve held at its last value (0.0 for an empty one) to the longest's length."""
    longest = max(len(c) for c in curves)
    return np.array([list(c) + [c[-1] if c else 0.0] * (longest - len(c)) for c in curves], np.float64)


def mean_curve(found: list[dict], field: str) -> tuple[float, ...] | None:
    """The mean over seeds of each result's `field` curve (held at its last value), or None where a result has
    none (a table without tests of that kind, or a result of an older format)."""
    curves = [r.get(field) for r in found]
    if any(c is None for c in curves) or not any(curves):
        return None
    return tuple(padded(curves).mean(axis=0).tolist())


def summarise(results: list[dict], costs: dict[str, float] | None = None) -> list[Row]:
    """Rows in the order the (selector, learner) pairs first appear in `results`; costs: key -> seconds."""
    groups: dict[tuple[str, str], list[dict]] = {}
    for r in results:
        groups.setdefault((r["cell"]["selector"], r["cell"]["learner"]), []).append(r)
    rows = []
    for (selector, learner), found in groups.items():
        seconds = [costs[r["key"]] for r in found if costs and r["key"] in costs]
        mean_seconds = float(np.mean(seconds)) if seconds else None
        failed = [r for r in found if "error" in r]
        if failed:
            rows.append(Row(selector, learner, len(found), float("nan"), 0.0, (), (), None, 0, mean_seconds,
                            failed[0]["error"]))
            continue
        curves = padded([r["p_theta_star"] for r in found])
        reached = [r["examples_to_criterion"] for r in found if r["examples_to_criterion"] is not None]
        ci = half_width(curves)
        rows.append(Row(selector, learner, len(found), float(curves[:, -1].mean()), float(ci[-1]),
                        tuple(curves.mean(axis=0).tolist()), tuple(ci.tolist()),
                        float(np.mean(reached)) if reached else None, len(reached), mean_seconds,
                        accuracy=mean_curve(found, "test_accuracy"), regret=mean_curve(found, "show_regret")))
    return rows


def read_costs(out) -> dict[str, float]:
    """key -> selection seconds, from a results folder's costs/."""
    found = {}
    for path in sorted((Path(out) / "costs").glob("*.json")):
        data = json.loads(path.read_text(encoding="utf-8"))
        found[data["key"]] = float(data["selection_seconds"])
    return found


def markdown(rows: list[Row], title: str) -> str:
    """A Markdown table of the rows, a line per (selector, learner)."""
    lines = [f"### {title}", "",
             f"| selector | learner | seeds | P(θ*) at the end (95 % CI) | examples to P(θ*) ≥ {CRITERION:g} "
             "(seeds reaching it) | selection s |",
             "|---|---|---:|---|---|---:|"]
    for r in rows:
        cost = "" if r.selection_cost is None else f"{r.selection_cost:.3g}"
        if r.error:
            lines.append(f"| {r.selector} | {r.learner} | {r.seeds} | refused: {r.error} | | {cost} |")
            continue
        ci = f" ± {r.final_ci:.3f}" if r.final_ci > 0 else ""
        crit = "never" if r.to_criterion is None else f"{r.to_criterion:.1f} ({r.reached}/{r.seeds})"
        lines.append(f"| {r.selector} | {r.learner} | {r.seeds} | {r.final:.3f}{ci} | {crit} | {cost} |")
    return "\n".join(lines) + "\n"


def mismatch(rows: list[Row]) -> tuple[list[str], list[str], np.ndarray]:
    """Lage et al.'s mismatch matrix: (selectors, learners, (S, L) mean final P(θ*)), one row per selector built
    for a learner model (a greedy selector, named after its model), one column per learner; the diagonal is each
    selector learnt by the learner it was built for."""
    learners = list(dict.fromkeys(r.learner for r in rows))
    built = [s for s in dict.fromkeys(r.selector for r in rows) if s in learners]
    final = {(r.selector, r.learner): r.final for r in rows}
    return built, learners, np.array([[final.get((s, u), np.nan) for u in learners] for s in built], np.float64)


def mismatch_markdown(rows: list[Row]) -> str:
    """The mismatch matrix as a Markdown table (rows: built for; columns: learnt by), or "" with no such rows."""
    built, learners, matrix = mismatch(rows)
    if not built:
        return ""
    lines = ["| built for \\ learnt by | " + " | ".join(learners) + " |", "|---|" + "---:|" * len(learners)]
    for s, values in zip(built, matrix, strict=True):
        cells = [f"**{v:.3f}**" if u == s else f"{v:.3f}" for u, v in zip(learners, values, strict=True)]
        lines.append(f"| {s} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"
