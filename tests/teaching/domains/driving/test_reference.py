"""The independent reference solver (driving/reference.py): KKT points, never worse than its own starts,
independent of the planner's strategy seeds, and the sign of reference_gap."""
import inspect

import numpy as np
import pytest

from teaching.core.candidates import sample_thetas
from teaching.core.table import TrajectoryTable
from teaching.domains.driving import kernels, reference
from teaching.domains.driving.dynamics import rollout_np
from teaching.domains.driving.environments import environment_id, get_environments, other_car_states
from teaching.domains.driving.features import default_normalisers, raw_features, reward
from teaching.domains.driving.planner import objective_weights, plan_chunk, strategy_seeds
from teaching.domains.driving.world import THETA_STAR, WORLD

K = WORLD.n_knots
PROBLEMS = [
    environment_id(0, 100, 2, 50),  # merging: a car close ahead in the right lane, at the robot's speed
    environment_id(1, 120, 1, 30),  # braking: a slower car ahead in the centre lane
]


def _F_and_grad(z, oxy, goal, w):
    g = np.empty(2 * K)
    F = kernels.objective_grad_hess(np.ascontiguousarray(z, np.float64).reshape(K, 2), np.ascontiguousarray(oxy[:, 0]),
                                    np.ascontiguousarray(oxy[:, 1]), int(goal), w, g, np.empty((2 * K, 2 * K)), False)
    return F, g


@pytest.fixture(scope="module")
def solved():
    envs = get_environments(PROBLEMS)
    oxy = other_car_states(envs)
    w = objective_weights(THETA_STAR, default_normalisers())[0]
    return [(oxy[i], envs.goal[i], w, reference.solve_reference(oxy[i], envs.goal[i], w)) for i in range(len(PROBLEMS))]


@pytest.mark.parametrize("i", range(len(PROBLEMS)))
def test_the_answer_is_a_kkt_point(solved, i):
    oxy, goal, w, r = solved[i]
    F, g = _F_and_grad(r["z"], oxy, goal, w)
    z = r["z"].reshape(-1)
    assert np.abs(z).max() <= 1.0
    assert np.abs(z - np.clip(z - g, -1.0, 1.0)).max() < 1e-7
    assert F == pytest.approx(r["F"], abs=1e-15)


@pytest.mark.parametrize("i", range(len(PROBLEMS)))
def test_at_least_as_good_as_every_start_and_every_local_solution(solved, i):
    oxy, goal, w, r = solved[i]
    F = _F_and_grad(r["z"], oxy, goal, w)[0]
    assert len(r["starts"]) >= 20
    assert F <= min(_F_and_grad(s, oxy, goal, w)[0] for s in r["starts"])
    assert F <= min(_F_and_grad(z, oxy, goal, w)[0] for z in r["local"]) + 1e-15


def test_the_starts_are_its_own_diverse_and_not_the_planners_seeds():
    starts = reference.reference_starts()
    assert len(starts) >= 20 and np.abs(starts).max() <= 1.0
    seeds = strategy_seeds()
    shared = np.abs(starts[:, None] - seeds[None]).max(axis=(2, 3)).min(axis=0) < 1e-2  # (seeds,)
    assert shared.sum() < len(seeds) / 2  # at most the obvious straight drives coincide
    assert not np.any(shared & (np.abs(seeds[..., 0]).max(axis=1) > 0))  # no lane change of the planner's
    assert "strategy_seeds" not in inspect.getsource(reference)
    x_end = rollout_np(starts)[:, -1, 0]
    for lane in WORLD.lane_centres:  # every lane is some start's end lane
        assert np.any(np.abs(x_end - lane) < 0.5), lane


def test_reference_gap_positive_for_a_bad_trajectory_and_zero_for_its_own():
    norm = default_normalisers()
    ids = np.array(PROBLEMS)
    thetas = sample_thetas(3, seed=4, theta_star=THETA_STAR)
    table = TrajectoryTable(thetas=thetas, env_ids=ids, normalisers=norm, **plan_chunk(ids, thetas, norm))
    envs, oxy = get_environments(table.env_ids), other_car_states(get_environments(table.env_ids))

    def store(m, n, z):  # exactly as the planner stores a trajectory: float32 controls, their features
        z = np.asarray(z, np.float32)
        table.controls[m, n] = z
        table.features[m, n] = raw_features(z[None].astype(np.float64), oxy[[m]], envs.goal[[m]])[0] / norm

    brake = np.stack([np.zeros(K), -np.ones(K)], axis=-1)  # full braking, straight ahead
    store(0, 1, brake)
    store(1, 2, brake)
    gap, sol = reference.reference_gap(table, [(0, 1), (1, 2)], n_jobs=2, return_solutions=True)
    z_ref = sol["z"]
    assert np.all(gap > 1e-3), gap
    assert np.all(sol["pg"] < 1e-7)
    # the reference's own answer stored in the table: the reference finds nothing better
    store(0, 1, z_ref[0])
    assert abs(reference.reference_gap(table, [(0, 1)], n_jobs=1)[0]) < 1e-6
    # and the gap is the reward difference under theta over |theta|, in the table's own units
    mine = reward(raw_features(brake[None], oxy[[1]], envs.goal[[1]])[0] / norm, thetas[2])
    ref = reward(raw_features(z_ref[1][None], oxy[[1]], envs.goal[[1]])[0] / norm, thetas[2])
    assert gap[1] == pytest.approx((ref - mine) / np.linalg.norm(thetas[2]), rel=1e-12)
