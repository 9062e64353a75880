"""A grid domain's table, planner and page rows, given its front: :class:`GridDomain`.

Every feature of a grid domain is a count of cells entered and every weight of θ negative, so a
path's reward θ·φ only falls as any count grows: the optimum for any θ is one of the environment's
*non-dominated* feature vectors.  A grid domain finds that front once per environment, with one
path for each φ (:meth:`GridDomain.front`); each θ then takes the φ of highest reward through
``teaching.core.rewards.reward`` - the first of equal rewards, so a front sorted
lexicographically breaks ties towards the lexicographically smaller φ.
"""
from __future__ import annotations

import numpy as np

from ...core.base import BaseDomain
from ...core.pathdistance import padded_distance
from ...core.rewards import reward
from . import ROOT
from .cells import cell_states, encode


def best_of_front(phi: np.ndarray, thetas: np.ndarray, normalisers) -> tuple[np.ndarray, np.ndarray]:
    """Each θ's choice among a front: phi (P, D) counts, thetas (N, D) -> ((N,) index into the
    front, (P, D) normalised features).  The first of equal rewards wins."""
    feats = np.asarray(phi) / np.asarray(normalisers, np.float64)  # (P, D)
    return np.argmax(reward(feats[None, :, :], np.asarray(thetas)[:, None, :]), axis=1), feats


class GridDomain(BaseDomain):
    """A :class:`~teaching.core.base.BaseDomain` whose trajectories are paths of cells.  A subclass
    sets ``width`` and ``max_moves`` (and ``state_scale`` if a cell is not one unit each way) and
    implements :meth:`front`, :meth:`strategy_labels` and ``environment_class``."""

    width: int  # columns; a cell (row, col) is stored as row * width + col
    max_moves: int  # a table's path holds max_moves + 1 cells
    state_scale: tuple = (1.0, 1.0)  # the Euclidean learner compares positions in these units
    extra_code_roots = (ROOT,)
    trajectory_dtype = np.dtype(np.int8)

    @property
    def trajectory_shape(self) -> tuple[int, ...]:
        return (self.max_moves + 1,)  # the cells visited, row * width + col

    def front(self, env_id: int) -> tuple[np.ndarray, list[list[tuple[int, int]]]]:
        """Every non-dominated feature vector of a path in environment `env_id`, lexicographically
        sorted, and one path (cells visited, start first) for each: ((P, D) int, P lists of (row, col))."""
        raise NotImplementedError

    def strategy_labels(self, phi: np.ndarray, env_class: np.ndarray) -> np.ndarray:
        """phi (..., D) counts, env_class (...) -> (...) int8 cluster (C: none of its class's)."""
        raise NotImplementedError

    def encode(self, path) -> np.ndarray:
        return encode(path, self.width, self.max_moves + 1)

    def states(self, controls) -> np.ndarray:
        """Stored paths (..., max_moves + 1) int8 -> positions (..., max_moves + 1, 2) float64 [col, row]."""
        return cell_states(controls, self.width)

    def euclidean_distance(self, states_a, states_b) -> np.ndarray:
        return padded_distance(states_a, states_b, self.state_scale)

    def plan_chunk(self, env_ids, thetas, normalisers) -> dict:
        """The optimal path of every (environment, θ): env_ids (n,), thetas (N, D) (θ* first).
        Returns controls (n, N, max_moves + 1) trajectory_dtype (cells), features (n, N, D) float64 normalised,
        strategy (n, N) int8, d_euclid (n, N) float32 to θ*'s path."""
        env_ids = np.asarray(env_ids, np.int64)
        thetas = np.asarray(thetas, np.float64)
        n, N, L, D = len(env_ids), len(thetas), self.max_moves + 1, len(self.feature_names)
        out = {"controls": np.empty((n, N, L), self.trajectory_dtype), "features": np.empty((n, N, D)),
               "strategy": np.empty((n, N), np.int8), "d_euclid": np.empty((n, N), np.float32)}
        classes = self.environment_class(env_ids)
        for k, env_id in enumerate(env_ids):
            phi, paths = self.front(int(env_id))
            pick, feats = best_of_front(phi, thetas, normalisers)
            # everything per front path (a handful), then each θ takes its path's
            encoded = np.stack([self.encode(p) for p in paths])
            labels = self.strategy_labels(phi, np.full(len(phi), classes[k]))
            pos = self.states(encoded)
            to_star = self.euclidean_distance(pos, pos[pick[0]][None])  # (P,) to θ*'s path
            out["controls"][k] = encoded[pick]
            out["features"][k] = feats[pick]
            out["strategy"][k] = labels[pick]
            out["d_euclid"][k] = to_star[pick]
        return out

    def path_rows(self, states: np.ndarray) -> list[list[int]]:
        """(max_moves + 1, 2) [col, row] states -> [[col, row]] * (moves + 1): the cells the robot
        enters, up to its arrival (a table pads a path by waiting at the end; the page need not)."""
        rows = np.asarray(states, np.int64)
        moving = np.flatnonzero(np.any(rows != rows[-1], axis=1))
        end = int(moving[-1]) + 2 if len(moving) else 1
        return rows[:end].tolist()
