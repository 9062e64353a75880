"""Synthetic trajectory tables for tests and benchmarks (not for studies).

A synthetic table mimics the structure the teaching code relies on without
running the planner: in each environment there is a small set of candidate
trajectories (random knot controls rolled out with a NumPy copy of the
DESIGN §2 dynamics, random normalised features), and every θ "plans" by
taking the candidate with the highest reward under θ.  So, as in a real table
after the cross-θ step, ``d_reward >= 0`` holds exactly and several θ share a
trajectory.  Strategy labels are *assigned* to candidates (alternating
between the two clusters of the environment's class), not computed from the
trajectory: good enough to exercise coverage and test-set selection.
"""
from __future__ import annotations

import numpy as np

from ...core.table import TrajectoryTable
from .environments import N_ENVIRONMENTS, OTHER, environment_class, get_environments, stratified_sample
from .strategies import OTHER_FORWARD, OTHER_MERGE
from .world import GOAL_MERGE, THETA_STAR, WORLD


class SyntheticTable(TrajectoryTable):
    """A TrajectoryTable that also keeps its candidates' states.

    ``cand_states`` (M, C, T+1, 5) float32 and ``choice`` (M, N) int: θ n's
    trajectory in environment m is candidate ``choice[m, n]``.  ``states``
    reads them instead of rolling controls out, so tests do not depend on
    the planner's dynamics module.
    """

    cand_states: np.ndarray
    choice: np.ndarray

    def states(self, env_index, theta_index) -> np.ndarray:
        return self.cand_states[env_index, self.choice[env_index, theta_index]].astype(np.float64)


def sample_thetas(n: int, rng: np.random.Generator, theta_star=THETA_STAR) -> np.ndarray:
    """(n, 5): θ* first, then log-uniform within one decade of |θ*_i| (DESIGN §4), negative."""
    theta_star = np.asarray(theta_star, dtype=np.float64)
    rest = -np.abs(theta_star) * 10.0 ** rng.uniform(-1, 1, size=(n - 1, len(theta_star)))
    return np.vstack([theta_star[None], rest])


def euler_rollout(knots: np.ndarray, world=WORLD) -> np.ndarray:
    """NumPy explicit Euler of DESIGN §2, knots as fractions of the control bounds
    (the stored convention of teaching.domains.driving.dynamics): (..., K, 2) -> states (..., T+1, 5)."""
    u = np.repeat(np.asarray(knots, np.float64), world.steps_per_knot, axis=-2) * world.control_bounds
    lead = u.shape[:-2]
    s = np.zeros(lead + (world.horizon + 1, 5))
    s[..., 0, 2], s[..., 0, 3] = np.pi / 2, world.v_init
    for t in range(world.horizon):
        x, y, h, v, st = (s[..., t, i] for i in range(5))
        s[..., t + 1, 0] = x + v * np.cos(h) * world.dt
        s[..., t + 1, 1] = y + v * np.sin(h) * world.dt
        s[..., t + 1, 2] = h + v / world.wheelbase * np.tan(st) * world.dt
        s[..., t + 1, 3] = v + u[..., t, 1] * world.dt  # accel_max keeps v > 0 within T
        s[..., t + 1, 4] = np.clip(st + u[..., t, 0] * world.dt, -world.steer_max, world.steer_max)
    return s


def candidate_distances(cand_states: np.ndarray, scale=WORLD.state_scale) -> np.ndarray:
    """(M, C, T+1, 5) -> (M, C, C) float32: (1/T) Σ_{t=1..T} ‖(s_a - s_b)/scale‖₂."""
    s = cand_states[:, :, 1:] / np.asarray(scale, dtype=np.float32)
    diff = s[:, :, None] - s[:, None, :]
    return np.sqrt((diff ** 2).sum(-1)).mean(-1).astype(np.float32)


def synthetic_table(n_envs: int = 64, n_thetas: int = 50, n_candidates: int = 4, seed: int = 0,
                    env_ids=None, chunk: int = 2048, max_stored: int = 4_000_000) -> SyntheticTable:
    """A seeded synthetic table of shape (n_envs, n_thetas); thetas[0] = θ*.

    env_ids default to a class-stratified sample (all 21,216 ids when
    n_envs == 21216).  Memory: features are (M, N, 5) float64 — 850 MB at
    paper size; above ``max_stored`` (env, θ) pairs the controls are a
    zero-cost broadcast view of zeros instead of the candidates' knots.
    """
    rng = np.random.default_rng(seed)
    if env_ids is None:
        env_ids = np.arange(N_ENVIRONMENTS) if n_envs == N_ENVIRONMENTS else stratified_sample(n_envs, seed)
    env_ids = np.asarray(env_ids, dtype=np.int64)
    m, c = len(env_ids), n_candidates
    envs = get_environments(env_ids)
    cls = environment_class(envs)
    thetas = sample_thetas(n_thetas, rng)

    knots = rng.uniform(-0.5, 0.5, size=(m, c, WORLD.n_knots, 2)).astype(np.float32)
    cand_states = euler_rollout(knots).astype(np.float32)
    cand_feat = rng.uniform(0, 1, size=(m, c, 5))
    cand_feat[:, :, 0] *= 0.05  # closeness is weighted by |θ*_0| = 64: keep trade-offs balanced
    # "other" environments barely matter to any θ: one dominant candidate, like the real domain
    other = cls == OTHER
    cand_feat[other, 1:] = cand_feat[other, :1] + 1e-3 * cand_feat[other, 1:]

    cand_cluster = np.where(envs.goal == GOAL_MERGE, OTHER_MERGE, OTHER_FORWARD)[:, None].repeat(c, 1)
    informative = ~other
    cand_cluster[informative] = (2 * cls[informative])[:, None] + (np.arange(c) % 2)[None]

    choice = np.empty((m, n_thetas), dtype=np.int64)
    for lo in range(0, m, chunk):
        choice[lo:lo + chunk] = np.einsum("mcf,nf->mnc", cand_feat[lo:lo + chunk], thetas).argmax(-1)
    rows = np.arange(m)[:, None]
    features = cand_feat[rows, choice]  # (M, N, 5)
    strategy = cand_cluster[rows, choice].astype(np.int8)
    cdist = candidate_distances(cand_states)
    d_euclid = cdist[rows, choice, choice[:, :1]]  # distance of each θ's trajectory to θ*'s

    if m * n_thetas <= max_stored:
        controls = knots[rows, choice]  # real knots: a saved table rolls out to cand_states
    else:  # paper size: 1.7 GB of controls nobody reads in a benchmark
        controls = np.broadcast_to(np.zeros((1, 1, WORLD.n_knots, 2), np.float32), (m, n_thetas, WORLD.n_knots, 2))
    table = SyntheticTable(thetas=thetas, env_ids=env_ids, controls=controls, features=features,
                           strategy=strategy, d_euclid=d_euclid.astype(np.float32),
                           normalisers=np.ones(5), meta={"preset": "synthetic", "seed": seed,
                                                         "sampler": "synthetic"})
    table.cand_states = cand_states
    table.choice = choice
    return table


def hand_table(d_reward: np.ndarray, d_euclid=None, strategy=None, env_ids=None) -> TrajectoryTable:
    """A table whose d_reward equals the given (M, N) matrix (column 0 must be 0).

    Features are built so that (φ(ξ^θ) - φ(ξ^θ*))·θ = d_reward with θ_0 = θ* and
    θ_n = -(n+1)·e_0 otherwise: lets tests write distances by hand.
    """
    d_reward = np.asarray(d_reward, dtype=np.float64)
    m, n = d_reward.shape
    thetas = np.zeros((n, 5))
    thetas[:, 0] = -(np.arange(n) + 1.0)
    thetas[0] = THETA_STAR
    features = np.zeros((m, n, 5))
    features[:, :, 0] = 1.0 - d_reward / -thetas[None, :, 0]  # θ0·(φ_n - φ_*) = d
    features[:, 0, 0] = 1.0
    if env_ids is None:
        env_ids = np.arange(m, dtype=np.int64)
    d_euclid = np.zeros((m, n), np.float32) if d_euclid is None else np.asarray(d_euclid, np.float32)
    strategy = np.zeros((m, n), np.int8) if strategy is None else np.asarray(strategy, np.int8)
    controls = np.zeros((m, n, WORLD.n_knots, 2), np.float32)
    return TrajectoryTable(thetas=thetas, env_ids=np.asarray(env_ids, np.int64), controls=controls,
                           features=features, strategy=strategy, d_euclid=d_euclid,
                           normalisers=np.ones(5), meta={"preset": "hand"})
