"""The distance between two paths recorded on one clock, for any robot whose states are poses over time.

A path that arrives early waits where it arrived (its last state repeats to the clock's end).  The distance
averages the scaled gap between the two paths over the steps until the later one has arrived, not over the
waiting after it, so a short path is not made to look close by its padding.  The grid domains use it on cells,
an imported robot on its recorded poses.
"""
from __future__ import annotations

import numpy as np


def moves_made(s: np.ndarray) -> np.ndarray:
    """(..., L, S) states -> (...) steps taken: the last step whose state differs from the end (at least 1,
    so a distance never divides by zero)."""
    moving = np.any(s != s[..., -1:, :], axis=-1)  # (..., L): not yet at the end
    return np.where(moving.any(-1), moving.shape[-1] - np.argmax(moving[..., ::-1], -1), 1)


def padded_distance(states_a, states_b, scale) -> np.ndarray:
    """d_euclid = (1/T) sum_{t=1..T} |(s_a,t - s_b,t) / scale|_2 with T the longer path's steps (the
    shorter one waits where it arrived), broadcast over the leading axes: (..., L, S) x (..., L, S) -> (...).
    scale (S,): each state column's unit (inf: the column is not compared)."""
    a, b = np.broadcast_arrays(np.asarray(states_a, np.float64), np.asarray(states_b, np.float64))
    diff = np.linalg.norm((a[..., 1:, :] - b[..., 1:, :]) / np.asarray(scale), axis=-1)
    return diff.sum(axis=-1) / np.maximum(moves_made(a), moves_made(b))
