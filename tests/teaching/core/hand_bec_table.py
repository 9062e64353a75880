"""A 2-feature table worked by hand for the BEC selectors (tests/teaching/core/test_bec.py).

Weights are costs: θ = -u with u ≥ 0, and θ's trajectory in an environment is the option of least
cost u·φ.  θ* = (-1, -1) takes φ* = (3, 3) (cost 6) everywhere.  In u-space an alternative φ gives
the half-space u·(φ - φ*) ≥ 0; the angle a of u = (cos a, sin a) measures from feature 0's axis.

    env  options (φ)                              normals φ - φ*                 angles allowed
    E0   (3,3) (2,5) (5,2)                        (-1,2) (2,-1)                  [26.57°, 63.43°]
    E1   (3,3) (2,6) (6,1)                        (-1,3) (3,-2)                  [18.43°, 56.31°]
    E2   (3,3) (1,6)                              (-2,3)                         [33.69°, 90°]
    E3   (3,3) (2,5) (9,0) (5,1.5)                (-1,2) (6,-3) (2,-1.5)         [26.57°, 53.13°]

(tan a ≥ 1/2 from (-1,2), tan a ≤ 2 from (2,-1), and so on.)  In E3 (6,-3) = 3·(2,-1) allows up to
63.43° but (2,-1.5) already stops at 53.13°: redundant.  Thetas in u-space, each choosing its
cheapest option: u0 = (1,1) θ*, u1 = (1,.1), u2 = (.1,1), u3 = (.6,1).
"""
from __future__ import annotations

import numpy as np

from teaching.core.table import TrajectoryTable

THETAS = -np.array([[1.0, 1.0], [1.0, 0.1], [0.1, 1.0], [0.6, 1.0]])
# features[m, n]: θ n's trajectory in environment m (checked in the tests to be its cheapest option)
OPTIONS = [[(3, 3), (2, 5), (5, 2)],
           [(3, 3), (2, 6), (6, 1)],
           [(3, 3), (1, 6)],
           [(3, 3), (2, 5), (9, 0), (5, 1.5)]]


def hand_bec_table(theta_star_clusters=(0, 1, 2, 1)) -> TrajectoryTable:
    """The table above: 4 environments (ids 10, 11, 12, 13) × 4 θ × 2 features."""
    options = [np.array(o, np.float64) for o in OPTIONS]
    features = np.stack([o[np.argmin(o @ -THETAS.T, axis=0)] for o in options])  # (M, N, 2)
    m, n = features.shape[:2]
    strategy = np.zeros((m, n), np.int8)
    strategy[:, 0] = theta_star_clusters
    return TrajectoryTable(thetas=THETAS, env_ids=np.arange(10, 10 + m, dtype=np.int64),
                           controls=np.zeros((m, n, 1), np.float32), features=features, strategy=strategy,
                           d_euclid=np.zeros((m, n), np.float32), normalisers=np.ones(2), meta={"preset": "hand"})
