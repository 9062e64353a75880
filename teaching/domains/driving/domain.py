"""The paper's car behind the :class:`~teaching.core.domain.Domain` interface.

A bicycle-model car on a 3-lane highway beside one other car (DESIGN §2-4): 21,216
environments in 4 classes, 8 strategy clusters (two per class), 5 cost features.  Everything
here delegates to the driving modules; this class only names them for the core (θ* parsing, all
five features being costs (DESIGN §3), and the stratified sample are the base domain's).
"""
from __future__ import annotations

from functools import cached_property
from pathlib import Path

import numpy as np

from ...core.base import BaseDomain
from ...core.build import Preset
from . import dynamics, environments, features, page, planner, strategies
from .world import FEATURE_NAMES, THETA_STAR, WORLD, world_fingerprint


class DrivingDomain(BaseDomain):
    name = "driving"
    n_environments = environments.N_ENVIRONMENTS
    class_names = environments.CLASS_NAMES
    cluster_names = strategies.CLUSTER_NAMES
    class_of_cluster = strategies.CLASS_OF_CLUSTER[:strategies.N_CLUSTERS]
    test_clusters = (strategies.MERGE_AHEAD, strategies.MERGE_BEHIND, strategies.BRAKE_STAY,
                     strategies.BRAKE_CHANGE, strategies.TAIL_CHANGE, strategies.TAIL_STAY)
    feature_names = FEATURE_NAMES
    vocabulary = frozenset({
        "driving", "car", "cars", "lane", "lanes", "merge", "merges", "merging", "braking", "brake", "tailgating",
        "overtake", "steer", "steering", "heading", "knot", "knots", "highway", "ft", "feet", "road", "wheelbase",
        "bicycle", "closeness", "acceleration", "turning"})
    theta_star = THETA_STAR
    min_option_distance = 0.5  # ~6 ft average lateral separation, or its equivalent (docs/teaching.md)
    trajectory_shape = (WORLD.n_knots, 2)  # knot controls [steer rate, accel] as fractions of the bounds
    trajectory_dtype = np.dtype(np.float32)
    state_scale = WORLD.state_scale  # [x ft, y ft, heading rad, v ft/s, steer rad]
    code_root = Path(__file__).resolve().parent
    texts = page.TEXTS
    palette = page.PALETTE
    page_keys = page.PAGE_KEYS

    @cached_property
    def presets(self) -> tuple[Preset, ...]:
        # built on first use: a Preset looks its domain up, which must be registered by then
        n_all = environments.N_ENVIRONMENTS
        return (Preset("tiny", n_envs=48, n_thetas=24, chunk_size=16, domain=self.name),
                Preset("demo", n_envs=1200, n_thetas=200, domain=self.name),
                Preset("paper", n_envs=n_all, n_thetas=1000, domain=self.name))

    def fingerprint(self) -> str:
        return world_fingerprint()

    def environment_class(self, env_ids) -> np.ndarray:
        return environments.environment_class(environments.get_environments(env_ids))

    def default_normalisers(self) -> np.ndarray:
        return features.default_normalisers()

    def planner_identity(self) -> dict:
        return planner.planner_identity()

    def plan_chunk(self, env_ids, thetas, normalisers) -> dict:
        return planner.plan_chunk(env_ids, thetas, normalisers)

    def states(self, controls) -> np.ndarray:
        return dynamics.rollout_np(controls)

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


DOMAIN = DrivingDomain()
