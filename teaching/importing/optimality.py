"""Is every trajectory of a table the best of its environment under its own objective?

The learner models assume an optimal robot: a learner who sees the robot take trajectory ξ in an
environment rules out every θ under which another of the environment's trajectories scores higher.  A table
imported from a researcher's planner must hold that: in each environment, objective k's trajectory scores at
least as much under θ_k as every other objective's trajectory there.  Objective 0 is θ*, the one the robot
teaches, so its column is the check that matters most and is counted apart.

A shortfall counts only above a millionth of the environment's range of scores under that objective (the
best minus the worst of its trajectories): the rounding of a file's six significant digits, not a worse
trajectory.  An environment whose trajectories all score alike has nothing to fall short of.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

RTOL = 1e-6  # of the environment's range of scores under the objective (above)


@dataclass(frozen=True)
class Optimality:
    """What the check found; `worst` is (environment id, objective, the objective whose trajectory beats it,
    the shortfall in score, the shortfall as a share of the environment's range) or None."""

    n_envs: int
    n_objectives: int
    star_short: int  # environments where θ*'s trajectory is not the best under θ*
    own_short: int  # (environment, objective) pairs, θ* included, whose trajectory is not the best under it
    worst: tuple[int, int, int, float, float] | None

    @property
    def optimal(self) -> bool:
        return self.own_short == 0

    def describe(self) -> str:
        """One line for a refusal or a report."""
        if self.optimal:
            return (f"every trajectory is the best of its environment under its own objective "
                    f"({self.n_envs:,} environments x {self.n_objectives:,} objectives)")
        env, k, by, short, share = self.worst
        return (f"θ*'s trajectory is not the best under θ* in {self.star_short:,} of {self.n_envs:,} environments, "
                f"and {self.own_short:,} of {self.n_envs * self.n_objectives:,} trajectories are not the best "
                f"under their own objective (worst: environment {env}, where objective {k}'s trajectory scores "
                f"{short:.4g} less under objective {k} than objective {by}'s, {share:.0%} of that environment's "
                f"range)")


def optimality(features: np.ndarray, thetas: np.ndarray, env_ids: np.ndarray, rtol: float = RTOL) -> Optimality:
    """features: (M, N, D) the feature counts of objective j's trajectory in environment m; thetas: (N, D),
    θ* first; env_ids: (M,) the environments' ids (for the report).  Scores are θ · φ.

    Each environment's distinct trajectories are scored under every objective: a planner gives many θ the same
    trajectory, so that is far fewer than N² scores (a paper-sized table in seconds, not minutes)."""
    m, n, _ = features.shape
    star_short = own_short = 0
    worst, worst_share = None, -1.0
    for i in range(m):
        phi = np.asarray(features[i], dtype=np.float64)  # (N, D)
        # the distinct rows by their bytes (a trajectory given to many θ is the same bytes each time): sorting
        # one opaque value a row is several times faster than np.unique(axis=0)'s field-by-field sort
        rows = np.ascontiguousarray(phi).view(np.dtype((np.void, phi.itemsize * phi.shape[1]))).reshape(-1)
        _, first, which = np.unique(rows, return_index=True, return_inverse=True)
        distinct = phi[first]  # (U, D): U <= N
        scores = distinct @ thetas.T  # (U, N): distinct trajectory u's score under objective k
        # each objective's own trajectory under it, read from the same products (computed apart, a rounding
        # difference would count as a shortfall where every trajectory scores alike)
        own = scores[which.reshape(-1), np.arange(n)]
        best, low = scores.max(axis=0), scores.min(axis=0)
        short, spread = best - own, best - low
        bad = short > rtol * spread
        if not bad.any():
            continue
        star_short += int(bad[0])
        own_short += int(bad.sum())
        share = np.where(bad, short / np.where(spread > 0, spread, 1.0), -1.0)
        k = int(np.argmax(share))
        if share[k] > worst_share:
            worst_share = float(share[k])
            by = int(first[int(np.argmax(scores[:, k]))])
            worst = (int(env_ids[i]), k, by, float(short[k]), worst_share)
    return Optimality(m, n, star_short, own_short, worst)
