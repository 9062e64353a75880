"""Optimal trajectories xi_E^theta for many (environment, theta) at once (DESIGN §4).

Longer than 400 lines because the steps below (anchors, warm starts, the cross-θ pass, settling) are one
algorithm whose order decides a table's bytes; each step is its own function, read top to bottom.

The objective theta . phi is non-convex (ahead of vs behind the other car), so
a local optimiser alone is wrong.  For one chunk of environments:

1. **anchors**: a few thetas spread over Theta (farthest-point order in
   log|theta|, theta* first) are solved from every strategy seed (all of them
   when Theta is small), and the next few in that order from the two straight
   seeds at higher and lower speed (speeding up and dropping back in lane are
   the basins warm starts from lane changes miss) and from the two double lane
   changes (a zigzag's basin no single lane change leads to);
2. **continuation over theta**: the thetas in the same farthest-point order,
   in rounds of doubling size (A, A, 2A, 4A, ... for A anchors); each starts from the best,
   under it, of everything solved so far in its environment (the anchors' seed
   solutions and all earlier rounds), and is solved by projected Newton.  A
   later theta lies close to an earlier one, so it starts near its optimum
   and in the best basin found so far;
3. **cross-theta**: every theta takes the best, under theta, of all
   trajectories found for any theta' in that environment;
4. **refine**: a theta that took another theta's trajectory is solved again
   from it (it lies in a better basin), then step 3 is repeated;
5. **hops**: a trajectory that crosses lane lines five or more times (a
   zigzag over all three lanes and back) is solved again from its own controls moved one knot
   earlier -- each timing of its moves is a basin of its own, and Newton keeps
   the timing it starts with -- and steps 3-4 run again, in the environments
   where a hop did better, with these as extra candidates.

6. **exact**: every theta's trajectory is solved again with the world's limits as hard
   constraints (:mod:`teaching.domains.driving.constrained`, sequential quadratic programming from the penalty's
   answer, which lies a little inside each limit it presses against), and steps 3-4 run again
   among those trajectories (docs/decisions.md, "The world's limits as hard constraints").

After step 3 every theta's stored trajectory is at least as good under theta as
theta*'s, so d_reward >= 0 holds exactly on the stored (float32) trajectories.
Newton uses exact Hessians (:mod:`teaching.domains.driving.kernels`, :mod:`.newton`); it is parallel over
problems with Numba threads and holds no state between calls, so it is safe in
a forked worker as long as the parent process has not run it (docs/decisions.md).
"""
from __future__ import annotations

import functools
import json
from dataclasses import asdict, dataclass

import numpy as np

from ...core import detmath
from . import constrained, kernels, newton
from .dynamics import rollout_np
from .environments import get_environments, other_car_states
from .features import raw_features, reward
from .strategies import lane_crossings, strategy_labels
from .world import WORLD

PLANNER_VERSION = 12  # bump whenever a change alters the trajectories it returns
NEWTON_TOL = 1e-7  # max |projected gradient|, normalised reward units per unit of z (1e-9 changed no gap)
REFINE_GAIN = 1e-6  # normalised reward units: exact IRL's tolerance (1e-7 and 1e-8 changed no measured gap)
FEAS_TOL = 1e-9  # ft: how far past a limit the constrained solve may end (teaching.domains.driving.constrained)
STORED_FEAS_TOL = 1e-4  # ft: ... and a stored (float32) trajectory that may be handed over (measured: < 2e-5)


@dataclass(frozen=True)
class PlannerSettings:
    n_anchors: int = 2  # solved from every seed; 8 is as good as 2 + the straight anchors below, at 1.3x the time
    straight_anchors: int = 8  # the next thetas in anchor order, solved from the straight seeds at higher and
    straight_seeds: tuple = (1, 2, 8, 9)  # lower speed (warm starts missed those basins most), and from the double
    #                                       lane changes (env 18182 / theta 861 needs them; docs/decisions.md)
    all_anchors_below: int = 32  # with so few thetas the cross-theta step has little to share: multi-start all
    anchor_iters: int = 200
    warm_iters: int = 200  # a cap, not a budget: warm starts run until Newton converges (NEWTON_TOL)
    refine_rounds: int = 1
    hop_min_crossings: int = 5  # lane-line crossings that make a trajectory hop (step 5): across all three lanes
    #                             and back; 3 (one lane, then two back) found 7 more of 128,000 pairs at 1.07x the time
    hop_shifts: tuple = (-1,)  # knots; (-1, +1) found 2 more pairs above 1e-4 in 128,000, at 1.17x the time
    exact: bool = True  # step 6: the world's limits as hard constraints (constrained.py)


def planner_identity(settings: PlannerSettings = None) -> dict:
    """Everything about the planner that a stored chunk's content depends on, as JSON would give it back
    (tuples as lists), so an identity read from a job spec or meta.json compares equal."""
    return json.loads(json.dumps({"version": PLANNER_VERSION, "newton_tol": NEWTON_TOL, "refine_gain": REFINE_GAIN,
                                  **asdict(settings or PlannerSettings())}))


def strategy_seeds() -> np.ndarray:
    """The 10 strategy seeds (10, K, 2) in [-1, 1]: straight at constant / higher /
    lower speed, lane change right (early at constant and higher speed; late
    while braking: merge behind), lane change left (early, constant / higher speed),
    and a double lane change each way (one lane left, then two right; and the mirror).

    The double lane changes are there because the optimum of some thetas is one: on 1,000
    random benchmark pairs the independent reference found a left-then-right-across
    optimum 1.1e-4 better than anything the 8 other seeds led to (docs/benchmarks.md).
    """
    K = WORLD.n_knots
    lane = np.zeros(K)
    lane[:4] = [-0.45, 0.45, 0.45, -0.45]  # one lane to the right (-steer turns towards +x) in ~2 s
    late = np.roll(lane, 4)

    def seed(steer, accel):
        return np.stack([steer, np.full(K, accel)], axis=-1)

    zero = np.zeros(K)
    return np.array([
        seed(zero, 0.0), seed(zero, 0.5), seed(zero, -0.5),
        seed(lane, 0.0), seed(lane, 0.5), seed(late, -0.5),
        seed(-lane, 0.0), seed(-lane, 0.5),
        seed(-lane + 2 * late, 0.0), seed(lane - 2 * late, 0.0),
    ])


def objective_weights(thetas: np.ndarray, normalisers: np.ndarray) -> np.ndarray:
    """(N, 5) weights w of the minimised F = w . phi_raw, in normalised reward units."""
    thetas = np.atleast_2d(thetas)
    return -thetas / np.linalg.norm(thetas, axis=1, keepdims=True) / normalisers


def anchor_order(thetas: np.ndarray) -> np.ndarray:
    """Farthest-point order of the thetas in log10|theta| space, starting with index 0."""
    thetas = np.ascontiguousarray(thetas, dtype=np.float64)
    return _anchor_order(thetas.tobytes(), thetas.shape).copy()


@functools.lru_cache(maxsize=4)
def _anchor_order(data: bytes, shape: tuple) -> np.ndarray:
    # cached: every chunk of a build asks for the same order (O(N^2): 1.5 % of a paper build)
    # detmath's correctly rounded log10: np.log10's AVX-512 loop differs in the last bit, and a tie
    # broken otherwise would reorder the anchors (and the table's bytes) on another CPU
    pts = detmath.log10(np.abs(np.frombuffer(data).reshape(shape)))
    order = [0]
    dist = np.linalg.norm(pts - pts[0], axis=1)
    for _ in range(len(pts) - 1):
        nxt = int(np.argmax(dist))
        order.append(nxt)
        dist = np.minimum(dist, np.linalg.norm(pts - pts[nxt], axis=1))
    return np.array(order)


def solve(z0, other_xy, goal, weights, maxiter):
    """Projected Newton from z0 (B, K, 2); returns (z, F, iterations)."""
    z = np.ascontiguousarray(z0, dtype=np.float64).copy()
    n = len(z)
    F = np.empty(n)
    its = np.empty(n, np.int64)
    if n:
        newton.solve_batch(z, np.ascontiguousarray(other_xy[..., 0]), np.ascontiguousarray(other_xy[..., 1]),
                           np.asarray(goal, np.int64), np.ascontiguousarray(weights), maxiter, NEWTON_TOL, F, its)
    return z, F, its


def solve_constrained(z0, other_xy, goal, weights, maxiter, from_penalty_optimum=False):
    """The hard-limit optimum from z0 (B, K, 2) (teaching.domains.driving.constrained; from_penalty_optimum: z0 already
    minimises the penalised F, so the penalised Newton is skipped); returns (z, w . phi_raw, iterations,
    status: 0 no limit pressed, 1 exact, 2 not converged: the better of the penalty's answer and the SQP's best
    feasible iterate kept)."""
    z = np.ascontiguousarray(z0, dtype=np.float64).copy()
    n = len(z)
    F = np.empty(n)
    its, status = np.empty(n, np.int64), np.empty(n, np.int64)
    if n:
        constrained.constrained_batch(z, np.ascontiguousarray(other_xy[..., 0]), np.ascontiguousarray(other_xy[..., 1]),
                                      np.asarray(goal, np.int64), np.ascontiguousarray(weights), maxiter, NEWTON_TOL,
                                      FEAS_TOL, from_penalty_optimum, F, its, status)
    return z, F, its, status


def limit_excess(z, goal):
    """max over the world's limits of how far (ft) each trajectory z (B, K, 2) lies past it (<= 0 inside)."""
    z = np.ascontiguousarray(z, dtype=np.float64)
    out = np.empty((len(z), kernels.NC))
    if len(z):
        constrained.limits_batch(z, np.asarray(goal, np.int64), out)
    return out.max(axis=1) if len(z) else np.zeros(0)


def _as_stored(z):
    """Round to the stored precision so features describe the stored trajectory exactly."""
    return np.clip(z, -1.0, 1.0).astype(np.float32).astype(np.float64)


def _writable(a, dtype):
    """a as a C-contiguous, writable array of dtype (copied only if it is not one): Numba compiles a kernel
    again for every new argument type, and a read-only array (a memory-mapped table's, a broadcast) is one."""
    a = np.ascontiguousarray(a, dtype)
    return a if a.flags.writeable else a.copy()


def _pool_best(pool_phi, thetas, allowed=None, own=None):
    """For every theta (N, 5), the best allowed trajectory of one environment's pool (P, 5 normalised
    features; allowed (P,) bool, all if None): (index (N,), reward (N,), reward of pool trajectory
    own[i] (N,), -inf where it is not allowed).  Ties go to the lowest index; rewards are summed as
    features.reward sums them (newton.pool_best)."""
    pool_phi = _writable(pool_phi, np.float64)
    thetas = _writable(thetas, np.float64)
    n = len(thetas)
    allowed = np.ones(len(pool_phi), np.bool_) if allowed is None else _writable(allowed, np.bool_)
    own = np.zeros(n, np.int64) if own is None else _writable(own, np.int64)
    best, best_r, own_r = np.empty(n, np.int64), np.empty(n), np.empty(n)
    newton.pool_best(pool_phi, thetas, allowed, own, best, best_r, own_r)
    return best, best_r, own_r


def _cross_theta(pool_phi, thetas, own, feasible=None):
    """Per environment, every theta takes the best feasible pool trajectory under theta.

    pool_phi (M, P, 5) normalised features, thetas (N, 5), own (M, N) index
    into the pool of each theta's own solution, feasible (M, P) bool (all if None).
    Returns the chosen pool index (M, N) (a theta keeps its own unless another is
    strictly better, or its own is infeasible) and the gain in normalised reward
    units (M, N; 0 where its own was infeasible).
    """
    pick = np.empty(own.shape, np.int64)
    gain = np.empty(own.shape)
    norms = np.linalg.norm(thetas, axis=1)
    for m in range(len(pool_phi)):
        best, best_r, own_r = _pool_best(pool_phi[m], thetas, None if feasible is None else feasible[m], own[m])
        pick[m] = np.where(best_r > own_r, best, own[m])
        gain[m] = np.where(np.isfinite(own_r), (best_r - own_r) / norms, 0.0)
    return pick, gain


def plan_chunk(env_ids, thetas, normalisers, settings: PlannerSettings = PlannerSettings(), stats=None):
    """Optimal trajectories for every (environment, theta) of one chunk.

    env_ids (M,), thetas (N, 5) with thetas[0] = theta*.  Returns a dict of
    controls (M, N, K, 2) float32, features (M, N, 5) float64 (normalised),
    strategy (M, N) int8, d_euclid (M, N) float32.  `stats`, if a dict, gets
    solve counts and Newton iterations.
    """
    envs = get_environments(env_ids)
    M, N, K = len(envs), len(thetas), WORLD.n_knots
    oxy = other_car_states(envs)  # (M, T+1, 2)
    weights = objective_weights(thetas, normalisers)
    seeds = strategy_seeds()
    S = len(seeds)
    order = anchor_order(thetas)
    A = N if N <= settings.all_anchors_below else settings.n_anchors
    anchors = order[:A]

    def batch(env_idx, theta_idx, z0, iters):
        z, _, its = solve(z0, oxy[env_idx], envs.goal[env_idx], weights[theta_idx], iters)
        if stats is not None:
            stats["solves"] = stats.get("solves", 0) + len(z)
            stats["iterations"] = stats.get("iterations", 0) + int(its.sum())
            stats["at_cap"] = stats.get("at_cap", 0) + int((its >= iters - 1).sum())
        return _as_stored(z)

    def objective(z, env_idx, theta_idx):  # F (penalties included) of (B, K, 2) controls, as they are
        return solve(z, oxy[env_idx], envs.goal[env_idx], weights[theta_idx], 0)[1]

    def phi(z, env_idx):
        return raw_features(z, oxy[env_idx], envs.goal[env_idx]) / normalisers

    # 1. anchors from every seed, and the next thetas in the same order from the straight seeds:
    #    the pool starts with these (M, P0) solutions
    more = order[A:A + settings.straight_anchors]
    th0 = np.concatenate([np.repeat(anchors, S), np.repeat(more, len(settings.straight_seeds))])
    sd0 = np.concatenate([np.tile(np.arange(S), A), np.tile(settings.straight_seeds, len(more))])
    P0 = len(th0)
    e1, a1 = np.repeat(np.arange(M), P0), np.tile(th0, M)
    pool_z = [batch(e1, a1, seeds[np.tile(sd0, M)], settings.anchor_iters).reshape(M, P0, K, 2)]
    pool_phi = [phi(pool_z[0].reshape(-1, K, 2), e1).reshape(M, P0, 5)]

    # 2. continuation over theta: in farthest-point order, in rounds of doubling size, each
    #    theta starts from the best under theta of everything solved so far in its environment
    z = np.empty((M, N, K, 2))
    feats = np.empty((M, N, 5))
    done, size = 0, A
    while done < N:
        idx = order[done:done + size]
        B = len(idx)
        pz, pphi = np.concatenate(pool_z, axis=1), np.concatenate(pool_phi, axis=1)
        start = np.stack([_pool_best(pphi[m], thetas[idx])[0] for m in range(M)])  # (M, B)
        e2, t2 = np.repeat(np.arange(M), B), np.tile(idx, M)
        zb = batch(e2, t2, pz[e2, start.reshape(-1)], settings.warm_iters).reshape(M, B, K, 2)
        phib = phi(zb.reshape(-1, K, 2), e2).reshape(M, B, 5)
        z[:, idx], feats[:, idx] = zb, phib
        pool_z.append(zb)
        pool_phi.append(phib)
        done += B
        size = done  # doubling

    # 3-4. cross-theta, then refine the thetas that moved to another basin
    settle = functools.partial(_settle, thetas=thetas, rounds=settings.refine_rounds, batch=batch, phi=phi,
                               iters=settings.warm_iters, stats=stats)
    z, feats = settle(z, feats, pool_z[0], pool_phi[0])

    # 5. hops: a trajectory that changes lane several times has a basin for every timing of its
    #    moves, and Newton keeps the timing it started with; so such trajectories are solved
    #    again from their controls moved in time (settings.hop_shifts), the results shared as in 3-4.
    #    A hop's answer is offered only where it beats, penalties included, the trajectory it came
    #    from: from a start that breaks a constraint Newton can stop far off the road, and
    #    cross-theta, which compares rewards alone, would take that.
    hop = np.argwhere(lane_crossings(rollout_np(z)[..., 0]) >= settings.hop_min_crossings)
    if len(hop):
        eh, th = hop[:, 0], hop[:, 1]
        own_F = objective(z[eh, th], eh, th)
        found = [batch(eh, th, shift_in_time(z[eh, th], s), settings.warm_iters) for s in settings.hop_shifts]
        better = [objective(f, eh, th) < own_F - REFINE_GAIN for f in found]
        e_found = np.concatenate([eh[b] for b in better])
        if len(e_found):  # steps 3-4 again, in the environments where a hop found something
            z_found = np.concatenate([f[b] for f, b in zip(found, better, strict=True)])
            rows, e_row = np.unique(e_found, return_inverse=True)
            extra_z, extra_phi = _per_environment(e_row, z_found, phi(z_found, e_found), z[rows, 0], feats[rows, 0])
            z[rows], feats[rows] = settle(z[rows], feats[rows], extra_z, extra_phi, rows=rows)
        if stats is not None:
            stats["hopped"] = stats.get("hopped", 0) + len(hop)
            stats["hops_better"] = stats.get("hops_better", 0) + len(e_found)

    # 6. exact: the penalty's minimiser lies a little inside each limit it presses against; every
    #    theta's trajectory is solved again with the limits as hard constraints, and the hand-overs
    #    settled again among these and the penalty's answers (the feasible ones only: the penalty's lie
    #    a little inside the limits), refining from a new start with the same constrained solve.  The
    #    penalty's answers stay candidates because an SQP that does not converge for one theta may
    #    leave its trajectory worse for another theta than the penalty's was.
    if settings.exact:
        def exact_batch(env_idx, theta_idx, z0, iters, from_penalty_optimum=False):
            zc, _, its, status = solve_constrained(z0, oxy[env_idx], envs.goal[env_idx], weights[theta_idx], iters,
                                                   from_penalty_optimum)
            if stats is not None:
                stats["constrained"] = stats.get("constrained", 0) + len(zc)
                stats["constrained_iterations"] = stats.get("constrained_iterations", 0) + int(its.sum())
                stats["constrained_unconverged"] = stats.get("constrained_unconverged", 0) + int((status == 2).sum())
            return _as_stored(zc)

        def feasible(zs, env_idx):
            return limit_excess(zs, envs.goal[env_idx]) <= STORED_FEAS_TOL

        e6, t6 = np.repeat(np.arange(M), N), np.tile(np.arange(N), M)
        zx = exact_batch(e6, t6, z.reshape(-1, K, 2), settings.warm_iters, True).reshape(M, N, K, 2)
        phix = phi(zx.reshape(-1, K, 2), e6).reshape(M, N, 5)
        z, feats = _settle(zx, phix, z, feats, thetas=thetas, rounds=settings.refine_rounds,
                           batch=exact_batch, phi=phi, iters=settings.warm_iters, stats=stats, feasible=feasible)

    # Guard in the table's own arithmetic: never worse under theta than theta*'s trajectory.
    worse = reward(feats, thetas) < reward(feats[:, :1], thetas)
    z = np.where(worse[..., None, None], z[:, :1], z)
    feats = np.where(worse[..., None], feats[:, :1], feats)
    if stats is not None:
        stats["guarded"] = stats.get("guarded", 0) + int(worse.sum())

    states = rollout_np(z)  # (M, N, T+1, 5)
    return {
        "controls": z.astype(np.float32),
        "features": feats,
        "strategy": strategy_labels(states, envs, oxy),
        "d_euclid": euclidean_distance(states, states[:, :1]).astype(np.float32),
    }


def _settle(z, feats, extra_z, extra_phi, *, thetas, rounds, batch, phi, iters, stats, rows=None, feasible=None):
    """Steps 3-4: every theta takes the best, under theta, of all thetas' trajectories and the extra
    candidates of its environment; a theta that gained more than REFINE_GAIN (it was in a worse
    basin) is solved again from its new start, the result offered to all, `rounds` times.

    z (M, N, K, 2) and feats (M, N, 5) are each theta's own; extra_z (M, P, K, 2), extra_phi (M, P, 5);
    rows (M,) the chunk's environments these are (all of them if None); feasible(z (B, K, 2), env_idx (B,))
    -> (B,) bool, if given, says which trajectories may be handed over.  Returns the settled (z, feats)."""
    M, N = feats.shape[:2]
    rows = np.arange(M) if rows is None else rows
    pool_z, pool_phi = np.concatenate([z, extra_z], axis=1), np.concatenate([feats, extra_phi], axis=1)
    own = np.broadcast_to(np.arange(N), (M, N))
    pool_ok = None  # (M, P) feasibility, checked once per trajectory: picks inherit it
    if feasible is not None:
        P = pool_z.shape[1]
        pool_ok = feasible(pool_z.reshape(-1, *pool_z.shape[2:]), np.repeat(rows, P)).reshape(M, P)

    for r in range(rounds + 1):
        pick, gain = _cross_theta(pool_phi, thetas, own, pool_ok)
        # Only a real gain says the theta was in a worse basin; re-solving after a
        # rounding-level gain would cost a solve and change nothing.
        moved = np.argwhere(gain > REFINE_GAIN)
        z = np.take_along_axis(pool_z, pick[..., None, None], 1)
        feats = np.take_along_axis(pool_phi, pick[..., None], 1)
        if stats is not None:
            stats["moved"] = stats.get("moved", 0) + int((pick != own).sum())
            stats["refined"] = stats.get("refined", 0) + len(moved)
        if not len(moved) or r == rounds:
            break
        em, tm = moved[:, 0], moved[:, 1]
        z_ref = batch(rows[em], tm, z[em, tm], iters)
        # the refined solutions join the pool as extra candidates; a theta with no refined
        # solution offers a copy of its current one (no new information)
        extra, extra_phi = z.copy(), feats.copy()
        extra[em, tm], extra_phi[em, tm] = z_ref, phi(z_ref, rows[em])
        pool_z, pool_phi = np.concatenate([z, extra], axis=1), np.concatenate([feats, extra_phi], axis=1)
        if pool_ok is not None:
            ok = np.take_along_axis(pool_ok, pick, 1)
            extra_ok = ok.copy()
            extra_ok[em, tm] = feasible(z_ref, rows[em])
            pool_ok = np.concatenate([ok, extra_ok], axis=1)
    return z, feats


def _per_environment(env_idx, cand_z, cand_phi, fill_z, fill_phi):
    """Candidates (C, K, 2) / (C, 5) of environments env_idx (C,) as (M, P, K, 2) / (M, P, 5) per
    environment, P the largest count, padded with that environment's fill_z (M, K, 2) / fill_phi (M, 5)
    (a trajectory already in its pool, so padding offers nothing new)."""
    M = len(fill_z)
    counts = np.bincount(env_idx, minlength=M)
    order = np.argsort(env_idx, kind="stable")
    env = env_idx[order]
    slot = np.arange(len(env)) - (np.cumsum(counts) - counts)[env]  # rank within its environment
    out_z = np.repeat(fill_z[:, None], counts.max(), axis=1)
    out_phi = np.repeat(fill_phi[:, None], counts.max(), axis=1)
    out_z[env, slot], out_phi[env, slot] = cand_z[order], cand_phi[order]
    return out_z, out_phi


def shift_in_time(z: np.ndarray, knots: int) -> np.ndarray:
    """Controls (..., K, 2) moved `knots` later (negative: earlier) along the knot axis, the knots
    that open up held at zero (straight on, constant speed): the same moves, timed differently."""
    out = np.zeros_like(z)
    if knots >= 0:
        out[..., knots:, :] = z[..., :z.shape[-2] - knots, :]
    else:
        out[..., :knots, :] = z[..., -knots:, :]
    return out


def euclidean_distance(states_a, states_b) -> np.ndarray:
    """d_euclid = (1/T) sum_{t=1..T} |(s_a,t - s_b,t) / scale|_2 (DESIGN §5), broadcast over leading axes."""
    diff = (states_a[..., 1:, :] - states_b[..., 1:, :]) / np.asarray(WORLD.state_scale)
    return np.linalg.norm(diff, axis=-1).mean(axis=-1)
