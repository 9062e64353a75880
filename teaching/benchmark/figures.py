"""The leaderboard's figures for one table: learning curves (one panel per learner) and the mismatch heat map."""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # figures are written to files; no display on servers
import matplotlib.pyplot as plt
import numpy as np

from .summary import Row


def learning_curves(rows: list[Row], title: str, path: Path, field: str = "curve",
                    ylabel: str = "mean P(θ*)") -> Path:
    """(selectors) lines of each row's `field` (a Row curve: "curve", "accuracy" or "regret") after each example,
    one panel per learner, to `path` (PNG).  Each line is as long as its longest sequence (summary.padded holds a
    shorter one at its last value)."""
    learners = list(dict.fromkeys(r.learner for r in rows))
    selectors = list(dict.fromkeys(r.selector for r in rows if not r.error))
    colours = dict(zip(selectors, plt.get_cmap("tab20")(np.linspace(0, 1, max(len(selectors), 2))), strict=False))
    dashes = {s: ("-", "--", ":")[i % 3] for i, s in enumerate(selectors)}  # neighbours in colour differ in line
    cols = 4
    fig, axes = plt.subplots(-(-len(learners) // cols), cols, figsize=(14, 3.2 * -(-len(learners) // cols)),
                             sharey=True, squeeze=False)
    curves = {(r.selector, r.learner): getattr(r, field) for r in rows if not r.error}
    probability = field != "regret"
    for ax, learner in zip(axes.flat, learners, strict=False):
        for selector in selectors:
            curve = curves.get((selector, learner))
            if curve:
                ax.plot(np.arange(1, len(curve) + 1), curve, color=colours[selector], ls=dashes[selector], lw=1.5,
                        label=selector)
        ax.set_title(learner, fontsize=10)
        if probability:
            ax.set_ylim(-0.02, 1.02)
        ax.grid(alpha=0.3)
        ax.set_xlabel("examples shown")
    for ax in axes[:, 0]:
        ax.set_ylabel(ylabel)
    for ax in list(axes.flat)[len(learners):]:
        ax.axis("off")
    handles, labels = axes.flat[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=min(len(labels), 8), fontsize=8, frameon=False)
    fig.suptitle(title, fontsize=11)
    fig.tight_layout(rect=(0, 0.08, 1, 0.96))
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=90, metadata={"Software": None})
    plt.close(fig)
    return path


def mismatch_heat_map(built: list[str], learners: list[str], matrix: np.ndarray, title: str, path: Path) -> Path:
    """(S, L) mean final P(θ*) as a heat map (rows: the learner model a selector was built for; columns: the
    learner), each cell written in, the diagonal framed, to `path` (PNG)."""
    fig, ax = plt.subplots(figsize=(1.1 * len(learners) + 2.5, 0.55 * len(built) + 1.8))
    image = ax.imshow(matrix, vmin=0.0, vmax=1.0, cmap="viridis", aspect="auto")
    for i, j in np.ndindex(matrix.shape):
        value = matrix[i, j]
        ax.text(j, i, "" if np.isnan(value) else f"{value:.2f}", ha="center", va="center", fontsize=8,
                color="black" if value > 0.6 else "white")
        if built[i] == learners[j]:
            ax.add_patch(plt.Rectangle((j - 0.5, i - 0.5), 1, 1, fill=False, edgecolor="red", lw=2))
    ax.set_xticks(range(len(learners)), learners, rotation=35, ha="right", fontsize=8)
    ax.set_yticks(range(len(built)), built, fontsize=8)
    ax.set_xlabel("learnt by")
    ax.set_ylabel("selector built for")
    fig.colorbar(image, ax=ax, label="mean P(θ*) at the end")
    ax.set_title(title, fontsize=10)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=90, metadata={"Software": None})
    plt.close(fig)
    return path
