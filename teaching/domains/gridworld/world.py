"""Constants of the delivery gridworld (units: cells, moves).

A delivery robot carries a parcel across a small yard from the left edge to a drop-off spot on
the right edge, one cell per move (right, up, down or left).  What it weighs (the features, all
costs counted per cell entered): moves carrying the parcel by hand, moves pushing a cart (a cart
standing in the yard, picked up by entering its cell, makes every later move cheaper: a detour
that can pay off), mud cells entered, and cells entered next to the dog.  Walls and the dog's own
cell cannot be entered.  Everything a table depends on is in :data:`GRID`, whose fingerprint every
table stores.
"""
from __future__ import annotations

import hashlib
import json
from dataclasses import asdict, dataclass

import numpy as np


@dataclass(frozen=True)
class Grid:
    width: int = 8  # columns; the robot starts in column 0 and delivers in column width - 1
    height: int = 6  # rows, row 0 at the top
    max_moves: int = 31  # a table's path holds max_moves + 1 cells (the longest optimal path: 22 moves)
    # the Euclidean learner compares cell positions: one cell = one unit
    state_scale: tuple = (1.0, 1.0)


GRID = Grid()
FEATURE_NAMES = ("carry_moves", "cart_moves", "mud", "near_dog")
# θ*: a move by hand costs 1, with the cart 0.3; a mud cell 2.5 moves' worth, a cell next to the
# dog 1.2 (docs/domains.md: both strategies of each class in at least 5 % of its environments)
THETA_STAR = np.array([-1.0, -0.3, -2.5, -1.2])

# cell codes
FREE, WALL, MUD, DOG, CART = 0, 1, 2, 3, 4
# moves in tie-break order: of two paths with the same features, the one whose move sequence comes
# first in this order is kept (docs/domains.md)
MOVES = ((0, 1), (-1, 0), (1, 0), (0, -1))  # (d_row, d_col): right, up, down, left


def world_fingerprint(grid: Grid = GRID) -> str:
    """16 hex digits over the grid's constants and θ*-independent rules (the cell codes and moves)."""
    blob = json.dumps({"grid": asdict(grid), "moves": MOVES, "codes": [FREE, WALL, MUD, DOG, CART],
                       "features": FEATURE_NAMES}, sort_keys=True).encode()
    return hashlib.sha256(blob).hexdigest()[:16]
