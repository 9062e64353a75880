"""The delivery gridworld behind the :class:`~teaching.core.domain.Domain` interface (docs/domains.md).

17,460 yards in 4 classes (mud, dog, cart, other), 7 strategy clusters, 4 cost features; paths are
exact (``planner``), so its tables are optimal by construction.
"""
from __future__ import annotations

from functools import cached_property
from pathlib import Path

import numpy as np

from ...core.build import Preset
from ...core.domain import parse_cost_weights
from . import environments, labels, page, planner
from .world import FEATURE_NAMES, GRID, THETA_STAR, world_fingerprint


class GridworldDomain:
    name = "gridworld"
    n_environments = environments.N_ENVIRONMENTS
    class_names = environments.CLASS_NAMES
    cluster_names = labels.CLUSTER_NAMES
    class_of_cluster = labels.CLASS_OF_CLUSTER
    # not the cart's: its yards have one way to carry by hand, so no test has 4 different options
    test_clusters = (labels.THROUGH_MUD, labels.AROUND_MUD, labels.PAST_DOG, labels.AROUND_DOG)
    feature_names = FEATURE_NAMES
    vocabulary = frozenset({"gridworld", "yard", "yards", "parcel", "parcels", "delivery", "deliveries", "mud",
                            "dog", "cart", "carts"})
    theta_star = THETA_STAR
    min_option_distance = 0.3  # cells per move, on average: a path in another row for a third of the way
    trajectory_shape = (GRID.max_moves + 1,)  # the cells visited, row * width + col
    trajectory_dtype = np.dtype(np.int8)
    code_root = Path(__file__).resolve().parent
    texts = page.TEXTS
    palette = page.PALETTE
    page_keys = page.PAGE_KEYS

    @cached_property
    def presets(self) -> tuple[Preset, ...]:
        n_all = environments.N_ENVIRONMENTS
        return (Preset("gridworld-tiny", n_envs=48, n_thetas=24, chunk_size=16, domain=self.name),
                Preset("gridworld", n_envs=1200, n_thetas=200, chunk_size=128, domain=self.name),
                Preset("gridworld-paper", n_envs=n_all, n_thetas=1000, chunk_size=128, domain=self.name))

    def fingerprint(self) -> str:
        return world_fingerprint()

    def parse_theta_star(self, values) -> tuple[float, ...]:
        return parse_cost_weights(values, len(FEATURE_NAMES))

    def environment_class(self, env_ids) -> np.ndarray:
        return environments.environment_class(env_ids)

    def stratified_sample(self, n: int, seed: int = 0) -> np.ndarray:
        return environments.stratified_sample(n, seed=seed)

    def default_normalisers(self) -> np.ndarray:
        return np.ones(len(FEATURE_NAMES))  # counts of cells are already on one scale

    def planner_identity(self) -> dict:
        return planner.planner_identity()

    def plan_chunk(self, env_ids, thetas, normalisers) -> dict:
        return planner.plan_chunk(env_ids, thetas, normalisers)

    def states(self, controls) -> np.ndarray:
        return planner.states(controls)

    def euclidean_distance(self, states_a, states_b) -> np.ndarray:
        return planner.euclidean_distance(states_a, states_b)

    def scene_payload(self, env_id) -> dict:
        return page.scene_payload(env_id)

    def path_rows(self, states) -> list:
        return page.path_rows(states)

    def page_scene(self, payload) -> dict:
        return page.page_scene(payload)

    def caption(self, payload):
        return page.caption(payload)

    def study_view(self, scenes) -> dict:
        return page.study_view(scenes)

    def render_sheet(self, **kwargs) -> int:
        from .sheet import render_sheet  # noqa: PLC0415  (matplotlib loads only for a sheet)

        return render_sheet(**kwargs)


DOMAIN = GridworldDomain()
