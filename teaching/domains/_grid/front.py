"""Every non-dominated path of a grid world whose features are counts of the cells entered.

For a domain whose robot carries no state but its cell (a domain with more, such as a thing it
picks up on the way, writes its own search over (cell, state)): ``entry`` (H, W, D) is what
entering each cell adds to φ, ``blocked`` (H, W) the cells it cannot enter.  A label-setting
search (Martins' algorithm for several criteria), layered by moves, keeps at each cell the
labels no other label there covers; at the goal, the non-dominated ones, sorted, with a path each.

Ties, a deterministic rule: of two paths with the same φ, the one whose move sequence comes first
in the order of ``moves`` (labels are created in that order and the first of equal ones stays).
"""
from __future__ import annotations

import numpy as np


def covers(a: tuple, b: tuple) -> bool:
    """a is at least as good as b: no count of a is larger."""
    return all(x <= y for x, y in zip(a, b, strict=True))


def pareto_front(entry: np.ndarray, blocked: np.ndarray, start, goal, moves) -> tuple[np.ndarray, list]:
    """((P, D) int64 non-dominated φ, lexicographically sorted, P paths [(row, col), ...] start first)."""
    entry = np.asarray(entry, np.int64)
    h, w, n_features = entry.shape
    start, goal = tuple(start), tuple(goal)
    phi, parent, cell = [(0,) * n_features], [-1], [start]
    live: dict[tuple, list[int]] = {start: [0]}  # cell -> labels not dominated there
    dead = [False]
    layer = [0]
    while layer:
        created = []
        for i in layer:
            if dead[i] or cell[i] == goal:  # a path ends where it arrives
                continue
            r, c = cell[i]
            for dr, dc in moves:
                nr, nc = r + dr, c + dc
                if not (0 <= nr < h and 0 <= nc < w) or blocked[nr, nc]:
                    continue
                new = tuple(int(a + b) for a, b in zip(phi[i], entry[nr, nc], strict=True))
                others = live.setdefault((nr, nc), [])
                if any(covers(phi[j], new) for j in others):
                    continue  # an equal or better label is there: the first stays (the tie rule)
                for j in [j for j in others if covers(new, phi[j])]:
                    dead[j] = True
                    others.remove(j)
                phi.append(new)
                parent.append(i)
                cell.append((nr, nc))
                dead.append(False)
                others.append(len(phi) - 1)
                created.append(len(phi) - 1)
        layer = created
    ends = sorted(live.get(goal, []), key=lambda j: (phi[j], j))
    paths = []
    for j in ends:
        path = []
        while j >= 0:
            path.append(cell[j])
            j = parent[j]
        paths.append(path[::-1])
    return np.array([phi[j] for j in ends], np.int64).reshape(-1, n_features), paths
