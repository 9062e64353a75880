"""A small grid world built only from the building blocks (teaching.core.base, teaching.domains._grid),
to show that a grid domain is its own world and nothing else, and to check the blocks end to end.

A rover crosses a 7 x 5 field from the left column to the right one, one cell per move, between
puddles and patches of sand.  Features, all costs counted per cell entered: moves, puddle cells, sand
cells.  Classes: *puddle* (every shortest path crosses the puddle) and *other*.  Strategies: through
or around the puddle; "other: cross".  Registered only by the tests that use it (:func:`registered`).
"""
from __future__ import annotations

import contextlib
import hashlib
from functools import cached_property
from pathlib import Path

import numpy as np

from teaching.core.build import Preset
from teaching.core.domain import LegendEntry, ParticipantTexts, register, unregister
from teaching.domains._grid.cells import shortest_moves
from teaching.domains._grid.domain import GridDomain
from teaching.domains._grid.front import cell_front

NAME = "small-grid"
WIDTH, HEIGHT, N_FIELDS = 7, 5, 600
FREE, PUDDLE, SAND = 0, 1, 2
MOVES = ((0, 1), (-1, 0), (1, 0), (0, -1))  # right, up, down, left: the tie rule's order
THROUGH, AROUND, CROSS = range(3)


def cells_of(env_id: int) -> tuple[np.ndarray, tuple, tuple]:
    """Field `env_id`: (HEIGHT, WIDTH) cell codes drawn from a generator seeded by the id (a quarter
    puddle, a fifth sand, the edge columns free), the start row and the goal row."""
    rng = np.random.default_rng([7, int(env_id)])
    start, goal = (int(v) for v in rng.integers(HEIGHT, size=2))
    u = rng.random((HEIGHT, WIDTH))
    cells = np.where(u < 0.25, PUDDLE, np.where(u < 0.45, SAND, FREE)).astype(np.int8)
    cells[:, [0, -1]] = FREE
    return cells, (start, 0), (goal, WIDTH - 1)


def env_class(env_id: int) -> int:
    cells, start, goal = cells_of(env_id)
    best = shortest_moves(np.ones(cells.shape, bool), start, goal, MOVES)
    return 0 if shortest_moves(cells != PUDDLE, start, goal, MOVES) > best else 1  # puddle, other


class SmallGridDomain(GridDomain):
    name = NAME
    n_environments = N_FIELDS
    class_names = ("puddle", "other")
    cluster_names = ("puddle: through", "puddle: around", "other: cross", "none of its class's strategies")
    class_of_cluster = np.array([0, 0, 1])
    test_clusters = (THROUGH, AROUND)
    feature_names = ("moves", "puddle", "sand")
    vocabulary = frozenset({"rover", "puddle", "sand", "field"})
    theta_star = np.array([-1.0, -2.0, -1.5])
    min_option_distance = 0.2
    width, max_moves = WIDTH, 19
    code_root = Path(__file__).resolve().parent
    page_keys = ("dt", "field")
    palette = {"free": "#f4f1e8", "grid": "#c8c2b4", "puddle": "#1d4ed8", "sand": "#e0c068",
               "sand-mark": "#8b5a2b", "robot": "#f5c518", "robot-edge": "#111111", "path": "#ff7a1a",
               "text": "#111111"}
    texts = ParticipantTexts(
        summary="you watch a rover cross a field and answer questions about what it prefers",
        consent="A research study about how people understand a rover's preferences.",
        instructions=("A rover crosses a field from S to D, one cell at a time, through or around puddles "
                      "(blue) and sand (dotted). You will watch {n_training} example{training_plural}, then "
                      "answer {n_tests} question{tests_plural}.",),
        attention_question="What did the rover do every time?",
        attention_choices=(("cross", "Crossed the field to D"), ("swim", "Swam in the puddle")),
        attention_correct=frozenset({"cross"}),
        watch="Watch how the rover crosses the field.",
        question="Which crossing matches the rover's preferences?",
        legend=(LegendEntry("the rover", "robot", "robot-edge"), LegendEntry("puddle", "puddle", "puddle"),
                LegendEntry("sand", "sand", "sand-mark")))

    @cached_property
    def presets(self) -> tuple[Preset, ...]:
        return (Preset("small-grid-tiny", n_envs=self.n_environments, n_thetas=40, chunk_size=64, domain=NAME),)

    def fingerprint(self) -> str:
        blob = repr((WIDTH, HEIGHT, N_FIELDS, MOVES, self.max_moves, self.feature_names)).encode()
        return hashlib.sha256(blob).hexdigest()[:16]

    @cached_property
    def _classes(self) -> np.ndarray:
        return np.array([env_class(i) for i in range(self.n_environments)], np.int8)

    def environment_class(self, env_ids) -> np.ndarray:
        return self._classes[np.asarray(env_ids, np.int64)]

    def planner_identity(self) -> dict:
        return {"version": 1, "algorithm": "pareto_front over cells"}

    def front(self, env_id):
        cells, start, goal = cells_of(env_id)
        entry = np.stack([np.ones(cells.shape), cells == PUDDLE, cells == SAND], axis=-1)
        return cell_front(entry, np.zeros(cells.shape, bool), start, goal, MOVES)

    def strategy_labels(self, phi, env_class):
        phi, cls = np.asarray(phi), np.asarray(env_class)
        return np.where(cls == 1, CROSS, np.where(phi[..., 1] > 0, THROUGH, AROUND)).astype(np.int8)

    def scene_payload(self, env_id) -> dict:
        cells, start, goal = cells_of(env_id)
        return {"dt": 0.3, "env_id": int(env_id),
                "field": {"cells": cells.astype(int).tolist(), "start": start[::-1], "goal": goal[::-1]}}


DOMAIN = SmallGridDomain()


@contextlib.contextmanager
def registered():
    """The small grid domain registered for the duration, then forgotten again, so code that
    iterates domain_names() elsewhere never meets it."""
    register(NAME, lambda: DOMAIN)
    try:
        yield DOMAIN
    finally:
        unregister(NAME)
