"""θ·φ: the reward of a trajectory under an objective, summed in one fixed order."""
from __future__ import annotations

import numpy as np


def reward(features: np.ndarray, thetas: np.ndarray) -> np.ndarray:
    """theta . phi over the last axis, broadcast.  Every reward comparison that
    must hold exactly (d_reward >= 0) goes through this one function, so the
    same numbers are always summed in the same order: left to right, one product at a time, as
    a domain's compiled planner must too (a BLAS product or np.sum may reorder the sum by CPU)."""
    features, thetas = np.asarray(features, np.float64), np.asarray(thetas, np.float64)
    r = features[..., 0] * thetas[..., 0]
    for i in range(1, features.shape[-1]):
        r = r + features[..., i] * thetas[..., i]
    return r
