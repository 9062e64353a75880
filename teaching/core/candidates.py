"""The candidate objectives Theta (DESIGN §4): theta* first, then N-1 seeded samples.

The sampler and seed are part of a table's identity.
"""
from __future__ import annotations

import numpy as np

from . import detmath

SAMPLERS = ("log-uniform", "sphere")


def sample_thetas(n: int, sampler: str = "log-uniform", seed: int = 0, *, theta_star) -> np.ndarray:
    """(n, D) candidate thetas, row 0 = theta_star (D,), the domain's objective.

    Every candidate lies in θ*'s orthant (each weight with θ*'s sign; a 0 counts as negative).
    log-uniform: |theta_i| = |theta*_i| * 10^U(-1, 1) (within one decade either side).  sphere:
    uniform on θ*'s orthant of the unit sphere (|N(0, I)| normalised, given θ*'s signs).
    """
    if n < 2:
        raise ValueError(f"need at least 2 candidate thetas (theta* and one other), got {n}")
    if sampler not in SAMPLERS:
        raise ValueError(f"unknown sampler {sampler!r}; choose one of {', '.join(SAMPLERS)}")
    rng = np.random.default_rng(seed)
    star = np.asarray(theta_star, dtype=float)
    # each weight keeps θ*'s sign (a cost stays a cost, a reward a reward); -1.0 * x is exactly -x,
    # so an all-cost θ* draws the same bits as negating did
    signs = np.where(star > 0, 1.0, -1.0)
    if sampler == "log-uniform":
        # 10**u correctly rounded (detmath): NumPy's power is CPU-dispatched and its AVX-512 loop
        # differs in the last bit, which moved thousands of a table's trajectories
        rest = signs * np.abs(star) * detmath.pow10(rng.uniform(-1.0, 1.0, size=(n - 1, len(star))))
    else:
        g = np.abs(rng.standard_normal((n - 1, len(star))))
        rest = signs * g / np.linalg.norm(g, axis=1, keepdims=True)
    return np.vstack([star, rest])
