"""Figures in the style of the paper's: grayscale heatmaps, white = 0, black = 1 (or the max)."""
from __future__ import annotations

import matplotlib

matplotlib.use("Agg")  # figures are written to files; no display on servers

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.patches import Rectangle

from .evaluation import grid_cells


def cell_labels(grid: np.ndarray, class_of_cluster) -> list[list[str]]:
    """The numbers an examples-per-cluster grid (k, n_classes) shows: each cluster's count, and ""
    where no cluster is (a class with fewer strategies than the most a class has)."""
    exists = np.zeros(np.shape(grid), bool)
    exists[grid_cells(np.asarray(class_of_cluster))] = True
    return [[str(int(v)) if e else "" for v, e in zip(row, ok, strict=True)]
            for row, ok in zip(grid, exists, strict=True)]


def _ink(value: float, vmax: float) -> str:
    return "white" if value > 0.5 * vmax else "black"


def plot_ideal_users(matrix: np.ndarray, sequence_names, user_names, path, title: str | None = None) -> None:
    """The paper's Fig. "sim_users": rows = sequence chosen for model, columns = ideal user."""
    s, u = matrix.shape
    fig, ax = plt.subplots(figsize=(1.0 + 0.9 * u, 1.0 + 0.6 * s))
    ax.imshow(matrix, cmap="Greys", vmin=0, vmax=1, aspect="auto")
    for i in range(s):
        for j in range(u):
            ax.text(j, i, f"{matrix[i, j]:.2f}", ha="center", va="center", fontsize=8,
                    color=_ink(matrix[i, j], 1.0))
    ax.set_xticks(range(u), user_names, rotation=45, ha="right")
    ax.set_yticks(range(s), sequence_names)
    ax.set_xlabel("ideal user (true learner model)")
    ax.set_ylabel("sequence chosen for model")
    ax.set_title(title or "P(θ* | examples)   white = 0, black = 1", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def plot_examples_shown(grids: np.ndarray, names, path, domain, vmax: float | None = None) -> None:
    """The paper's Fig. "examples_shown": one grid per sequence (S, k, n_classes), laid out by
    evaluation.cluster_grid (2 × 4 in the paper).  `domain` names the classes and clusters.

    White = 0 examples, black = vmax (4 as in the paper, or more if a sequence shows more).  A cell
    no cluster has (a class with fewer strategies than another) is hatched and left without a number.
    """
    n_rows, n_classes = grids.shape[1:]
    of = np.asarray(domain.class_of_cluster)
    vmax = float(max(4, grids.max()) if vmax is None else vmax)
    n = len(names)
    cols = min(4, n)
    rows = int(np.ceil(n / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(2.6 * cols, 1.6 * rows + 0.6), squeeze=False)
    for k, ax in enumerate(axes.flat):
        if k >= n:
            ax.axis("off")
            continue
        g = grids[k]
        ax.imshow(g, cmap="Greys", vmin=0, vmax=vmax)
        labels = cell_labels(g, of)
        for r in range(n_rows):
            for c in range(n_classes):
                if labels[r][c]:
                    ax.text(c, r, labels[r][c], ha="center", va="center", fontsize=8, color=_ink(g[r, c], vmax))
                else:  # no such strategy: not "0 examples"
                    ax.add_patch(Rectangle((c - 0.5, r - 0.5), 1, 1, facecolor="#f2f2f2", edgecolor="#bbbbbb",
                                           hatch="////", linewidth=0))
        ax.set_title(names[k], fontsize=9)
        ax.set_xticks(range(n_classes), domain.class_names[:n_classes], fontsize=7)  # classes with strategies
        ax.set_yticks(range(n_rows), ["1st", "2nd", "3rd", *(f"{i}th" for i in range(4, n_rows + 1))][:n_rows],
                      fontsize=7)
    rows_doc = "; ".join(
        f"{name}: " + " / ".join(domain.cluster_names[i].split(": ")[-1] for i in np.flatnonzero(of == c))
        for c, name in enumerate(domain.class_names[:n_classes]))
    fig.suptitle(f"examples per strategy cluster, white = 0, black = {vmax:g}\nrows 1st / 2nd: {rows_doc}",
                 fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
