"""Figures of the user-study analysis, in the style of the paper (matplotlib, no Django).

* :func:`scores_figure` -- mean confidence score per condition with SE error bars and
  significance brackets (Holm-adjusted Welch p: * < .05, ** < .01, *** < .001, n.s. otherwise).
  Left panel: exact and the approximate-inference models (paper Fig. "noisemodels_sig", left);
  right panel: random, approx*, coverage-random, coverage-approx* (right).
* :func:`correlation_figure` -- the two scatters of Fig. "corr" (condition x test level).
* :func:`examples_figure` -- training examples per strategy cluster per condition.
* :func:`learning_figure` -- closed-loop conditions' learning curves: the share choosing θ*'s option
  at each check number, with its 95 % Wilson interval, against chance (only when there are any).
"""
from __future__ import annotations

import base64
import io

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.patches import Patch

from . import learning as L
from . import stats as S

COLORS = {"exact": "#9e9e9e", "approximate": "#4c72b0", "random": "#dd8452", "other": "#8c8c8c"}
STAR_COLOR = "#222222"


def stars(p: float) -> str:
    if p is None or np.isnan(p):
        return ""
    return "***" if p < 0.001 else "**" if p < 0.01 else "*" if p < 0.05 else "n.s."


def _panels(analysis: S.Analysis) -> list[tuple[str, list[str]]]:
    have = [c for c in analysis.summary.index if analysis.summary.loc[c, "n"] > 0]
    star = analysis.approx_star
    left = [c for c in ("exact", *S.APPROX_CONDITIONS) if c in have]
    right = [c for c in ("random", star, S.COVERAGE_RANDOM, S.COVERAGE_APPROX) if c in have]
    rest = [c for c in have if c not in left and c not in right]
    panels = []
    if left:
        panels.append(("Approximate-inference models", left))
    if right:
        panels.append(("Coverage and the random baseline", right))
    if rest:
        panels.append(("Other conditions", rest))
    return panels


def _color(analysis, cond):
    if cond == analysis.approx_star or cond == S.COVERAGE_APPROX:
        return "#55a868"
    return COLORS[S.condition_factors(cond, analysis.approx_star)["model"]]


def _layout(analysis, conds):
    """x positions, bar width, tick positions and labels: the approximate models grouped by
    distance with deterministic / probabilistic side by side (the paper's layout), else one bar each."""
    approx = [c for c in conds if S.condition_factors(c, analysis.approx_star)["model"] == "approximate"
              and not S.condition_factors(c, analysis.approx_star)["coverage"]]
    if len(approx) < 2 or len(approx) + ("exact" in conds) != len(conds):
        x = np.arange(len(conds), dtype=float)
        return x, 0.8, x, [S.label(c, analysis.approx_star).replace(" (", "\n(") for c in conds]
    pos, ticks, labels, g = {}, [], [], 0.0
    if "exact" in conds:
        pos["exact"] = 0.0
        ticks.append(0.0)
        labels.append("exact")
        g = 1.2
    for dist in S.DISTANCES:
        members = [c for c in approx if S.condition_factors(c)["distance"] == dist]
        members.sort(key=lambda c: S.condition_factors(c)["determinism"])  # deterministic first
        if not members:
            continue
        offs = [0.0] if len(members) == 1 else [-0.21, 0.21]
        for c, o in zip(members, offs, strict=False):
            pos[c] = g + o
        ticks.append(g)
        labels.append(dist + (" (approx*: det)" if analysis.approx_star in members else ""))
        g += 1.2
    return np.array([pos[c] for c in conds]), 0.4, ticks, labels


def scores_figure(analysis: S.Analysis):
    panels = _panels(analysis)
    if not panels:
        fig, ax = plt.subplots(figsize=(5, 2))
        ax.text(0.5, 0.5, "No included participants yet", ha="center", va="center")
        ax.axis("off")
        return fig
    widths = [max(len(c), 2) for _, c in panels]
    fig, axes = plt.subplots(1, len(panels), figsize=(3.2 + 1.05 * sum(widths), 4.2), squeeze=False,
                             gridspec_kw={"width_ratios": widths}, sharey=True)
    summ = analysis.summary
    welch = analysis.welch
    top_all = float(np.nanmax((summ["mean"] + summ["se"].fillna(0)).to_numpy(float))) if len(summ) else 1.0
    low_all = float(np.nanmin((summ["mean"] - summ["se"].fillna(0)).to_numpy(float))) if len(summ) else 0.0
    step = max(0.35, 0.08 * (top_all - min(low_all, 0) + 1))
    for ax, (title, conds) in zip(axes[0], panels, strict=True):
        x, width, ticks, tick_labels = _layout(analysis, conds)
        means = summ.loc[conds, "mean"].to_numpy(float)
        ses = summ.loc[conds, "se"].to_numpy(float)
        hatches = ["//" if S.condition_factors(c, analysis.approx_star)["determinism"] == "probabilistic"
                   and c != S.COVERAGE_APPROX else "" for c in conds]
        bars = ax.bar(x, means, width=width, yerr=np.nan_to_num(ses), capsize=4,
                      color=[_color(analysis, c) for c in conds], edgecolor="black", linewidth=0.6,
                      error_kw={"elinewidth": 1})
        for bar, h in zip(bars, hatches, strict=True):
            bar.set_hatch(h)
        ax.axhline(0, color="black", linewidth=0.8)
        ax.set_xticks(ticks, tick_labels, rotation=30, ha="right", fontsize=8)
        for xi, c in zip(x, conds, strict=True):  # participant counts along the bottom edge
            ax.text(xi, 0.01, f"n={int(summ.loc[c, 'n'])}", ha="center", va="bottom", fontsize=7, color="#444",
                    transform=ax.get_xaxis_transform())
        if any(hatches):
            ax.legend(handles=[Patch(facecolor="white", edgecolor="black", label="deterministic"),
                               Patch(facecolor="white", edgecolor="black", hatch="//", label="probabilistic")],
                      fontsize=7, loc="upper right", frameon=False)
        ax.set_title(title, fontsize=10)
        level = top_all + step * 0.6
        for _, w in welch.iterrows():
            if w["a"] in conds and w["b"] in conds and not np.isnan(w.get("p_holm", np.nan)):
                i, j = sorted((x[conds.index(w["a"])], x[conds.index(w["b"])]))
                ax.plot([i, i, j, j], [level - step * 0.25, level, level, level - step * 0.25], color=STAR_COLOR,
                        linewidth=0.9)
                ax.text((i + j) / 2, level + 0.02,
                        f"{stars(w['p_holm'])} (p {'' if w['p'] < 0.001 else '= '}{S.fmt_p(w['p'])})",
                        ha="center", va="bottom", fontsize=7)
                level += step
        ax.set_ylim(min(low_all, 0) - 2 * step - 0.4, max(level + step * 0.3, top_all + step))
        ax.spines[["top", "right"]].set_visible(False)
    axes[0][0].set_ylabel("confidence score (mean ± SE)")
    fig.tight_layout()
    return fig


def correlation_figure(analysis: S.Analysis):
    cors = {(c.name, c.level): c for c in analysis.correlations}
    picks = [cors.get(("number of examples vs score", "condition x test")),
             cors.get(("helpful examples vs per-test score", "condition x test"))]
    fig, axes = plt.subplots(1, 2, figsize=(9, 3.8))
    xlabels = ["number of training examples in the condition", "helpful training examples for the test"]
    for ax, c, xl in zip(axes, picks, xlabels, strict=True):
        ax.set_xlabel(xl)
        ax.set_ylabel("mean confidence score on the test")
        if c is None or c.data is None or not len(c.data):
            ax.text(0.5, 0.5, "no data", ha="center", va="center", transform=ax.transAxes)
            continue
        d = c.data[[c.x, c.y]].dropna()
        ax.scatter(d[c.x], d[c.y], s=28, color="#4c72b0", edgecolor="white", linewidth=0.5, zorder=3)
        if c.ok:
            slope, icept = np.polyfit(d[c.x].to_numpy(float), d[c.y].to_numpy(float), 1)
            xx = np.linspace(d[c.x].min(), d[c.x].max(), 10)
            ax.plot(xx, icept + slope * xx, color="#c44e52", linewidth=1.2)
            ax.set_title(f"r = {c.r:.2f} [{c.ci_low:.2f}, {c.ci_high:.2f}], p = {c.p:.2g}, n = {c.n}", fontsize=9)
        else:
            ax.set_title(c.message, fontsize=8)
        ax.axhline(0, color="#999", linewidth=0.6)
        ax.spines[["top", "right"]].set_visible(False)
    fig.tight_layout()
    return fig


def examples_figure(analysis: S.Analysis):
    grid = analysis.examples_per_cluster
    clusters = analysis.clusters
    fig, ax = plt.subplots(figsize=(8.5, 0.45 * max(len(grid), 1) + 2.2))
    if grid.empty:
        ax.text(0.5, 0.5, "no training sequences", ha="center", va="center")
        ax.axis("off")
        return fig
    vals = grid.to_numpy()
    ax.imshow(vals, cmap="Blues", aspect="auto", vmin=0, vmax=max(3, vals.max()))
    for (i, j), v in np.ndenumerate(vals):
        ax.text(j, i, str(v) if v else "·", ha="center", va="center", fontsize=9,
                color="white" if v > max(3, vals.max()) * 0.6 else "black")
    ax.set_xticks(range(grid.shape[1]), [clusters.name(c) for c in grid.columns],
                  rotation=35, ha="right", fontsize=8)
    ax.set_yticks(range(len(grid)), [f"{S.label(c, analysis.approx_star)}  ({vals[i].sum()})"
                                     for i, c in enumerate(grid.index)], fontsize=8)
    for k in clusters.class_starts():  # a white line between the domain's classes
        ax.axvline(k - 0.5, color="white", linewidth=3)
    ax.set_title("training examples per strategy cluster (total in brackets)", fontsize=10)
    fig.tight_layout()
    return fig


def learning_figure(analysis: S.Analysis):
    """x: check number, y: share of participants choosing θ*'s option (95 % Wilson interval as error
    bars), one line per closed-loop condition; chance (1 in 4) dashed."""
    curves = analysis.learning
    fig, ax = plt.subplots(figsize=(6.5, 3.8))
    for k, (cond, c) in enumerate(curves.groupby("condition", sort=False)):
        x = c["check_number"].to_numpy(float) + 0.06 * (k - (curves["condition"].nunique() - 1) / 2)  # no overlap
        p = c["p_correct"].to_numpy(float)
        err = np.vstack([p - c["ci_low"].to_numpy(float), c["ci_high"].to_numpy(float) - p])
        low, high = int(c["n"].min()), int(c["n"].max())  # participants per check: in the legend, off the data
        ax.errorbar(x, p, yerr=err, marker="o", capsize=3, linewidth=1.2, markersize=5,
                    label=f"{S.label(cond, analysis.approx_star)} (n = {low}{'' if low == high else f'–{high}'})")
    ax.axhline(L.CHANCE, color="#777", linestyle="--", linewidth=1, label="chance (1 in 4)")
    numbers = sorted(set(curves["check_number"].astype(int)))
    ax.set_xticks(numbers)
    ax.set_ylim(0, 1.02)
    ax.set_xlabel("check question (1st, 2nd, … the participant answered)")
    ax.set_ylabel("share choosing θ*'s option (95 % CI)")
    ax.legend(fontsize=8, frameon=False, loc="best")
    ax.spines[["top", "right"]].set_visible(False)
    fig.tight_layout()
    return fig


def all_figures(analysis: S.Analysis) -> dict:
    figures = {"scores": scores_figure(analysis), "correlations": correlation_figure(analysis),
               "examples_per_cluster": examples_figure(analysis)}
    if len(analysis.learning):
        figures["learning"] = learning_figure(analysis)
    return figures


def to_bytes(fig, fmt: str = "png", dpi: int = 110) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format=fmt, dpi=dpi, bbox_inches="tight")
    plt.close(fig)
    return buf.getvalue()


def data_uri(png: bytes) -> str:
    return "data:image/png;base64," + base64.b64encode(png).decode("ascii")
