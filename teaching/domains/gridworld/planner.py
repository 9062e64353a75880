"""Exact optimal paths in the delivery yard, for every θ at once.

Every feature is a count of cells entered (moves by hand, moves with the cart, mud, next to the
dog) and every weight of θ is negative, so a path's reward θ·φ only falls as any count grows: the
optimum for any θ is one of the *non-dominated* feature vectors (no other path has every count as
low).  So each environment is solved once, for all θ: a label-setting search (Martins' algorithm
for several criteria, over states (cell, cart picked up), in layers of moves) finds every
non-dominated φ with one path for each, and each θ takes the φ of highest reward.  Exact by
construction: counts are integers, rewards go through ``teaching.core.rewards.reward``.

Ties, a documented deterministic rule:
* of two paths with the same φ, the one whose move sequence comes first in the order right, up,
  down, left (the search creates labels in that order and keeps the first of equal ones);
* of two φ with the same reward under a θ, the one first in lexicographic order of
  (carry moves, cart moves, mud, near dog).
"""
from __future__ import annotations

import numpy as np

from ...core.rewards import reward
from .environments import Yard, environment_class, get_yard
from .labels import strategy_labels
from .world import CART, DOG, GRID, MOVES, MUD, WALL

PLANNER_VERSION = 1  # bump whenever a change alters the paths it returns


def planner_identity() -> dict:
    return {"version": PLANNER_VERSION, "algorithm": "label-setting over (cell, cart), layered by moves"}


def _step_features(yard: Yard) -> tuple[np.ndarray, np.ndarray]:
    """(height, width) int: the mud and near-dog count of entering each cell."""
    return (yard.cells == MUD).astype(np.int64), yard.near_dog().astype(np.int64)


def _covers(a: tuple, b: tuple) -> bool:
    """a is at least as good as b: no count of a is larger."""
    return all(x <= y for x, y in zip(a, b, strict=True))


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
                if any(_covers(phi[j], new) for j in others):
                    continue  # an equal or better label is there: the first stays (the tie rule)
                for j in [j for j in others if _covers(new, phi[j])]:
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
    ends = [j for j in ends if not any(phi[k] != phi[j] and _covers(phi[k], phi[j]) for k in ends)]
    ends = sorted(ends, key=lambda j: (phi[j], j))
    paths = []
    for j in ends:
        path = []
        while j >= 0:
            path.append(cell[j])
            j = parent[j]
        paths.append(path[::-1])
    return np.array([phi[j] for j in ends], np.int64).reshape(-1, 4), paths


def encode(path: list[tuple[int, int]]) -> np.ndarray:
    """A path as the table stores it: (max_moves + 1,) int8 cell indices (row * width + col),
    the last cell repeated after arrival."""
    if len(path) > GRID.max_moves + 1:
        raise ValueError(f"a path of {len(path) - 1} moves is longer than the table holds ({GRID.max_moves})")
    out = np.empty(GRID.max_moves + 1, np.int8)
    idx = [r * GRID.width + c for r, c in path]
    out[:len(idx)] = idx
    out[len(idx):] = idx[-1]
    return out


def states(cells: np.ndarray) -> np.ndarray:
    """Stored paths (..., max_moves + 1) int8 -> positions (..., max_moves + 1, 2) float64 [col, row]."""
    cells = np.asarray(cells, np.int64)
    return np.stack([cells % GRID.width, cells // GRID.width], axis=-1).astype(np.float64)


def euclidean_distance(states_a, states_b) -> np.ndarray:
    """d_euclid = (1/T) sum_{t=1..T} |(s_a,t - s_b,t) / scale|_2 with T the longer path's moves (the
    shorter one waits at the drop-off, where both end), broadcast over the leading axes."""
    a, b = np.broadcast_arrays(np.asarray(states_a, np.float64), np.asarray(states_b, np.float64))
    diff = np.linalg.norm((a[..., 1:, :] - b[..., 1:, :]) / np.asarray(GRID.state_scale), axis=-1)
    return diff.sum(axis=-1) / np.maximum(_moves(a), _moves(b))


def _moves(s: np.ndarray) -> np.ndarray:
    """(..., L, 2) positions -> (...) moves made: the last step whose position differs from the end."""
    moving = np.any(s != s[..., -1:, :], axis=-1)  # (..., L): not yet at the end
    return np.where(moving.any(-1), moving.shape[-1] - np.argmax(moving[..., ::-1], -1), 1)


def plan_chunk(env_ids, thetas, normalisers) -> dict:
    """The optimal path of every (environment, θ): env_ids (n,), thetas (N, 4) (θ* first), normalisers
    (4,).  Returns controls (n, N, max_moves + 1) int8 cells, features (n, N, 4) float64 normalised,
    strategy (n, N) int8, d_euclid (n, N) float32 to θ*'s path."""
    env_ids = np.asarray(env_ids, np.int64)
    thetas = np.asarray(thetas, np.float64)
    n, N, L = len(env_ids), len(thetas), GRID.max_moves + 1
    out = {"controls": np.empty((n, N, L), np.int8), "features": np.empty((n, N, 4)),
           "strategy": np.empty((n, N), np.int8), "d_euclid": np.empty((n, N), np.float32)}
    classes = environment_class(env_ids)
    for k, env_id in enumerate(env_ids):
        phi, paths = pareto_paths(get_yard(env_id))
        feats = phi / np.asarray(normalisers, np.float64)  # (P, 4)
        pick = np.argmax(reward(feats[None, :, :], thetas[:, None, :]), axis=1)  # first of equal rewards
        # everything per front path (P <= 6), then each θ takes its path's
        encoded = np.stack([encode(p) for p in paths])
        labels = strategy_labels(phi, np.full(len(phi), classes[k]))
        pos = states(encoded)
        to_star = euclidean_distance(pos, pos[pick[0]][None])  # (P,) to θ*'s path
        out["controls"][k] = encoded[pick]
        out["features"][k] = feats[pick]
        out["strategy"][k] = labels[pick]
        out["d_euclid"][k] = to_star[pick]
    return out
