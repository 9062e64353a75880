"""Reward features phi(xi) of DESIGN §3 (gamma = 1) and their normalisation.

The arithmetic is compiled in :mod:`teaching.domains.driving.kernels` (shared with the
planner's objective so the two can never disagree); this module is the
batched NumPy entry and the calibration.  Feature
1 (closeness) is left raw; features 2-5 are divided by constants fixed once
from a calibration set (:func:`calibrate_normalisers`, docs/calibration.md).
"""
from __future__ import annotations

import numpy as np

from ...core.rewards import reward  # noqa: F401  (the planner's and the tests' name for it)
from . import dynamics, newton
from .dynamics import HEADING, X
from .world import WORLD, World


def raw_features(knots: np.ndarray, other_xy: np.ndarray, goal: np.ndarray) -> np.ndarray:
    """Unnormalised features of a batch of trajectories: exactly the ones the planner optimises.

    knots (B, K, 2) in [-1, 1]; other_xy (B, T+1, 2) other car positions;
    goal (B,) 0 merge / 1 forward.  Returns (B, 5): closeness, acceleration^2,
    speed deviation^2, turning (sum_t sqrt(dh^2 + eps^2) - eps, eps =
    WORLD.turn_smoothing: one definition everywhere), goal distance.
    """
    knots = np.ascontiguousarray(knots, dtype=np.float64)
    out = np.empty((len(knots), 5))
    if len(knots):
        newton.features_batch(knots, np.ascontiguousarray(other_xy[..., 0], dtype=np.float64),
                               np.ascontiguousarray(other_xy[..., 1], dtype=np.float64),
                               np.asarray(goal, dtype=np.int64), out)
    return out


def calibration_controls(world: World = WORLD, n_random: int = 200_000, seed: int = 0) -> np.ndarray:
    """The calibration set's control sequences (C, K, 2).

    Constant accelerations on a grid across the bounds (they give the largest
    speed features), plus seeded uniformly random bounded sequences that keep
    the car where the world lets it drive (|x| <= x_limit, |heading - pi/2| <= 0.5):
    the maximum of each feature over plausible driving, not over spinning cars.
    """
    K = world.n_knots
    accels = np.linspace(-1.0, 1.0, 9)
    const = np.stack([np.zeros((9, K)), np.repeat(accels[:, None], K, 1)], axis=-1)  # fractions of the bound
    rng = np.random.default_rng(seed)
    rand = rng.uniform(-1, 1, size=(n_random, K, 2))
    states = dynamics.rollout_np(rand)
    on_road = (np.abs(states[..., X]).max(1) <= world.x_limit) & (
        np.abs(states[..., HEADING] - np.pi / 2).max(1) <= 0.5)
    return np.concatenate([const, rand[on_road]])


def calibrate_normalisers(world: World = WORLD) -> np.ndarray:
    """(5,) divisors: 1 for closeness, the calibration-set maximum for 2-5.

    The goal feature's maximum is taken over both goals.  Fixed once; stored
    with every table.
    """
    ctrl = calibration_controls(world)
    n = len(ctrl)
    far = np.zeros((n, world.horizon + 1, 2))
    far[..., 1] = 1e6  # no other car: closeness is not normalised anyway
    raw = np.concatenate([raw_features(ctrl, far, np.full(n, g)) for g in (0, 1)])
    norm = raw.max(axis=0)
    norm[0] = 1.0
    return norm


_NORMALISERS = None


def default_normalisers() -> np.ndarray:
    """The project's fixed normalisation constants (computed once per process)."""
    global _NORMALISERS
    if _NORMALISERS is None:
        _NORMALISERS = calibrate_normalisers()
    return _NORMALISERS.copy()
