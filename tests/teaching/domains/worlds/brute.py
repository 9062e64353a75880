"""An independent reference for grid worlds from a file: the best reward of every environment by
enumerating every action sequence up to the horizon (memoised on (state, actions left), which visits
the same sequences as the enumeration tree), from the file's parsed fields alone.

It shares nothing with teaching.domains._grid.fileworld but the parsed World: its own transition
rules (written from docs/gridworlds.md), no Pareto fronts, no tie rule, and its own replay of a stored
trajectory into counts.
"""
from __future__ import annotations

from functools import cache

import numpy as np

from teaching.domains._grid.worldfile import HELD, World

STEPS = {"right": (0, 1), "up": (-1, 0), "down": (1, 0), "left": (0, -1)}


def _moves_count(f, action, holding) -> int:
    """1 if a "moves" feature counts this action (docs/gridworlds.md)."""
    if action in f.also:  # named pick-ups and drops count, held or not
        return 1
    return int(action in STEPS and (f.holding is None or f.holding == holding))


def step(world: World, variant: int, state, action):
    """(next state, counts added (D,), ended) of `action` in `state`, or None if it is not allowed."""
    kinds, blocked = world.cells(variant), world.blocked(variant)
    (r, c), obj = state
    holding = obj == HELD
    add = np.zeros(len(world.features), np.int64)
    if action == "exit":
        return (state, add, True) if world.exit else None
    if action in STEPS:
        dr, dc = STEPS[action]
        cell = (r + dr, c + dc)
        if not (0 <= cell[0] < world.height and 0 <= cell[1] < world.width) or blocked[cell]:
            return None
        ended = False
        for i, f in enumerate(world.features):
            if f.counts == "moves":
                add[i] = _moves_count(f, action, holding)
            elif f.counts == "enter":
                add[i] = int(kinds[cell] == f.cell)
            elif f.counts == "reach" and f.at == cell and not ended:
                add[i], ended = 1, True
        return (cell, obj), add, ended
    if action == "pickup":
        if obj is None or obj == HELD or obj != (r, c):
            return None
        nxt = ((r, c), HELD)
    elif action == "drop":
        if not holding:
            return None
        nxt = ((r, c), (r, c))
    else:
        raise ValueError(action)
    ended = False
    for i, f in enumerate(world.features):
        if f.counts == "moves":
            add[i] = _moves_count(f, action, holding)
        elif f.counts == "deliver" and action == "drop" and world.destination == (r, c) and not ended:
            add[i], ended = 1, True
    return nxt, add, ended


ACTIONS = ("right", "up", "down", "left", "pickup", "drop", "exit")


def best_rewards(world: World, variant: int, start, thetas: np.ndarray, horizon: int) -> np.ndarray:
    """(T,) for thetas (T, D): the highest θ·φ of any action sequence from start state `start` of at most
    `horizon` actions that ends the episode (by a terminal feature or exit); -inf where none does."""
    return best_rewards_from(world, variant, [start], thetas, horizon)[0]


def best_rewards_from(world: World, variant: int, starts, thetas: np.ndarray, horizon: int) -> np.ndarray:
    """(S, T): best_rewards from each of the start states `starts`, one memo for all of them."""
    thetas = np.asarray(thetas, np.float64)

    @cache
    def best(state, left: int) -> np.ndarray:
        out = np.full(len(thetas), -np.inf)
        for action in ACTIONS:
            if left == 0 and action != "exit":
                continue
            moved = step(world, variant, state, action)
            if moved is None:
                continue
            nxt, add, ended = moved
            gain = thetas @ add
            out = np.maximum(out, gain if ended else gain + best(nxt, left - 1))
        return out

    return np.array([best(s, horizon) for s in starts]).reshape(len(starts), len(thetas))


def reachable(world: World, variant: int) -> set:
    """Every state the file's starts reach by allowed actions, but those in which the episode has ended
    (this module's own rules, breadth first)."""
    seen, queue = set(world.starts), list(world.starts)
    while queue:
        state = queue.pop()
        for action in ACTIONS[:-1]:
            moved = step(world, variant, state, action)
            if moved is not None and not moved[2] and moved[0] not in seen:
                seen.add(moved[0])
                queue.append(moved[0])
    return seen


def replay(world: World, variant: int, start, cells_holding: list) -> np.ndarray:
    """Counts (D,) of a stored trajectory given as [(row, col, holding)] per action, start first:
    each step is the one action that leads there (a move, a pick-up or a drop); the episode then
    ends by the terminal feature it reached, else by exit; `start` the start state."""
    state = start
    assert (state[0][0], state[0][1], int(state[1] == HELD)) == tuple(cells_holding[0])
    total = np.zeros(len(world.features), np.int64)
    ended = False
    for r, c, h in cells_holding[1:]:
        assert not ended, "the trajectory goes on after its episode ended"
        for action in ACTIONS[:-1]:
            moved = step(world, variant, state, action)
            if moved and moved[0][0] == (r, c) and int(moved[0][1] == HELD) == h:
                state, add, ended = moved
                total += add
                break
        else:
            raise AssertionError(f"no action leads from {state} to {(r, c, h)}")
    assert ended or world.exit, "the trajectory neither reached an ending nor may exit"
    return total


_MOVE = {(1, 0): "right", (-1, 0): "left", (0, -1): "up", (0, 1): "down"}


def actions_of(world: World, rows: list) -> list[str]:
    """The actions that draw a page's path `rows` ([col, row, holding] per action, start first), then
    "exit" unless the last cell is a goal or the last action delivered the object: read off the rows."""
    out = []
    for (c0, r0, h0), (c1, r1, h1) in zip(rows, rows[1:], strict=False):
        out.append(_MOVE[(c1 - c0, r1 - r0)] if (c0, r0) != (c1, r1) else ("pickup" if h1 > h0 else "drop"))
    goals = {f.at for f in world.features if f.counts == "reach"}
    delivers = any(f.counts == "deliver" for f in world.features)
    delivered = delivers and out and out[-1] == "drop" and world.destination == (rows[-1][1], rows[-1][0])
    if (rows[-1][1], rows[-1][0]) not in goals and not delivered:
        out.append("exit")
    return out
