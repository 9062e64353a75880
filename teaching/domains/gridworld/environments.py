"""The delivery yards: 17,460 environments, their stable ids, layouts and classes.

Enumeration order (documented, never to change): the id is the mixed-radix number over
(start row 6, drop-off row 6, obstacle 97, cart 5), first axis most significant.  The robot starts
at (start row, column 0) and delivers at (drop-off row, column 7).  Obstacles, in order:

    0          none
    1 .. 72    a mud band from column c (c = 2, 3, 4) over every row but a gap g (0..5); its
               thickness per row by profile p: 1 everywhere, 2 everywhere, 1 in rows 0-2 and 2 in
               rows 3-5, or the reverse (index 1 + (c-2)*24 + p*6 + g)
    73 .. 96   the dog at (row r, column c), c = 3, 4, r = 0..5; in the second 12 a wall fills its
               column except the dog's neighbours and the row farthest from it
               (index 73 + wall*12 + (c-3)*6 + r)

Carts: 0 none, then one cart at (row 0, column 1), (row 5, column 1), (row 0, column 6),
(row 5, column 6).

Classes come from the layout and shortest paths (in moves), never from θ: *mud* when every
shortest path crosses mud, *dog* when every shortest path passes next to the dog (and a way around
exists), else *cart* when fetching the cart is a detour (no shortest path passes it), else *other*.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from .._grid import cells as grid_cells
from .world import CART, DOG, FREE, GRID, MOVES, MUD, WALL

N_STARTS = N_GOALS = GRID.height
N_OBSTACLES = 97
CARTS = (None, (0, 1), (5, 1), (0, 6), (5, 6))  # (row, col)
AXES = (N_STARTS, N_GOALS, N_OBSTACLES, len(CARTS))
N_ENVIRONMENTS = int(np.prod(AXES))  # 17,460
MUD_PROFILES = ((1,) * 6, (2,) * 6, (1, 1, 1, 2, 2, 2), (2, 2, 2, 1, 1, 1))  # thickness per row

MUD_CLASS, DOG_CLASS, CART_CLASS, OTHER = 0, 1, 2, 3
CLASS_NAMES = ("mud", "dog", "cart", "other")


@dataclass(frozen=True)
class Yard:
    """One environment: cells (height, width) int8 codes, start and goal (row, col)."""

    env_id: int
    cells: np.ndarray
    start: tuple[int, int]
    goal: tuple[int, int]

    def near_dog(self) -> np.ndarray:
        """(height, width) bool: cells next to the dog (its 8 neighbours), entering one costs."""
        return grid_cells.neighbours(self.cells == DOG)


def layout_cells(obstacle: int, cart: int) -> np.ndarray:
    """(height, width) int8 cell codes of obstacle 0 .. N_OBSTACLES - 1 with cart 0 .. 4 (module docstring)."""
    if not (0 <= obstacle < N_OBSTACLES and 0 <= cart < len(CARTS)):
        raise ValueError(f"no such layout: obstacle {obstacle}, cart {cart}")
    h, w = GRID.height, GRID.width
    cells = np.full((h, w), FREE, np.int8)
    if 1 <= obstacle <= 72:
        c, p, g = np.unravel_index(obstacle - 1, (3, 4, 6))
        for row, thick in enumerate(MUD_PROFILES[p]):
            if row != g:
                cells[row, 2 + c:2 + c + thick] = MUD
    elif obstacle >= 73:
        wall, c, r = np.unravel_index(obstacle - 73, (2, 2, 6))
        c += 3
        if wall:
            cells[:, c] = WALL
            cells[max(r - 1, 0):r + 2, c] = FREE
            cells[0 if r >= h / 2 else h - 1, c] = FREE
        cells[r, c] = DOG
    if CARTS[cart] is not None:
        cells[CARTS[cart]] = CART
    return cells


def get_yard(env_id: int) -> Yard:
    env_id = int(env_id)
    if not 0 <= env_id < N_ENVIRONMENTS:
        raise ValueError(f"environment ids must lie in [0, {N_ENVIRONMENTS}); got {env_id}")
    rs, rd, obstacle, cart = (int(v) for v in np.unravel_index(env_id, AXES))
    return Yard(env_id, layout_cells(obstacle, cart), (rs, 0), (rd, GRID.width - 1))


def shortest_moves(passable: np.ndarray, start, goal) -> float:
    """Fewest moves from start to goal through `passable` cells (breadth-first), inf if none."""
    return grid_cells.shortest_moves(passable, start, goal, MOVES)


def yard_class(yard: Yard) -> int:
    """The environment's class (module docstring), from shortest paths alone."""
    open_ = (yard.cells != WALL) & (yard.cells != DOG)
    best = shortest_moves(open_, yard.start, yard.goal)
    if (yard.cells == MUD).any() and shortest_moves(open_ & (yard.cells != MUD), yard.start, yard.goal) > best:
        return MUD_CLASS
    if (yard.cells == DOG).any() and best < shortest_moves(open_ & ~yard.near_dog(), yard.start, yard.goal) < np.inf:
        return DOG_CLASS
    if (yard.cells == CART).any():
        cart = tuple(int(v) for v in np.argwhere(yard.cells == CART)[0])
        via = shortest_moves(open_, yard.start, cart) + shortest_moves(open_, cart, yard.goal)
        return CART_CLASS if via > best else OTHER
    return OTHER


@lru_cache(maxsize=1)
def all_classes() -> np.ndarray:
    """(N_ENVIRONMENTS,) int8 class of every environment (computed once: a few seconds)."""
    return np.array([yard_class(get_yard(i)) for i in range(N_ENVIRONMENTS)], np.int8)


def environment_class(env_ids) -> np.ndarray:
    ids = np.asarray(env_ids, np.int64)
    if len(ids) and (ids.min() < 0 or ids.max() >= N_ENVIRONMENTS):
        raise ValueError(f"environment ids must lie in [0, {N_ENVIRONMENTS}); got {ids.min()}..{ids.max()}")
    return all_classes()[ids]
