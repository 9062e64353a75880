"""Lee, Admoni & Simmons' three worlds as the shipped files give them, with no edited copy: each variant's
start pool is every state their starts reach (the authors draw demonstrations and tests from every state
of their MDP but the terminal ones), every start of it is planned within the file's max_moves, θ*'s way
scores regret 0, and three worse ways (a detour, a needless toll or walk along the walls, an early exit)
score the regret worked by hand here and found by an independent brute force over the world's action
sequences (tests/teaching/domains/worlds/brute.py: its own transition rules and replay)."""
from __future__ import annotations

import numpy as np
import pytest

from teaching.core.domain import domain_names, get_domain
from teaching.domains import WORLDS
from teaching.domains._grid.filedomain import world_domain
from tests.teaching.domains.worlds import brute
from tests.teaching.domains.worlds.shipped import NAMES

# world -> the pool's size in each variant that blocks no optional cell, worked by hand: taxi 12 cells but
# 2 walls, the robot on any of the 10, the passenger held or on the ground anywhere but at the destination
# (dropping them there ends the episode); two-goal 25 cells but the two goals (reaching one ends it);
# skateboard 28 cells but 5 walls and the goal, the robot on 22, the board held or on any of those 22
POOL_SIZE = {"taxi": 10 * (9 + 1), "two-goal": 25 - 2, "skateboard": 22 * (22 + 1)}


def test_the_three_worlds_are_registered_by_default():
    assert set(NAMES) <= set(domain_names())
    for name in NAMES:  # the registered domain is the shipped file's
        assert get_domain(name).fingerprint() == world_domain(WORLDS / f"{name}.toml").fingerprint()


@pytest.mark.parametrize("name", NAMES)
def test_each_pool_is_every_state_the_starts_reach(name):
    domain = world_domain(WORLDS / f"{name}.toml")
    world = domain.world
    assert domain.n_environments == sum(len(p) for p in domain.pools)
    assert len(domain.pools[0]) == POOL_SIZE[name]
    full = world.n_variants - 1  # every optional cell on
    for variant in (0, full, world.n_variants // 3):
        pool = domain.pools[variant]
        assert pool[:len(world.starts)] == world.starts  # the file's starts first, in the file's order
        assert len(set(pool)) == len(pool) and set(pool) == brute.reachable(world, variant)
        # a variant's pool lies within the pool of the variant that blocks nothing
        assert set(pool) <= set(domain.pools[0])


@pytest.mark.parametrize("name", NAMES)
def test_every_start_is_planned_and_theta_stars_way_scores_regret_0(name):
    """Every state of the widest pool (no optional cell on: it holds every other variant's starts), planned
    in that variant and with every optional cell on, within max_moves; θ*'s best reward from each equals the
    brute force's, and θ*'s own way, shown, scores regret 0."""
    domain = get_domain(name)
    world = domain.world
    for variant in (0, world.n_variants - 1):
        starts = domain.pools[variant]
        best = brute.best_rewards_from(world, variant, starts, domain.theta_star[None], world.max_moves)[:, 0]
        for k in range(len(starts)):
            env = domain.environment_id(variant, k)
            phi, paths = domain.front(env)  # raises if any candidate is longer than max_moves
            assert max(len(p) for p in paths) - 1 <= world.max_moves
            star = int(np.argmax(phi @ domain.theta_star))
            # tolerance: rewards are sums of a few dozen weights of size ≤ 26, exact to ~1e-13
            assert phi[star] @ domain.theta_star == pytest.approx(best[k], abs=1e-9), (variant, starts[k])
            rows = [[c, r, int(place == "held")] for (r, c), place in paths[star]]
            score = domain.score_shown(env, brute.actions_of(world, rows))
            assert score["optimal"] and score["regret"] == pytest.approx(0, abs=1e-9)


# (world, variant, start's place in its pool, θ*'s way, [(what it is, a worse way, its regret by hand)])
WAYS = [
    # taxi, the toll at [3, 2] on (bit 4): pick up at [4, 1], three left, drop: 26 - 5 steps = 21
    ("taxi", 1 << 4, 0, ["pickup", "left", "left", "left", "drop"], [
        ("detour", ["pickup", "up", "down", "left", "left", "left", "drop"], 2.0),  # 2 steps more
        ("needless toll", ["pickup", "up", "left", "down", "left", "left", "drop"], 5.0),  # 2 steps, 1 toll (3)
        ("early exit", ["pickup", "left", "exit"], 23.0),  # -2 instead of 21
    ]),
    # two goals, the walls at [1, 4], [2, 4], [3, 4] on (bits 0-2): from [3, 5] to the goal worth 10.5 at
    # [5, 2] in 5 moves, 5.5
    ("two-goal", 0b111, 0, ["right", "right", "down", "down", "down"], [
        ("detour", ["left", "right", "right", "right", "down", "down", "down"], 2.0),
        # round the wall to the goal worth 7.25 at [1, 1]: 8 moves, -0.75
        ("walk round the wall", ["right", "down", "down", "left", "left", "left", "down", "down"], 6.25),
        ("early exit", ["exit"], 5.5),
    ]),
    # skateboard, no optional wall: fetch the board at [2, 3] (3 steps, a pick-up), ride 11 moves to the
    # goal at [6, 4]: 9 - 3 - 12 * 0.3 = 2.4
    ("skateboard", 0, 0, ["down", "left", "left", "pickup", "right", "right", "down", "down", "right", "right",
                          "right", "up", "up", "up", "left"], [
        ("detour", ["left", "right", "down", "left", "left", "pickup", "right", "right", "down", "down",
                    "right", "right", "right", "up", "up", "up", "left"], 2.0),
        # on foot down the wall, along the bottom row, up the right-hand column to the goal: 10 steps, -1
        ("walk along the wall", ["down", "down", "down", "right", "right", "right", "up", "up", "up", "left"],
         3.4),
        ("early exit", ["down", "left", "left", "pickup", "exit"], 5.7),  # 3 steps and a pick-up: -3.3
    ]),
]


@pytest.mark.parametrize("name, variant, start, star_way, worse", WAYS, ids=[w[0] for w in WAYS])
def test_worse_ways_score_the_regret_a_brute_force_gives(name, variant, start, star_way, worse):
    domain = get_domain(name)
    world = domain.world
    env = domain.environment_id(variant, start)
    _, start_state = domain.environment(env)
    theta = np.asarray(world.theta_star)
    best = brute.best_rewards(world, variant, start_state, theta[None], world.max_moves)[0]
    assert domain.score_shown(env, star_way)["regret"] == pytest.approx(0, abs=1e-9)
    for what, way, by_hand in [("theta*'s way", star_way, 0.0), *worse]:
        state, counts = start_state, np.zeros(len(theta))
        for action in way:  # brute's own replay: its transition rules, not the planner's
            state, add, _ = brute.step(world, variant, state, action)
            counts += add
        reference = best - counts @ theta
        score = domain.score_shown(env, way)
        # tolerance: regrets are differences of sums of at most 20 weights given to 2 decimals
        assert reference == pytest.approx(by_hand, abs=1e-9), what
        assert score["regret"] == pytest.approx(reference, abs=1e-9), what
        assert score["counts"] == counts.astype(int).tolist(), what
        # the authors' units: θ* scaled to an L1 norm of 1 (their params.py)
        assert score["regret_normalised"] == pytest.approx(reference / np.abs(theta).sum(), abs=1e-12), what


@pytest.mark.parametrize("name", NAMES)
def test_a_preset_of_a_reachable_pool_gets_the_environments_it_names_with_a_share_per_class(name):
    domain = get_domain(name)
    ids = domain.stratified_sample(48, seed=4)
    assert len(ids) == len(set(ids.tolist())) == 48 and np.all(np.diff(ids) > 0)
    assert np.array_equal(ids, domain.stratified_sample(48, seed=4))  # seeded
    classes = domain.environment_class(ids)
    # 24 of each class where the class has 24 members; two-goal has no "other" environment (from every start
    # both goals are somebody's best), so its 48 are all of the one class
    expected = [48] if name == "two-goal" else [24, 24]
    assert sorted(np.bincount(classes, minlength=len(domain.class_names)).tolist(), reverse=True)[:len(expected)] \
        == expected
