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

from .._grid.front import covers
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
    and one path (cells visited, start first) for each: ((P, 4) int64, P lists of (row, col))."""
    h, w = yard.cells.shape
    mud, near = _step_features(yard)
    blocked = (yard.cells == WALL) | (yard.cells == DOG)
    phi, parent, cell, cart = [(0, 0, 0, 0)], [-1], [yard.start], [yard.cells[yard.start] == CART]
    live: dict[tuple, list[int]] = {(yard.start, cart[0]): [0]}  # state -> labels not dominated there
    dead = [False]
    layer = [0]
    while layer:
        created = []
        for i in layer:
            if dead[i] or cell[i] == yard.goal:  # delivered: a path ends at the drop-off
                continue
            r, c = cell[i]
            for dr, dc in MOVES:
                nr, nc = r + dr, c + dc
                if not (0 <= nr < h and 0 <= nc < w) or blocked[nr, nc]:
                    continue
                has = cart[i] or yard.cells[nr, nc] == CART
                carry, pushed, m, d = phi[i]
                new = (carry + (not cart[i]), pushed + bool(cart[i]), m + int(mud[nr, nc]), d + int(near[nr, nc]))
                state = ((nr, nc), has)
                others = live.setdefault(state, [])
                if any(covers(phi[j], new) for j in others):
                    continue  # an equal or better label is there: the first stays (the tie rule)
                for j in [j for j in others if covers(new, phi[j])]:
                    dead[j] = True
                    others.remove(j)
                phi.append(new)
                parent.append(i)
                cell.append((nr, nc))
                cart.append(has)
                dead.append(False)
                others.append(len(phi) - 1)
                created.append(len(phi) - 1)
        layer = created
    ends = [j for has in (False, True) for j in live.get((yard.goal, has), [])]
    ends = [j for j in ends if not any(phi[k] != phi[j] and covers(phi[k], phi[j]) for k in ends)]
    ends = sorted(ends, key=lambda j: (phi[j], j))
    paths = []
    for j in ends:
        path = []
        while j >= 0:
            path.append(cell[j])
            j = parent[j]
        paths.append(path[::-1])
    return np.array([phi[j] for j in ends], np.int64).reshape(-1, 4), paths
