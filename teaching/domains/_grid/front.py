"""Every non-dominated path of a grid world whose features are counts added by each move.

A label-setting search (Martins' algorithm for several criteria), layered by moves, over states
(cell, extra): ``extra`` is whatever else the robot carries that changes what a move costs (a thing
it picked up on the way; None for a robot that is only where it is).  At each state it keeps the
labels no other label there covers; at the goal cell, the non-dominated ones over every state
there, sorted, with a path each.

Ties, a deterministic rule: of two paths with the same φ, the one whose move sequence comes first
in the order the domain's ``successors`` yields moves (labels are created in that order and the
first of equal ones stays); the front is sorted lexicographically by φ.
"""
from __future__ import annotations

from collections.abc import Callable, Iterable

import numpy as np

State = tuple  # ((row, col), extra)


def covers(a: tuple, b: tuple) -> bool:
    """a is at least as good as b: no count of a is larger."""
    return all(x <= y for x, y in zip(a, b, strict=True))


def pareto_front(start: State, successors: Callable[[State], Iterable[tuple[State, tuple]]], goal,
                 n_features: int) -> tuple[np.ndarray, list[list[tuple[int, int]]]]:
    """successors(state) -> (next state, the counts the move adds) for every move allowed there, in
    the tie rule's order.  Returns ((P, n_features) int64 non-dominated φ, lexicographically sorted,
    P paths [(row, col), ...] start first)."""
    goal = tuple(goal)
    phi, parent, state = [(0,) * n_features], [-1], [start]
    live: dict[State, list[int]] = {start: [0]}  # state -> labels not dominated there
    dead = [False]
    layer = [0]
    while layer:
        created = []
        for i in layer:
            if dead[i] or state[i][0] == goal:  # a path ends where it arrives
                continue
            for nxt, added in successors(state[i]):
                new = tuple(a + b for a, b in zip(phi[i], added, strict=True))
                others = live.setdefault(nxt, [])
                if any(covers(phi[j], new) for j in others):
                    continue  # an equal or better label is there: the first stays (the tie rule)
                for j in [j for j in others if covers(new, phi[j])]:
                    dead[j] = True
                    others.remove(j)
                phi.append(new)
                parent.append(i)
                state.append(nxt)
                dead.append(False)
                others.append(len(phi) - 1)
                created.append(len(phi) - 1)
        layer = created
    ends = [j for s, labels in live.items() if s[0] == goal for j in labels]
    ends = [j for j in ends if not any(phi[k] != phi[j] and covers(phi[k], phi[j]) for k in ends)]
    ends = sorted(ends, key=lambda j: (phi[j], j))
    paths = []
    for j in ends:
        path = []
        while j >= 0:
            path.append(state[j][0])
            j = parent[j]
        paths.append(path[::-1])
    return np.array([phi[j] for j in ends], np.int64).reshape(-1, n_features), paths


def cell_front(entry: np.ndarray, blocked: np.ndarray, start, goal, moves) -> tuple[np.ndarray, list]:
    """:func:`pareto_front` of a robot that is only where it is: entering cell (r, c) adds
    entry[r, c] (H, W, D) counts; `blocked` (H, W) cells cannot be entered; `moves` in tie order."""
    entry = np.asarray(entry, np.int64)
    h, w, n_features = entry.shape
    adds = {(r, c): tuple(int(v) for v in entry[r, c]) for r in range(h) for c in range(w)}

    def successors(s):
        (r, c), _ = s
        for dr, dc in moves:
            nr, nc = r + dr, c + dc
            if 0 <= nr < h and 0 <= nc < w and not blocked[nr, nc]:
                yield ((nr, nc), None), adds[nr, nc]

    return pareto_front((tuple(start), None), successors, goal, n_features)
