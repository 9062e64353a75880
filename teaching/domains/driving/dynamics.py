"""Bicycle-model car, explicit Euler (DESIGN §2): the NumPy entry points.

State s = [x, y, heading, v, steer]; control u = [steer rate, acceleration].
A trajectory is stored as its knot controls z (K, 2), each a fraction of the
bound ([-1, 1] x [steer_rate_max, accel_max]), held for steps_per_knot steps;
the compiled step itself is in :mod:`teaching.domains.driving.kernels`.
"""
from __future__ import annotations

import numpy as np

from . import newton
from .world import WORLD

STATE_DIM = 5
X, Y, HEADING, V, STEER = range(STATE_DIM)


def rollout_np(knots: np.ndarray) -> np.ndarray:
    """Knot controls (..., K, 2) in [-1, 1] -> states (..., T+1, 5) float64, start state included."""
    knots = np.asarray(knots, dtype=np.float64)
    if knots.shape[-2:] != (WORLD.n_knots, 2):
        raise ValueError(f"knots must have shape (..., {WORLD.n_knots}, 2), got {knots.shape}")
    lead = knots.shape[:-2]
    flat = np.ascontiguousarray(knots.reshape((-1, WORLD.n_knots, 2)))
    out = np.empty((len(flat), WORLD.horizon + 1, STATE_DIM))
    if len(flat):
        newton.rollout_batch(flat, out)
    return out.reshape(lead + (WORLD.horizon + 1, STATE_DIM))


def physical_controls(knots: np.ndarray) -> np.ndarray:
    """Knot fractions (..., K, 2) -> per-step controls (..., T, 2) in rad/s and ft/s^2."""
    return np.repeat(np.asarray(knots, np.float64) * WORLD.control_bounds, WORLD.steps_per_knot, axis=-2)
