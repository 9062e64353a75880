"""Ideal-user evaluation (paper, "Analysis of Approximate Inference Models with Ideal Users").

* the matrix P_M(θ* | sequence chosen for model M') for every sequence M'
  (rows: the learners' greedy sequences + random, as in the paper's figure)
  and every ideal user M (columns: the paper's 7 models and the hierarchical learner of its
  Discussion, learners.LEARNER_NAMES);
* the number of examples of each strategy cluster in each sequence, laid out
  as the paper's 2 × 4 grid (column = environment class, row = its first /
  second strategy).

``study_matrix`` is the same matrix for any named sequences of one table (a study's
conditions), each ideal user with its τ / λ chosen as ``teach`` chooses it.
"""
from __future__ import annotations

import numpy as np

from .learners import LEARNER_NAMES, Distances, LearnerModel, p_theta_star
from .selection import DEFAULT_SETTINGS, SelectionSettings, fitted_model

# The paper's 8 sequences (one per model: prob-strategy's equals det-strategy's, and random) with the
# hierarchical learner's before random; the paper's figure is the matrix without that row and column.
SEQUENCE_NAMES = LEARNER_NAMES + ("random",)
USER_NAMES = LEARNER_NAMES


def ideal_user_matrix(models: dict[str, LearnerModel], sequences: dict[str, list[int]], dist: Distances,
                      sequence_names=SEQUENCE_NAMES, user_names=USER_NAMES) -> np.ndarray:
    """(S, U) float64: entry [s, u] = P_{user u}(θ* | ξ^{θ*} in sequence s's environments).

    sequences: name -> environment indices (table rows).
    """
    out = np.zeros((len(sequence_names), len(user_names)))
    for i, s in enumerate(sequence_names):
        for j, u in enumerate(user_names):
            out[i, j] = p_theta_star(models[u], dist, sequences[s])
    return out


def study_matrix(table, sequences: dict[str, list[int]], hyperparameters: dict | None = None, *,
                 settings: SelectionSettings = DEFAULT_SETTINGS, dist: Distances | None = None,
                 user_names=USER_NAMES) -> tuple[np.ndarray, dict[str, LearnerModel]]:
    """The ideal-user matrix of named sequences (e.g. a study's conditions) on one table.

    sequences: name -> environment indices (table rows); the rows follow its order.  Columns:
    `user_names`, each user with its τ / λ fixed in `hyperparameters` ({model: value}) or else
    chosen by the paper's rule (``selection.fitted_model``, the sweep ``teach`` runs), so with no
    `hyperparameters` the users are ``teach(table).models``.  Returns ((S, U) matrix, {user: model}).
    """
    dist = dist or Distances(table)
    buffer = np.empty(dist.shape, np.float32)
    models = {u: fitted_model(u, dist, dict(hyperparameters or {}), settings, buffer=buffer)[0] for u in user_names}
    return ideal_user_matrix(models, sequences, dist, sequence_names=list(sequences), user_names=user_names), models


def cluster_counts(clusters: np.ndarray, envs, n_clusters: int) -> np.ndarray:
    """(C,) int: how many of ``envs`` (table rows) show θ* in each strategy cluster 0 .. C - 1.

    clusters: (M,) θ*'s cluster per environment (C: no strategy, not counted).  Repeated
    examples count each time.
    """
    return np.bincount(clusters[np.asarray(envs, dtype=np.int64)], minlength=n_clusters)[:n_clusters]


def grid_cells(class_of_cluster) -> tuple[np.ndarray, np.ndarray]:
    """Where each cluster stands in :func:`cluster_grid`'s grid: ((C,) row = its rank within its
    class, (C,) column = its class)."""
    cols = np.asarray(class_of_cluster, np.int64)
    rows = np.array([np.count_nonzero(cols[:c] == cols[c]) for c in range(len(cols))], np.int64)
    return rows, cols


def cluster_grid(counts: np.ndarray, class_of_cluster) -> np.ndarray:
    """(C,) -> (k, n_classes): column = class, row = the class's first, second, ... cluster
    (k = most clusters of one class; a class with fewer leaves zeros): (2, 4) for the paper's four
    classes of two strategies each."""
    rows, cols = grid_cells(class_of_cluster)
    grid = np.zeros((int(rows.max()) + 1, int(cols.max()) + 1), np.asarray(counts).dtype)
    grid[rows, cols] = counts
    return grid


def grid_layout(domain) -> str:
    """How to read :func:`cluster_grid`'s grids, in words (written beside them)."""
    of = np.asarray(domain.class_of_cluster)
    rows = ("1st/2nd strategy (cluster 2*col+row)" if np.array_equal(of, np.arange(len(of)) // 2)
            else "the class's 1st, 2nd, ... strategy cluster, in cluster order")
    return f"grid[row][col]: col = class ({', '.join(domain.class_names)}), row = {rows}"


def examples_per_cluster(clusters: np.ndarray, sequences: dict[str, list[int]], names=SEQUENCE_NAMES, *,
                         class_of_cluster) -> np.ndarray:
    """(S, k, n_classes) int grids (:func:`cluster_grid`) for the sequences ``names``."""
    n = len(class_of_cluster)
    return np.stack([cluster_grid(cluster_counts(clusters, sequences[n_], n), class_of_cluster) for n_ in names])
