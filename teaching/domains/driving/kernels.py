"""Compiled (Numba) kernels: rollout, features, and the objective with its
exact gradient and Hessian, for one trajectory at a time.

Longer than 400 lines because the derivatives (the forward and backward passes) must sit beside the
rollout and penalties they differentiate: Numba compiles and caches the kernels that call one another
by module, and a change to one must recompile the others.

Decision variables z (K, 2) lie in [-1, 1]; the controls are
u_k = z_k * [steer_rate_max, accel_max], held for `steps_per_knot` steps.

The minimised objective is F(z) = sum_i w_i phi_i(z) + C(z) with
w = -theta / |theta| / normalisers (so F is in normalised reward units, sign
flipped), and C(z) the stiff smooth penalties of the world's constraints (not
features, docs/calibration.md): the car's centre stays within the outer lane
centres at every step, and at step T it lies within `lane_end_band` of a lane
centre (of the right lane's for the merge goal) with its heading within
`heading_end_band` of straight ahead.  The features here are the
stored ones: turning is sum_t sqrt(dh^2 + eps^2) - eps everywhere.

Exact derivatives, with s_t the state after t steps and J_t = ds_t/dz:
  grad F = sum_t J_t^T grad l_t  (+ the acceleration term, quadratic in z)
  hess F = sum_t J_t^T M_t J_t,  M_t = hess l_t + sum_k co_{t+1,k} hess f_k(s_t)
where l_t is the stage cost at s_t, f the Euler step and co the costate
(co_T = grad l_T, co_t = grad l_t + A_t^T co_{t+1}).  Controls enter the
step linearly, so these are all the second-order terms.  The steering clip
(never active at an optimum) is treated as constant where it binds.
"""
from __future__ import annotations

import hashlib
import math
import os

import numpy as np
from numba import njit
from numba.core import config as numba_config

from ...core import detmath
from .world import WORLD, world_fingerprint

# Numba's disk cache is keyed on each function's own source file alone, but these kernels freeze
# the world's constants when they compile and take in one another across modules (newton.py and
# constrained.py call the ones here, every one calls teaching/core/detmath.py): an edited world.py,
# detmath.py or kernel module would load stale machine code for the others.  So their cache lives
# in a directory named by the world's fingerprint and a hash of every kernel module's source (the
# locator is fixed when each function is decorated: each kernel module sets KERNEL_CACHE_DIR first).
KERNEL_MODULES = (detmath.__file__, *(os.path.join(os.path.dirname(__file__), f"{name}.py")
                                      for name in ("kernels", "newton", "qp", "constrained")))


def kernel_cache_dir(base: str, world: str, sources=KERNEL_MODULES) -> str:
    """base/numba-<16 hex digits over the world's fingerprint and the bytes of every source>."""
    digest = hashlib.sha256(world.encode())
    for path in sources:
        with open(path, "rb") as f:
            digest.update(hashlib.sha256(f.read()).digest())
    return os.path.join(base, f"numba-{digest.hexdigest()[:16]}")


_user_cache_dir = numba_config.CACHE_DIR
KERNEL_CACHE_DIR = kernel_cache_dir(_user_cache_dir or os.path.join(os.path.dirname(__file__), "__pycache__"),
                                    world_fingerprint())
numba_config.CACHE_DIR = KERNEL_CACHE_DIR

DT = WORLD.dt
WB = WORLD.wheelbase
T = WORLD.horizon
K = WORLD.n_knots
SPK = WORLD.steps_per_knot
NV = 2 * K
W_MAX = WORLD.steer_rate_max
A_MAX = WORLD.accel_max
S_MAX = WORLD.steer_max
V0 = WORLD.v_init
H0 = math.pi / 2
LW = WORLD.lane_width
SIG_LAT2 = WORLD.sigma_lat**2
SIG_LONG2 = WORLD.sigma_long**2
EPS = WORLD.turn_smoothing
Y_MAX = WORLD.y_reachable_max
X_LIM = WORLD.x_limit  # the car's centre stays between the outer lane centres
BAND = WORLD.lane_end_band  # at step T the centre lies this close to a lane centre
H_BAND = WORLD.heading_end_band  # ... and the heading this close to straight ahead
H_SCALE = WORLD.heading_penalty_scale  # ft per rad in the penalty
W_PEN = WORLD.constraint_penalty
PEN_SOFT = 0.05  # ft: the penalty's softness (softplus scale); 0.01-0.2 ft all tried, this was fastest
STRIPES = 256  # parallel work units per batch (solve_batch)
ACTIVE_EPS = 1e-3  # widest band next to a bound in which a variable may be held fixed
NC = T + 2  # the world's limits: |x_t| <= X_LIM at t = 1..T, then the lane-end band, then the end heading
NO_MULTIPLIERS = np.zeros(NC)
TRACE_W = 7  # columns of trace_buffer


@njit(cache=True)
def overshoot_penalty(o):
    """Penalty for being o ft outside an allowed interval (o < 0: inside), with its first and
    second derivatives in o: W_PEN q^2 with q = PEN_SOFT log(1 + e^(o / PEN_SOFT)), a softplus.

    About W_PEN o^2 outside and vanishing a few PEN_SOFT inside, and smooth everywhere: at an
    optimum pressed against a constraint the curvature grows smoothly with the force, so Newton
    keeps its quadratic model.  A C2 spline (zero inside, a cubic ramp, then W o^2) made Newton
    slide along the curved penalty valley in short steps: on 2,000 cold solves it averaged 78
    iterations with 133 at the 200 cap, against 35 and 26 with this one (docs/decisions.md)."""
    u = o / PEN_SOFT
    if u < -40.0:
        return 0.0, 0.0, 0.0
    if u > 40.0:
        sp, sig = u, 1.0
    else:
        sp, sig = detmath.softplus_sigmoid(u)  # not libm's: its CPU-dispatched variants differ in the last bit
    q = PEN_SOFT * sp
    return W_PEN * q * q, 2.0 * W_PEN * q * sig, 2.0 * W_PEN * (sig * sig + q * sig * (1.0 - sig) / PEN_SOFT)


@njit(cache=True)
def limit_term(o, lam, hard):
    """The objective's term for one limit o <= 0 (o in ft), with d/do and d2/do2: the soft penalty
    (overshoot_penalty), which finds the basins, or, if hard, the Lagrangian's term lam * o with the
    limit's multiplier lam >= 0 (normalised reward units per ft; teaching.domains.driving.constrained)."""
    if hard:
        return lam * o, lam, 0.0
    return overshoot_penalty(o)


@njit(cache=True)
def road_penalty(x, lam, hard):
    """The limit on the car's centre, |x| <= X_LIM: (value, d/dx, d2/dx2)."""
    p, dp, ddp = limit_term(abs(x) - X_LIM, lam, hard)
    return p, (dp if x > 0.0 else -dp), ddp


@njit(cache=True)
def lane_end_penalty(x, goal, lam, hard):
    """The end of the drive: x_T within BAND of a lane centre (goal 0, merge
    right: of the right lane's).  (value, d/dx, d2/dx2).  Between two lanes the
    penalty peaks half-way, so a local search keeps the lane its start ends in;
    the planner's seeds end in every lane."""
    if goal == 0:
        c = LW
    else:
        c = min(max(LW * math.floor(x / LW + 0.5), -LW), LW)
    p, dp, ddp = limit_term(abs(x - c) - BAND, lam, hard)
    return p, (dp if x > c else -dp), ddp


@njit(cache=True)
def heading_end_penalty(h, lam, hard):
    """The end of the drive: |h_T - pi/2| <= H_BAND.  (value, d/dh, d2/dh2)."""
    d = h - H0
    p, dp, ddp = limit_term(H_SCALE * (abs(d) - H_BAND), lam, hard)
    return p, (H_SCALE * dp if d > 0.0 else -H_SCALE * dp), H_SCALE * H_SCALE * ddp


@njit(cache=True)
def rollout_one(z, out, trace=None):
    """z (K, 2) in [-1, 1] -> out (T+1, 5) states; trace (T+1, TRACE_W), if given, gets each step's
    transcendentals (see trace_buffer)."""
    x, y, h, v, st = 0.0, 0.0, H0, V0, 0.0
    out[0, 0], out[0, 1], out[0, 2], out[0, 3], out[0, 4] = x, y, h, v, st
    for t in range(T):
        k = t // SPK
        sh, ch = detmath.sincos(h)
        tn = detmath.tan(st)
        if trace is not None:
            trace[t, 0], trace[t, 1], trace[t, 2] = ch, sh, tn
        xn = x + DT * v * ch
        yn = y + DT * v * sh
        hn = h + DT / WB * v * tn
        v = v + DT * A_MAX * z[k, 1]
        st = min(max(st + DT * W_MAX * z[k, 0], -S_MAX), S_MAX)
        x, y, h = xn, yn, hn
        out[t + 1, 0], out[t + 1, 1], out[t + 1, 2], out[t + 1, 3], out[t + 1, 4] = x, y, h, v, st


@njit(cache=True)
def features_one(z, ox, oy, goal, out):
    """Raw features (5,) of one trajectory; ox, oy (T+1,) other car positions."""
    s = np.empty((T + 1, 5))
    rollout_one(z, s)
    features_of_states(s, ox, oy, goal, out)


@njit(cache=True)
def trace_buffer():
    """What an objective evaluation can hand to the next forward pass at the same point, so that
    Newton's step, whose line search has just evaluated the objective there, computes no
    transcendental twice (the same values, so the same bits): per step t, cos h_t, sin h_t and
    tan(steer_t) (columns 0-2, t < T), and at state t >= 1 the closeness kernel (3) and the road
    limit's soft penalty with its two derivatives (4-6)."""
    return np.empty((T + 1, TRACE_W))


@njit(cache=True)
def features_of_states(s, ox, oy, goal, out, trace=None):
    """Raw features (5,) of rolled-out states s (T+1, 5); trace, if given, gets the closeness kernel."""
    clo = 0.0
    dev = 0.0
    turn = 0.0
    merge = 0.0
    for t in range(1, T + 1):
        dx = s[t, 0] - ox[t]
        dy = s[t, 1] - oy[t]
        gk = detmath.exp(-0.5 * (dx * dx / SIG_LAT2 + dy * dy / SIG_LONG2))
        if trace is not None:
            trace[t, 3] = gk
        clo += gk
        dev += (s[t, 3] - V0) ** 2
        d = s[t, 2] - H0
        turn += math.sqrt(d * d + EPS * EPS) - EPS
        m = max(0.0, LW - s[t, 0])
        merge += m * m
    acc = 0.0
    for t in range(T):
        acc += (s[t + 1, 3] - s[t, 3]) ** 2
    out[0] = clo
    out[1] = acc
    out[2] = dev
    out[3] = turn
    out[4] = merge if goal == 0 else Y_MAX - s[T, 1]


@njit(cache=True)
def objective(z, ox, oy, goal, w, trace=None):
    """F(z) with the soft penalty, value only: used in line searches (trace: see trace_buffer)."""
    return _objective(z, ox, oy, goal, w, NO_MULTIPLIERS, False, trace)


@njit(cache=True)
def lagrangian(z, ox, oy, goal, w, lam):
    """w . phi_raw(z) + sum_i lam_i c_i(z), the hard-limit problem's Lagrangian (lam (NC,); see hard_merge)."""
    return _objective(z, ox, oy, goal, w, lam, True)


@njit(cache=True)
def _objective(z, ox, oy, goal, w, lam, hard, trace=None):
    s = np.empty((T + 1, 5))
    rollout_one(z, s, trace)  # once: the features and the penalties read the same states
    f = np.empty(5)
    features_of_states(s, ox, oy, goal, f, trace)
    if hard and goal == 0:
        f[4] = 0.0
        for t in range(1, T + 1):
            f[4] += (LW - s[t, 0]) ** 2  # hard_merge
    pen = lane_end_penalty(s[T, 0], goal, lam[T], hard)[0] + heading_end_penalty(s[T, 2], lam[T + 1], hard)[0]
    for t in range(1, T + 1):
        p_road, dp_road, ddp_road = road_penalty(s[t, 0], lam[t - 1], hard)
        if trace is not None:
            trace[t, 4], trace[t, 5], trace[t, 6] = p_road, dp_road, ddp_road
        pen += p_road
    return w[0] * f[0] + w[1] * f[1] + w[2] * f[2] + w[3] * f[3] + w[4] * f[4] + pen


@njit(cache=True)
def objective_grad_hess(z, ox, oy, goal, w, g, H, want_hess):
    """F(z) with the soft penalty; fills g (NV,) and, if want_hess, H (NV, NV) with exact derivatives."""
    return _objective_grad_hess(z, ox, oy, goal, w, NO_MULTIPLIERS, False, g, H, want_hess)


@njit(cache=True)
def lagrangian_grad_hess(z, ox, oy, goal, w, lam, g, H, want_hess):
    """The Lagrangian (see lagrangian); fills g (NV,) and, if want_hess, H (NV, NV) with exact derivatives.

    hard_merge: under hard limits the merge feature sum_t max(0, LW - x_t)^2 is taken as its smooth
    extension sum_t (LW - x_t)^2, equal wherever |x_t| <= X_LIM = LW holds, without the kink at
    x_t = 12 that lies exactly on the road's limit where a merging car ends."""
    return _objective_grad_hess(z, ox, oy, goal, w, lam, True, g, H, want_hess)


@njit(cache=True, inline="always")  # the Hessian's hot loop: a call per step cost 5 % of a build
def euler_step_sensitivities(z, t, x, y, h, v, st, ch, sh, tn, J, Jn):
    """Euler step t from the state (x, y, h, v, st) under z (K, 2), given cos h, sin h and tan(st),
    with the forward sensitivities: Jn (5, NV) = ds_{t+1}/dz from J = ds_t/dz.  s_{t+1} depends on
    knots 0..k only (k = t // SPK), so only Jn's first 2 (k + 1) columns are written (the others stay
    as they were: zero).  The steering angle's clip is held constant where it binds.  Returns the
    new state and whether the clip bound."""
    k = t // SPK
    sec2 = 1.0 + tn * tn
    for j in range(2 * (k + 1)):
        Jn[0, j] = J[0, j] - DT * v * sh * J[2, j] + DT * ch * J[3, j]
        Jn[1, j] = J[1, j] + DT * v * ch * J[2, j] + DT * sh * J[3, j]
        Jn[2, j] = J[2, j] + DT / WB * tn * J[3, j] + DT / WB * v * sec2 * J[4, j]
        Jn[3, j] = J[3, j]
        Jn[4, j] = J[4, j]
    Jn[3, 2 * k + 1] += DT * A_MAX
    st_new = st + DT * W_MAX * z[k, 0]
    clipped = abs(st_new) > S_MAX
    if clipped:
        st_new = S_MAX if st_new > 0 else -S_MAX
        for j in range(NV):
            Jn[4, j] = 0.0
    else:
        Jn[4, 2 * k] += DT * W_MAX
    return x + DT * v * ch, y + DT * v * sh, h + DT / WB * v * tn, v + DT * A_MAX * z[k, 1], st_new, clipped


@njit(cache=True)
def _objective_grad_hess(z, ox, oy, goal, w, lam, hard, g, H, want_hess):
    work = workspace()
    F = _forward(z, ox, oy, goal, w, lam, hard, g, work, trace_buffer(), False)
    if want_hess:
        _backward(ox, oy, goal, w, lam, hard, work, H)
    return F


@njit(cache=True)
def workspace():
    """What the forward pass keeps for the Hessian's backward pass: states S (T+1, 5), sensitivities
    Jall (T+1, 5, NV) = ds_t/dz, stage-cost gradients dl (T+1, 5), cos h, sin h, tan(steer) and the
    closeness kernel per step trig (T+1, 4), whether the steering clip bound (T,), and the limits'
    second derivatives pen2 (T+1, 3): the road's at each step, the lane end's and the heading's at T.
    Zeros where a pass never writes (Jall's columns of later knots, dl's last column), so one
    workspace serves any number of passes."""
    return (np.empty((T + 1, 5)), np.zeros((T + 1, 5, NV)), np.zeros((T + 1, 5)), np.empty((T + 1, 4)),
            np.zeros(T, np.bool_), np.zeros((T + 1, 3)))


@njit(cache=True)
def _forward(z, ox, oy, goal, w, lam, hard, g, work, trace, traced):
    """F(z) and its gradient g (NV,), filling the workspace (see workspace) for _backward.  If traced,
    trace holds the transcendentals of an objective evaluation at this z (trace_buffer; the road
    penalty's only if not hard).  (A flag, not an optional argument: one compiled _forward, not two.)"""
    S, Jall, dl, trig, clipped, pen2 = work
    g[:] = 0.0
    x, y, h, v, st = 0.0, 0.0, H0, V0, 0.0
    S[0, 0], S[0, 1], S[0, 2], S[0, 3], S[0, 4] = x, y, h, v, st
    # cos h, sin h, tan(steer) at each step and the closeness kernel at each state are kept for the
    # backward pass: recomputing them there was a fifth of a Hessian evaluation
    F = 0.0
    for t in range(T):
        if traced:
            ch, sh, tn = trace[t, 0], trace[t, 1], trace[t, 2]
        else:
            sh, ch = detmath.sincos(h)
            tn = detmath.tan(st)
        x, y, h, v, st, clipped[t] = euler_step_sensitivities(z, t, x, y, h, v, st, ch, sh, tn, Jall[t], Jall[t + 1])
        trig[t, 0], trig[t, 1], trig[t, 2] = ch, sh, tn
        S[t + 1, 0], S[t + 1, 1], S[t + 1, 2], S[t + 1, 3], S[t + 1, 4] = x, y, h, v, st
        # stage cost at s_{t+1}
        dx, dy = x - ox[t + 1], y - oy[t + 1]
        gk = trace[t + 1, 3] if traced else detmath.exp(-0.5 * (dx * dx / SIG_LAT2 + dy * dy / SIG_LONG2))
        trig[t + 1, 3] = gk
        d = h - H0
        rt = math.sqrt(d * d + EPS * EPS)
        F += w[0] * gk + w[2] * (v - V0) ** 2 + w[3] * (rt - EPS)
        dl[t + 1, 0] = -w[0] * gk * dx / SIG_LAT2
        dl[t + 1, 1] = -w[0] * gk * dy / SIG_LONG2
        dl[t + 1, 2] = w[3] * d / rt
        dl[t + 1, 3] = 2.0 * w[2] * (v - V0)
        if hard or not traced:  # the road's limit: a constraint of the world, not a feature
            p_pen, dp_pen, pen2[t + 1, 0] = road_penalty(x, lam[t], hard)
        else:
            p_pen, dp_pen, pen2[t + 1, 0] = trace[t + 1, 4], trace[t + 1, 5], trace[t + 1, 6]
        if t + 1 == T:
            p_end, dp_end, pen2[T, 1] = lane_end_penalty(x, goal, lam[T], hard)
            p_head, dp_head, pen2[T, 2] = heading_end_penalty(h, lam[T + 1], hard)
            p_pen += p_end + p_head
            dp_pen += dp_end
            dl[t + 1, 2] += dp_head
        F += p_pen
        dl[t + 1, 0] += dp_pen
        if goal == 0:
            m = (LW - x) if hard else max(0.0, LW - x)  # hard_merge
            F += w[4] * m * m
            dl[t + 1, 0] += -2.0 * w[4] * m
        elif t + 1 == T:
            F += w[4] * (Y_MAX - y)
            dl[t + 1, 1] += -w[4]
        Jn = Jall[t + 1]
        for i in range(5):
            if dl[t + 1, i] != 0.0:
                for j in range(2 * (t // SPK + 1)):  # the columns s_{t+1} depends on
                    g[j] += Jn[i, j] * dl[t + 1, i]
    ca = 2.0 * w[1] * SPK * (DT * A_MAX) ** 2  # acceleration: spk * sum_k (dt a_k)^2
    for kk in range(K):
        F += 0.5 * ca * z[kk, 1] ** 2
        g[2 * kk + 1] += ca * z[kk, 1]
    return F


@njit(cache=True)
def _backward(ox, oy, goal, w, lam, hard, work, H):
    """H (NV, NV), the exact Hessian at the point of the last _forward into `work` (the costate
    recursion of the module docstring)."""
    S, Jall, dl, trig, clipped, pen2 = work
    ca = 2.0 * w[1] * SPK * (DT * A_MAX) ** 2
    H[:, :] = 0.0
    co = dl[T].copy()  # the costate
    M = np.zeros((5, 5))
    N = np.empty((5, NV))
    for t in range(T, 0, -1):
        x, y, h, v = S[t, 0], S[t, 1], S[t, 2], S[t, 3]
        M[:, :] = 0.0
        dx, dy = x - ox[t], y - oy[t]
        gk = w[0] * trig[t, 3]
        M[0, 0] = gk * (dx * dx / SIG_LAT2**2 - 1.0 / SIG_LAT2)
        M[0, 1] = M[1, 0] = gk * dx * dy / (SIG_LAT2 * SIG_LONG2)
        M[1, 1] = gk * (dy * dy / SIG_LONG2**2 - 1.0 / SIG_LONG2)
        d = h - H0
        q = d * d + EPS * EPS
        M[2, 2] = w[3] * EPS * EPS / (q * math.sqrt(q))  # q**1.5 without libm's pow
        M[3, 3] = 2.0 * w[2]
        if goal == 0 and (hard or LW - x > 0.0):
            M[0, 0] += 2.0 * w[4]
        M[0, 0] += pen2[t, 0]  # the limits' curvature, as the forward pass found it
        if t == T:
            M[0, 0] += pen2[T, 1]
            M[2, 2] += pen2[T, 2]
        if t < T:  # second derivatives of the step s_t -> s_{t+1}, weighted by the costate co_{t+1}
            ch, sh, tn = trig[t, 0], trig[t, 1], trig[t, 2]
            sec2 = 1.0 + tn * tn
            M[2, 2] += -co[0] * DT * v * ch - co[1] * DT * v * sh
            M[2, 3] += -co[0] * DT * sh + co[1] * DT * ch
            M[3, 2] = M[2, 3]
            M[3, 4] += co[2] * DT / WB * sec2
            M[4, 3] = M[3, 4]
            M[4, 4] += co[2] * DT / WB * v * 2.0 * sec2 * tn
            # costate: co_t = grad l_t + A_t^T co_{t+1}
            l0, l1, l2, l3, l4 = co[0], co[1], co[2], co[3], co[4]
            co[0] = dl[t, 0] + l0
            co[1] = dl[t, 1] + l1
            co[2] = dl[t, 2] + l2 - l0 * DT * v * sh + l1 * DT * v * ch
            co[3] = dl[t, 3] + l3 + l0 * DT * ch + l1 * DT * sh + l2 * DT / WB * tn
            co[4] = dl[t, 4] + (0.0 if clipped[t] else l4) + l2 * DT / WB * v * sec2
        J = Jall[t]
        nz = 2 * ((t - 1) // SPK + 1)  # J_t depends only on knots before step t
        # N = M J with M's structure spelled out: 11 of its 25 entries can be non-zero
        # (position block, heading-speed-steer chain), and this product is a third of the Hessian's cost
        for j in range(nz):
            j0, j1, j2, j3, j4 = J[0, j], J[1, j], J[2, j], J[3, j], J[4, j]
            N[0, j] = M[0, 0] * j0 + M[0, 1] * j1
            N[1, j] = M[1, 0] * j0 + M[1, 1] * j1
            N[2, j] = M[2, 2] * j2 + M[2, 3] * j3
            N[3, j] = M[3, 2] * j2 + M[3, 3] * j3 + M[3, 4] * j4
            N[4, j] = M[4, 3] * j3 + M[4, 4] * j4
        # H[a, b] += J[:, a] . N[:, b].  A steer column (a even) has no speed entry and an
        # acceleration column (a odd) no steering-angle entry, so four terms each, not five.
        for a in range(0, nz, 2):
            c0, c1, c2, c4 = J[0, a], J[1, a], J[2, a], J[4, a]
            for b in range(a, nz):
                H[a, b] += c0 * N[0, b] + c1 * N[1, b] + c2 * N[2, b] + c4 * N[4, b]
        for a in range(1, nz, 2):
            c0, c1, c2, c3 = J[0, a], J[1, a], J[2, a], J[3, a]
            for b in range(a, nz):
                H[a, b] += c0 * N[0, b] + c1 * N[1, b] + c2 * N[2, b] + c3 * N[3, b]
    for a in range(NV):
        for b in range(a):
            H[a, b] = H[b, a]
    for kk in range(K):
        H[2 * kk + 1, 2 * kk + 1] += ca


numba_config.CACHE_DIR = _user_cache_dir
