"""The delivery gridworld behind the :class:`~teaching.core.domain.Domain` interface (docs/domains.md).

17,460 yards in 4 classes (mud, dog, cart, other), 7 strategy clusters, 4 cost features; paths are
exact (``planner``: the front of each yard; ``teaching.domains._grid``: each θ's choice), so its
tables are optimal by construction.  The defaults (cost-only θ*, unit normalisers, the stratified
sample, the page's keys) are the base domain's.
"""
from __future__ import annotations

from functools import cached_property
from pathlib import Path

from ...core.build import Preset
from .._grid.domain import GridDomain
from . import environments, labels, page, planner
from .world import FEATURE_NAMES, GRID, THETA_STAR, world_fingerprint


class GridworldDomain(GridDomain):
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
    width = GRID.width
    max_moves = GRID.max_moves
    state_scale = GRID.state_scale
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

    def environment_class(self, env_ids):
        return environments.environment_class(env_ids)

    def planner_identity(self) -> dict:
        return planner.planner_identity()

    def front(self, env_id):
        return planner.pareto_paths(environments.get_yard(env_id))

    def strategy_labels(self, phi, env_class):
        return labels.strategy_labels(phi, env_class)

    def scene_payload(self, env_id) -> dict:
        return page.scene_payload(env_id)

    def render_sheet(self, **kwargs) -> int:
        from .sheet import render_sheet  # noqa: PLC0415  (matplotlib loads only for a sheet)

        return render_sheet(**kwargs)


DOMAIN = GridworldDomain()
