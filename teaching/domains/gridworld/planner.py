"""Exact optimal paths in the delivery yard, for every θ at once.

Every feature is a count of cells entered (moves by hand, moves with the cart, mud, next to the
dog) and every weight of θ is negative, so a path's reward θ·φ only falls as any count grows: the
optimum for any θ is one of the *non-dominated* feature vectors (no other path has every count as
low).  So each environment is solved once, for all θ: a label-setting search (Martins' algorithm
for several criteria, over states (cell, cart picked up), in layers of moves) finds every
non-dominated φ with one path for each, and each θ takes the φ of highest reward.  Exact by
construction: counts are integers, and each θ chooses among the front through
``teaching.core.rewards.reward`` (``teaching.domains._grid.domain.GridDomain.plan_chunk``).

Ties, a documented deterministic rule:
* of two paths with the same φ, the one whose move sequence comes first in the order right, up,
  down, left (the search creates labels in that order and keeps the first of equal ones);
* of two φ with the same reward under a θ, the one first in lexicographic order of
  (carry moves, cart moves, mud, near dog).
"""
from __future__ import annotations

import numpy as np

from .._grid.front import pareto_front
from .environments import Yard
from .world import CART, DOG, MOVES, MUD, WALL

PLANNER_VERSION = 1  # bump whenever a change alters the paths it returns


def planner_identity() -> dict:
    return {"version": PLANNER_VERSION, "algorithm": "label-setting over (cell, cart), layered by moves"}


def _step_features(yard: Yard) -> tuple[np.ndarray, np.ndarray]:
    """(height, width) int: the mud and near-dog count of entering each cell."""
    return (yard.cells == MUD).astype(np.int64), yard.near_dog().astype(np.int64)


def pareto_paths(yard: Yard) -> tuple[np.ndarray, list[list[tuple[int, int]]]]:
    """Every non-dominated feature vector of a path from start to goal, lexicographically sorted,
    and one path (cells visited, start first) for each: ((P, 4) int64, P lists of (row, col)).
    States are (cell, cart picked up): a move costs a carry or a cart move by whether the robot has it."""
    h, w = yard.cells.shape
    mud, near = _step_features(yard)
    blocked = (yard.cells == WALL) | (yard.cells == DOG)

    def successors(state):
        (r, c), has = state
        for dr, dc in MOVES:
            nr, nc = r + dr, c + dc
            if 0 <= nr < h and 0 <= nc < w and not blocked[nr, nc]:
                # entering the cart's cell picks it up: the moves after it are the cart's
                after = ((nr, nc), bool(has or yard.cells[nr, nc] == CART))
                yield after, (int(not has), int(has), int(mud[nr, nc]), int(near[nr, nc]))

    return pareto_front((yard.start, bool(yard.cells[yard.start] == CART)), successors, yard.goal, 4)
