"""A grid world from a file as a domain: exact optimal trajectories, environments, classes, labels.

An environment is a variant (a set of optional cells switched on) and a start state from the variant's
start pool (:func:`start_pool`): the file's starts, and with ``start_pool = "reachable"`` every state they
reach.  A state is (robot cell, where the object is: its cell, HELD, or None).
Actions, in the tie rule's order: move right, up, down, left (into a cell of the grid that is not
blocked), pick up (where the object lies), drop (while holding it), exit (where the file allows it).

Exact for every θ at once, as every grid domain (teaching.domains._grid.domain): a feature that can
grow without end is a cost (the file's θ* and every candidate weigh it negatively), and the features
that end an episode ("reach", "deliver"; and exit, which adds nothing) happen once.  So for each
way an episode can end, the optimal trajectory of any θ is one of that ending's *non-dominated*
cost-count vectors; a label-setting search (Martins' algorithm, layered by actions) finds them all
with one trajectory each, and each θ takes the highest reward among all endings' fronts through
``teaching.core.rewards.reward`` (the first of equal rewards: endings in the order reach/deliver
features, then exit; within one, fronts sorted lexicographically by φ).

Ties between trajectories with the same φ and ending: the first found in action order (labels are
created in that order and the first of equal ones stays).

A trajectory is stored as (max_moves + 1,) int16 codes ``cell * 2 + holding``, one per action
taken, start first, padded by repeating the last (the robot stays where the episode ended).
"""
from __future__ import annotations

import hashlib
import json
from collections.abc import Iterable
from dataclasses import asdict

import numpy as np

from ...core.i18n import TranslatableError
from ...core.i18n import gettext_noop as _
from .front import covers
from .worldfile import HELD, MOVES, World, WorldFileError

EXIT = "exit"
# what a participant may do when showing the way, in the order successors() yields the actions; a refusal
# names them, so each is marked for the catalogs as the participant's word for that action
# Translators: the robot's actions when a participant shows the way (a move one cell right, up, down or left,
# picking the object up, putting it down, stopping where it is), named in a way that cannot be submitted
ACTIONS = (_("right"), _("up"), _("down"), _("left"), _("pickup"), _("drop"), _("exit"))
_STEP = dict(zip(ACTIONS[:4], MOVES, strict=True))  # a move's name -> (d_row, d_col)


def world_fingerprint(world: World) -> str:
    """16 hex digits over everything in the file that decides a table's bytes (not colours or texts)."""
    blob = {k: v for k, v in asdict(world).items()
            if k not in ("kinds", "texts", "translations", "source", "title", "presets")
            and not (k == "start_pool" and v == "listed")}  # a file without the field keeps its tables
    blob["passable"] = {k: v.passable for k, v in world.kinds.items()}
    blob["fixed"] = sorted((list(c), k) for c, k in world.fixed.items())
    blob["moves"] = MOVES
    return hashlib.sha256(json.dumps(blob, sort_keys=True, default=str).encode()).hexdigest()[:16]


def endings(world: World) -> tuple:
    """The ways an episode can end, in the tie order: each terminal feature's index, then EXIT."""
    return tuple(i for i, f in enumerate(world.features) if f.terminal) + ((EXIT,) if world.exit else ())


def successors(world: World, kinds: np.ndarray, blocked: np.ndarray, state) -> Iterable[tuple]:
    """Every action allowed in `state`, in the tie order: (next state or None, counts added, ending
    or None); an ending's terminal feature is among the counts added (1, once: the episode ends).
    kinds (H, W) the variant's cell kinds, blocked (H, W) bool."""
    (r, c), place = state
    holding = place == HELD
    feats = world.features

    def counts(action: str, entered, ending=None) -> tuple[int, ...]:
        out = []
        for i, f in enumerate(feats):
            if f.terminal:
                hit = i == ending
            elif f.counts == "moves":
                # a pick-up or drop a feature names in `also` counts whatever the robot holds
                hit = action in f.also or (action == "move" and (f.holding is None or f.holding == holding))
            else:  # "enter"
                hit = action == "move" and kinds[entered] == f.cell
            out.append(int(hit))
        return tuple(out)

    h, w = blocked.shape
    for dr, dc in MOVES:
        nr, nc = r + dr, c + dc
        if 0 <= nr < h and 0 <= nc < w and not blocked[nr, nc]:
            reached = next((i for i, f in enumerate(feats) if f.counts == "reach" and f.at == (nr, nc)), None)
            yield ((nr, nc), place), counts("move", (nr, nc), reached), reached
    if place is not None and place != HELD and place == (r, c):
        yield ((r, c), HELD), counts("pickup", None), None
    if holding:
        delivered = next((i for i, f in enumerate(feats) if f.counts == "deliver" and world.destination == (r, c)),
                         None)
        yield ((r, c), (r, c)), counts("drop", None, delivered), delivered
    if world.exit:
        yield None, (0,) * len(feats), EXIT


class ReplayError(TranslatableError):
    """A shown way the world does not allow (play): one line, str() in English, translatable."""


def start_pool(world: World, variant: int) -> tuple:
    """The start states of variant `variant`, in order: the file's starts, then (``start_pool =
    "reachable"``) every other state they reach by the actions successors() allows, breadth first in
    the tie order, but for the states in which an episode has ended (a goal reached, the object
    delivered): the pool Lee, Admoni & Simmons draw demonstrations and tests from (every state of
    their MDP but the terminal ones).  WorldFileError for a file's start inside a blocked cell."""
    kinds, blocked = world.cells(variant), world.blocked(variant)
    for i, (cell, _place) in enumerate(world.starts):
        if blocked[cell]:
            raise WorldFileError(f"{world.source}: starts[{i}].at: the robot starts inside a blocked cell "
                                 f"in variant {variant}")
    pool = dict.fromkeys(world.starts)
    if world.start_pool == "reachable":
        queue = list(pool)
        for state in queue:  # grows as it is read: breadth first
            for nxt, _, ending in successors(world, kinds, blocked, state):
                if ending is None and nxt not in pool:
                    pool[nxt] = None
                    queue.append(nxt)
    return tuple(pool)


def play(world: World, variant: int, start, actions, states: list | None = None) -> tuple[np.ndarray, object]:
    """Replay `actions` (names of :data:`ACTIONS`) from start state `start` of variant `variant`: ((D,) int64
    counts, the ending reached (a terminal feature's index or EXIT)); every state the robot is in, start
    first, is appended to `states` if given (the trajectory, as the planner's paths list it).
    ReplayError (a ValueError, one line) for an action not allowed where it is taken, an action after the
    episode ended, or actions that stop before it ends."""
    kinds, blocked = world.cells(variant), world.blocked(variant)
    state, counts = start, np.zeros(len(world.features), np.int64)
    states = [] if states is None else states
    states.append(state)
    for k, name in enumerate(actions):
        if name not in ACTIONS:
            raise ReplayError(_("action {number}: {name} is not one of {actions}"), words=("actions",),
                              number=k + 1, name=repr(name), actions=ACTIONS)
        r, c = state[0]
        step = _STEP.get(name)
        target = (r + step[0], c + step[1]) if step else None
        allowed = successors(world, kinds, blocked, state)
        taken = next((t for t in allowed if _is_action(name, state, t[0], t[2], target)), None)
        if taken is None:
            raise ReplayError(_("action {number}: {action} is not possible at [{x}, {y}]"), words=("action",),
                              number=k + 1, action=name, x=c + 1, y=world.height - r)
        nxt, added, ending = taken
        counts += added
        if nxt is not None:
            states.append(nxt)
        if ending is not None:
            if k != len(actions) - 1:
                raise ReplayError(_("action {number}: the episode ended at action {ended}"), number=k + 2, ended=k + 1)
            return counts, ending
        state = nxt
    raise ReplayError(_("the actions stop before the episode ends (reach a goal, deliver, or exit)"))


def _is_action(name: str, state, nxt, ending, target) -> bool:
    """Whether the transition successors() yielded (nxt, ending) from `state` is action `name`."""
    if name == EXIT:
        return ending == EXIT
    if nxt is None:
        return False
    if target is not None:
        return nxt[0] == target
    held_before, held_after = state[1] == HELD, nxt[1] == HELD
    picked = held_after and not held_before
    return nxt[0] == state[0] and (picked if name == "pickup" else held_before and not held_after)


def fronts(world: World, variant: int, start) -> tuple[np.ndarray, list[list]]:
    """Every (ending, non-dominated φ) of environment (variant, start state) with one trajectory each:
    ((P, D) int64 φ, the ending's terminal feature counted once; P lists of states, start first),
    endings in :func:`endings` order and each ending's φ sorted lexicographically."""
    kinds, blocked = world.cells(variant), world.blocked(variant)
    n = len(world.features)
    phi, parent, state = [(0,) * n], [-1], [start]
    live = {start: [0]}  # state -> labels no other label there covers
    dead: set[int] = set()
    ends: dict = {e: [] for e in endings(world)}
    layer = [0]
    while layer:
        created = []
        for i in layer:
            if i in dead:
                continue
            for nxt, added, ending in successors(world, kinds, blocked, state[i]):
                new = tuple(a + b for a, b in zip(phi[i], added, strict=True))
                if ending is not None:
                    if not any(covers(phi[j], new) for j in ends[ending]):
                        phi.append(new)
                        parent.append(i)
                        state.append(nxt)  # None for an exit: the trajectory ends at its parent
                        ends[ending] = [j for j in ends[ending] if not covers(new, phi[j])] + [len(phi) - 1]
                    continue
                others = live.setdefault(nxt, [])
                if any(covers(phi[j], new) for j in others):
                    continue
                for j in [j for j in others if covers(new, phi[j])]:
                    dead.add(j)
                    others.remove(j)
                phi.append(new)
                parent.append(i)
                state.append(nxt)
                others.append(len(phi) - 1)
                created.append(len(phi) - 1)
        layer = created
    out_phi, paths = [], []
    for ending in endings(world):
        for j in sorted(ends[ending], key=lambda j: (phi[j], j)):
            path, k = [], j if state[j] is not None else parent[j]
            while k >= 0:
                path.append(state[k])
                k = parent[k]
            out_phi.append(phi[j])
            paths.append(path[::-1])
    return np.array(out_phi, np.int64).reshape(-1, n), paths
