"""A hard-constraint reference solver for one (environment, theta) problem.

teaching/domains/driving/reference.py minimises the planner's own penalised objective, so it cannot
see what the soft penalty costs.  This module shares nothing with the planner: its
rollout, features and their derivatives are written here in NumPy from DESIGN §2-3
and teaching/domains/driving/world.py, and the world's limits are HARD constraints:

* |x_t| <= WORLD.x_limit at every step t = 1..T (ft);
* |x_T - c| <= lane_end_band for the end lane's centre c: the right lane's for the
  merge goal (goal 0); for drive forward (goal 1) each lane is a separate problem
  and the best answer over the three is taken;
* |h_T - pi/2| <= heading_end_band (rad).

It maximises theta . phi(xi) / normalisers / |theta| (normalised reward units)
over knot controls z in [-1, 1]^(K x 2) with SciPy SLSQP and analytic Jacobians
(forward sensitivities J_t = ds_t/dz of the Euler rollout), from its own 29 starts
(:func:`hard_starts`), then polishes the best distinct local answers
(:func:`polish`): SLSQP again at tight tolerances until the objective moves by
<= 1e-12 between rounds, then a minimum-norm Newton projection onto the active
constraints so their violation is <= 1e-9 ft.  Slow by design (seconds per pair).
"""
from __future__ import annotations

import math

import numpy as np
from scipy.optimize import minimize, nnls
from scipy.stats import qmc
from threadpoolctl import threadpool_limits

from .world import WORLD

W = WORLD
K, T, SPK, NV = W.n_knots, W.horizon, W.steps_per_knot, 2 * W.n_knots
H0 = math.pi / 2
LANES = np.asarray(W.lane_centres, dtype=np.float64)
ACTIVE = 1e-7  # ft (or rad): a constraint this close to its bound counts as active


def rollout_jac(z):
    """z (K, 2) in [-1, 1] -> states S (T+1, 5) [x, y, h, v, steer] and J (T+1, 5, NV) = dS/dz (flat z).

    Explicit Euler of DESIGN §2; the steering angle is clipped at steer_max (its
    derivative is then zero: the clipped value does not move)."""
    z = np.asarray(z, dtype=np.float64).reshape(K, 2)
    S = np.zeros((T + 1, 5))
    J = np.zeros((T + 1, 5, NV))
    x, y, h, v, st = 0.0, 0.0, H0, W.v_init, 0.0
    S[0] = x, y, h, v, st
    dt, L = W.dt, W.wheelbase
    for t in range(T):
        k = t // SPK
        c, s, tn = math.cos(h), math.sin(h), math.tan(st)
        Jx, Jy, Jh, Jv, Js = J[t]
        nJ = J[t + 1]
        nJ[0] = Jx + dt * c * Jv - dt * v * s * Jh
        nJ[1] = Jy + dt * s * Jv + dt * v * c * Jh
        nJ[2] = Jh + dt / L * tn * Jv + dt / L * v * (1.0 + tn * tn) * Js
        nJ[3] = Jv
        nJ[3, 2 * k + 1] += dt * W.accel_max
        raw = st + dt * W.steer_rate_max * z[k, 0]
        if abs(raw) < W.steer_max:
            nJ[4] = Js
            nJ[4, 2 * k] += dt * W.steer_rate_max
        x, y, h = x + dt * v * c, y + dt * v * s, h + dt / L * v * tn
        v, st = v + dt * W.accel_max * z[k, 1], min(max(raw, -W.steer_max), W.steer_max)
        S[t + 1] = x, y, h, v, st
    return S, J


def features_jac(S, J, other_xy, goal):
    """Raw features phi (5,) of DESIGN §3 and dphi/dz (5, NV) from a rollout; other_xy (T+1, 2) in ft.

    closeness sum_t exp(-dx^2/2 sig_lat^2 - dy^2/2 sig_long^2), acceleration sum_t (v_t+1 - v_t)^2,
    speed deviation sum_t (v_t - v_0)^2, turning sum_t sqrt(dh^2 + eps^2) - eps, goal: merge
    sum_t max(0, w - x_t)^2, forward y_reachable_max - y_T (t = 1..T unless said)."""
    x, y, h, v = S[1:, 0], S[1:, 1], S[1:, 2], S[1:, 3]
    Jx, Jy, Jh, Jv = J[1:, 0], J[1:, 1], J[1:, 2], J[1:, 3]
    dx, dy = x - other_xy[1:, 0], y - other_xy[1:, 1]
    a, b = W.sigma_lat ** 2, W.sigma_long ** 2
    e = np.exp(-0.5 * (dx * dx / a + dy * dy / b))
    dv = np.diff(S[:, 3])
    dJv = np.diff(J[:, 3], axis=0)
    d, eps = h - H0, W.turn_smoothing
    r = np.sqrt(d * d + eps * eps)
    phi = np.array([e.sum(), (dv * dv).sum(), ((v - W.v_init) ** 2).sum(), (r - eps).sum(), 0.0])
    grad = np.stack([-(e * dx / a) @ Jx - (e * dy / b) @ Jy, 2.0 * dv @ dJv, 2.0 * (v - W.v_init) @ Jv,
                     (d / r) @ Jh, np.zeros(NV)])
    if goal == 0:
        m = np.maximum(0.0, W.lane_width - x)
        phi[4], grad[4] = (m * m).sum(), -2.0 * m @ Jx
    else:
        phi[4], grad[4] = W.y_reachable_max - S[T, 1], -J[T, 1]
    return phi, grad


def constraints_jac(S, J, lane_c):
    """Inequality constraints g(z) >= 0 (42,) and dg/dz (42, NV): road limits at t = 1..T (ft),
    then the lane-end band about lane_c (ft), then the end heading band (rad)."""
    xs, Jx = S[1:, 0], J[1:, 0]
    g = np.concatenate([W.x_limit - xs, W.x_limit + xs,
                        [W.lane_end_band - (S[T, 0] - lane_c), W.lane_end_band + (S[T, 0] - lane_c),
                         W.heading_end_band - (S[T, 2] - H0), W.heading_end_band + (S[T, 2] - H0)]])
    dg = np.concatenate([-Jx, Jx, [-J[T, 0], J[T, 0], -J[T, 2], J[T, 2]]])
    return g, dg


class HardProblem:
    """One (environment, weights, end lane) problem on flat z (NV,); evaluations cached per z
    (SLSQP asks for the objective, the constraints and their Jacobians separately)."""

    def __init__(self, other_xy, goal, weights, lane_c):
        self.oxy, self.goal, self.lane_c = np.asarray(other_xy, np.float64), int(goal), float(lane_c)
        self.w = np.asarray(weights, np.float64)
        self._key, self._val = None, None

    def eval(self, z):
        z = np.asarray(z, np.float64)
        key = z.tobytes()
        if key != self._key:
            S, J = rollout_jac(z)
            phi, dphi = features_jac(S, J, self.oxy, self.goal)
            g, dg = constraints_jac(S, J, self.lane_c)
            self._key, self._val = key, (float(self.w @ phi), self.w @ dphi, g, dg, phi, S)
        return self._val

    def f(self, z):
        return self.eval(z)[0]

    def df(self, z):
        return self.eval(z)[1]

    def g(self, z):
        return self.eval(z)[2]

    def dg(self, z):
        return self.eval(z)[3]


def slsqp(prob: HardProblem, z0, maxiter=300, ftol=1e-12):
    """One SLSQP run on the box [-1, 1]^NV with the hard constraints; returns flat z (NV,)."""
    res = minimize(prob.f, np.clip(np.asarray(z0, float).reshape(-1), -1, 1), jac=prob.df, method="SLSQP",
                   bounds=[(-1.0, 1.0)] * NV, constraints=[{"type": "ineq", "fun": prob.g, "jac": prob.dg}],
                   options={"maxiter": maxiter, "ftol": ftol})
    return np.clip(res.x, -1.0, 1.0)


def project_active(prob: HardProblem, z, iters=8):
    """Minimum-norm Newton steps onto the constraints within ACTIVE of their bound (and violated
    ones), keeping box-active variables fixed: drives their violation to rounding level."""
    for _ in range(iters):
        g, dg = prob.g(z), prob.dg(z)
        act = g < ACTIVE
        if not act.any() or np.abs(np.minimum(g, 0.0)).max() <= 1e-13:
            break
        free = np.abs(z) < 1.0 - 1e-12
        A = dg[np.ix_(act, free)]
        step = np.zeros(NV)
        step[free] = np.linalg.lstsq(A, -g[act], rcond=None)[0]
        z = np.clip(z + step, -1.0, 1.0)
    return z


def kkt_residual(prob: HardProblem, z):
    """max |grad f - sum_i lam_i grad g_i - box multipliers| over nonnegative multipliers of the
    active constraints (non-negative least squares): 0 at a KKT point."""
    g, dg, grad = prob.g(z), prob.dg(z), prob.df(z)
    cols = [dg[g < ACTIVE].T]
    lo, hi = z <= -1.0 + 1e-12, z >= 1.0 - 1e-12
    cols += [np.eye(NV)[:, lo], -np.eye(NV)[:, hi]]  # box z >= -1 and -z >= -1
    A = np.concatenate(cols, axis=1)
    if A.shape[1] == 0:
        return float(np.abs(grad).max())
    lam = nnls(A, grad, maxiter=50 * A.shape[1])[0]
    return float(np.abs(grad - A @ lam).max())


def polish(prob: HardProblem, z, rounds=30):
    """SLSQP restarted at tight tolerance until f moves by <= 1e-12, then projected onto the active
    constraints.  Returns (z, f, max violation, KKT residual)."""
    f = prob.f(z)
    for _ in range(rounds):
        zn = project_active(prob, slsqp(prob, z, maxiter=500, ftol=1e-15))
        fn = prob.f(zn)
        viol = max(0.0, -prob.g(zn).min())
        if viol > 1e-9 or fn > f + 1e-15:  # a worse or infeasible round: keep the last point
            break
        z, done, f = zn, abs(f - fn) <= 1e-12, fn
        if done:
            break
    return z, f, max(0.0, -prob.g(z).min()), kkt_residual(prob, z)


def _lateral(steer, accel):
    """x_T of this module's rollout for knot fractions steer (K,) at constant acceleration."""
    return rollout_jac(np.stack([steer, np.full(K, accel)], -1))[0][T, 0]


def _sine_change(start, n, accel, direction):
    """Knots (K, 2): one period of a sine in the steer rate over n knots from `start`, amplitude
    bisected so the car ends one lane over (direction +1: right) at that acceleration."""
    shape = np.zeros(K)
    shape[start:start + n] = -np.sin(2 * np.pi * (np.arange(n) + 0.5) / n)  # -steer turns towards +x
    lo, hi = 0.0, 1.0
    for _ in range(50):
        a = 0.5 * (lo + hi)
        lo, hi = (a, hi) if _lateral(a * shape, accel) < W.lane_width else (lo, a)
    return np.stack([direction * a * shape, np.full(K, accel)], axis=-1)


def hard_starts(n_random: int = 7, seed: int = 7) -> np.ndarray:
    """This solver's own 29 starts (S, K, 2) in [-1, 1]: 6 straight drives (constant acceleration
    -0.75, -0.25, 0.25, 0.75 and the two linear ramps), 16 sine lane changes (4-knot period from
    knot 1, 3, 5 at acceleration -0.4 / 0.4, and 6-knot from knot 1 / 3 at 0.2, both directions),
    and 7 scrambled Halton points (seed 7), steer column scaled by 0.25."""
    starts = [np.stack([np.zeros(K), np.full(K, a)], -1) for a in (-0.75, -0.25, 0.25, 0.75)]
    starts += [np.stack([np.zeros(K), r], -1) for r in (np.linspace(-1, 1, K), np.linspace(1, -1, K))]
    for d in (1, -1):
        starts += [_sine_change(s, 4, a, d) for s in (1, 3, 5) for a in (-0.4, 0.4)]
        starts += [_sine_change(s, 6, 0.2, d) for s in (1, 3)]
    hal = 2.0 * qmc.Halton(NV, scramble=True, seed=seed).random(n_random) - 1.0
    hal = hal.reshape(n_random, K, 2) * [0.25, 1.0]
    return np.clip(np.concatenate([np.array(starts), hal]), -1.0, 1.0)


def hard_weights(theta, normalisers):
    """(5,) weights of the minimised f = w . phi_raw = -theta . (phi / normalisers) / |theta|."""
    theta = np.asarray(theta, np.float64)
    return -theta / np.linalg.norm(theta) / np.asarray(normalisers, np.float64)


def end_lanes(goal):
    """Lane centres (ft) a drive with this goal may end in: the right lane's for merge (0), any for forward."""
    return LANES[-1:] if int(goal) == 0 else LANES


def solve_hard(other_xy, goal, theta, normalisers, n_polish: int = 3, starts=None) -> dict:
    """Global search with hard constraints for one problem.  Returns a dict: z (K, 2), f (normalised
    reward units, sign flipped: reward = -f), phi (5,) raw features, violation (max, ft / rad), kkt
    (residual), lane (end lane centre), local_f (starts x lanes,) of the local SLSQP answers."""
    starts = hard_starts() if starts is None else np.asarray(starts, float)
    w = hard_weights(theta, normalisers)
    best, local_f = None, []
    with threadpool_limits(1):  # tiny BLAS calls: idle threads spinning on a loaded machine cost 5-50x
        for c in end_lanes(goal):
            best = _solve_lane(HardProblem(other_xy, goal, w, c), starts, n_polish, best, local_f)
    if best is None:
        raise RuntimeError("no feasible answer from any start")
    best["local_f"] = np.array(local_f)
    return best


def _solve_lane(prob: HardProblem, starts, n_polish, best, local_f):
    """SLSQP from every start on one end lane, polish the n_polish best distinct feasible answers;
    returns the better of `best` and this lane's best (appends the local answers' f to local_f)."""
    local = [slsqp(prob, s) for s in starts]
    fs = np.array([prob.f(z) if prob.g(z).min() >= -1e-6 else np.inf for z in local])
    local_f.extend(fs)
    picked = []
    for i in np.argsort(fs, kind="stable"):
        if np.isfinite(fs[i]) and len(picked) < n_polish and all(
                np.abs(local[i] - local[j]).max() > 1e-5 for j in picked):
            picked.append(i)
    for i in picked:
        z, f, viol, kkt = polish(prob, local[i])
        if viol <= 1e-9 and (best is None or f < best["f"]):
            best = {"z": z.reshape(K, 2), "f": f, "phi": prob.eval(z)[4], "violation": viol, "kkt": kkt,
                    "lane": prob.lane_c}
    return best


def margins(z, goal) -> dict:
    """Where a trajectory z (K, 2) stands against the world's limits.  Distances are positive inside:
    road (T,) 12 - |x_t| in ft; lane_end |x_T - c| to the band edge (ft) for the nearest allowed c;
    heading the end heading band's margin (rad); violation = max(0, -smallest of the three) per kind."""
    S = rollout_jac(z)[0]
    lanes = end_lanes(goal)
    c = lanes[np.argmin(np.abs(S[T, 0] - lanes))]
    road = W.x_limit - np.abs(S[1:, 0])
    lane_end = W.lane_end_band - abs(S[T, 0] - c)
    heading = W.heading_end_band - abs(S[T, 2] - H0)
    return {"road": road, "road_min": float(road.min()), "lane_end": float(lane_end), "heading": float(heading),
            "lane": float(c), "x": S[:, 0], "violation_ft": float(max(0.0, -road.min(), -lane_end)),
            "violation_rad": float(max(0.0, -heading))}


def compare_pair(table_z, table_phi, other_xy, goal, theta, normalisers, **solve_kw) -> dict:
    """The hard reference against a table's answer for one pair.  table_z (K, 2) stored controls,
    table_phi (5,) its stored normalised features.  Rewards are theta . phi_normalised / |theta|
    (normalised reward units); gap = ref - table (> 0: the table is worse).  Margins are positive
    inside (ft, heading in rad); ref_active_steps are the steps t (1..T) where the reference
    presses against |x| = x_limit, and table_road_at_active the table's 12 - |x_t| there."""
    theta, norm = np.asarray(theta, np.float64), np.asarray(normalisers, np.float64)
    nt = np.linalg.norm(theta)
    ref = solve_hard(other_xy, goal, theta, norm, **solve_kw)
    r_ref = float(theta @ (ref["phi"] / norm)) / nt
    r_tab = float(theta @ np.asarray(table_phi, np.float64)) / nt
    mr, mt = margins(ref["z"], goal), margins(np.asarray(table_z, np.float64), goal)
    active = np.flatnonzero(mr["road"] <= ACTIVE)
    return {"ref_reward": r_ref, "table_reward": r_tab, "gap": r_ref - r_tab, "ref_z": ref["z"],
            "ref_kkt": ref["kkt"], "ref_violation": ref["violation"],
            "ref_violation_ft": mr["violation_ft"], "ref_violation_rad": mr["violation_rad"],
            "table_violation_ft": mt["violation_ft"], "table_violation_rad": mt["violation_rad"],
            "table_road_min": mt["road_min"], "table_lane_end": mt["lane_end"], "table_heading": mt["heading"],
            "ref_lane": mr["lane"], "table_lane": mt["lane"], "ref_road_active": bool(len(active)),
            "ref_lane_end_active": bool(mr["lane_end"] <= ACTIVE), "ref_heading_active": bool(mr["heading"] <= ACTIVE),
            "ref_active_steps": active + 1, "table_road_at_active": mt["road"][active],
            "max_dx": float(np.abs(mr["x"] - mt["x"]).max())}
