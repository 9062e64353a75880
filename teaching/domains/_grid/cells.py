"""Paths on a grid as a table stores them, their states, and shortest paths (the distance between two
paths is teaching.core.pathdistance's).

Units: cells and moves.  A cell (row, col) is stored as ``row * width + col`` (int8: a grid of at
most 127 cells); a path is the cells it visits, start first, padded to a fixed length by
repeating its last cell (the robot waits where it arrived), so ``states`` needs no environment.
"""
from __future__ import annotations

from collections import deque

import numpy as np


def encode(path, width: int, length: int) -> np.ndarray:
    """A path [(row, col), ...] -> (length,) int8 cell indices, the last cell repeated after arrival."""
    if len(path) > length:
        raise ValueError(f"a path of {len(path) - 1} moves is longer than the table holds ({length - 1})")
    out = np.empty(length, np.int8)
    idx = [r * width + c for r, c in path]
    out[:len(idx)] = idx
    out[len(idx):] = idx[-1]
    return out


def cell_states(cells: np.ndarray, width: int) -> np.ndarray:
    """Stored paths (..., L) cell indices -> positions (..., L, 2) float64 [col, row]."""
    cells = np.asarray(cells, np.int64)
    return np.stack([cells % width, cells // width], axis=-1).astype(np.float64)


def shortest_moves(passable: np.ndarray, start, goal, moves) -> float:
    """Fewest moves from start to goal (row, col) through `passable` (H, W) cells, each move one of
    `moves` ((d_row, d_col), ...), by breadth-first search; inf if there is no way."""
    h, w = passable.shape
    dist = np.full((h, w), -1)
    dist[start] = 0
    queue = deque([start])
    while queue:
        r, c = queue.popleft()
        if (r, c) == tuple(goal):
            return float(dist[r, c])
        for dr, dc in moves:
            nr, nc = r + dr, c + dc
            if 0 <= nr < h and 0 <= nc < w and passable[nr, nc] and dist[nr, nc] < 0:
                dist[nr, nc] = dist[r, c] + 1
                queue.append((nr, nc))
    return float("inf")


def neighbours(mask: np.ndarray) -> np.ndarray:
    """(H, W) bool -> the cells next to a True cell (its 8 neighbours), not themselves True."""
    near = np.zeros(mask.shape, bool)
    for r, c in zip(*np.nonzero(mask), strict=True):
        near[max(r - 1, 0):r + 2, max(c - 1, 0):c + 2] = True
    return near & ~mask
