"""The pooled fit's joint maximum of the log-likelihood over (τ or λ, ε) (:func:`.fitting.fit_model`).

ℓ is concave in the lapse ε, so every candidate τ / λ gets its exact best ε (:func:`best_lapse`), and the
search over the model's own hyperparameter runs on that profile: continuously for λ (the profile is smooth
in λ; :func:`smooth_maximum`), and step by step for a deterministic learner's τ, whose ℓ is a step function
that changes only where τ reaches a distance (:func:`step_counts`, :func:`step_maximum`).  Answers are
grouped by what the likelihood reads of them (:func:`answer_classes`), so the cost grows with the distinct
(sequence, test, choice) triples, not with the participants.
"""
from __future__ import annotations

import numpy as np
from scipy.optimize import minimize_scalar

from .answers import Answers
from .choice import OptionDistances
from .learners import Deterministic, Distances


def answer_classes(answers: Answers) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The answered tests grouped by what the likelihood reads of them: (U,) sequence, test and chosen
    option of each distinct (s, t, k) and (U,) how many answers it stands for."""
    who, test = np.nonzero(answers.choice >= 0)
    keys = np.stack([answers.group[who], test, answers.choice[who, test]], 1)
    uniq, counts = np.unique(keys, axis=0, return_counts=True)
    return uniq[:, 0], uniq[:, 1], uniq[:, 2], counts


def best_lapse(p: np.ndarray, counts: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """p (C, U) q of each answer class's chosen option under C candidate models, counts (U,) answers per
    class, K options -> ((C,) ε in [0, 1] maximising ℓ(ε) = Σ_u n_u log((1 - ε) p_u + ε / K), (C,) that ℓ).

    ℓ is concave in ε, so its maximum is where the slope Σ_u n_u (1/K - p_u) / ((1 - ε) p_u + ε / K)
    changes sign: 0 when the slope at 0 is <= 0, 1 when the slope at 1 is >= 0, else found by Newton steps
    kept inside a bracket that halves whenever a step would leave it (to float precision, vectorised over
    the candidates, deterministic)."""
    p = np.atleast_2d(np.asarray(p, np.float64))

    def slope_curvature(p, eps):  # dℓ/dε and d²ℓ/dε² (<= 0) of each candidate at its ε
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):  # p = 0 at ε = 0: an infinite slope
            ratio = (1 / k - p) / ((1 - eps)[:, None] * p + eps[:, None] / k)
            return (counts * ratio).sum(1), -(counts * ratio ** 2).sum(1)

    at0, at1 = slope_curvature(p, np.zeros(len(p)))[0], slope_curvature(p, np.ones(len(p)))[0]
    eps = np.where(at0 <= 0, 0.0, 1.0)
    inner = np.flatnonzero((at0 > 0) & (at1 < 0))
    if len(inner):
        sub = p[inner]
        lo, hi, x = np.zeros(len(inner)), np.ones(len(inner)), np.full(len(inner), 0.5)
        for _ in range(200):
            g, h = slope_curvature(sub, x)
            lo, hi = np.where(g > 0, x, lo), np.where(g > 0, hi, x)
            with np.errstate(divide="ignore", invalid="ignore"):
                step = x - g / h
            new = np.where((step > lo) & (step < hi), step, (lo + hi) / 2)
            done = np.abs(new - x) <= 4 * np.finfo(float).eps
            x = new
            if done.all():
                break
        eps[inner] = x
    with np.errstate(divide="ignore"):
        ll = (counts * np.log((1 - eps)[:, None] * p + eps[:, None] / k)).sum(1)
    return eps, ll


def profile(q: np.ndarray, classes, k: int) -> tuple[np.ndarray, np.ndarray]:
    """q (C, S, T, K) -> best_lapse of each candidate: ((C,) ε, (C,) ℓ at it)."""
    s, t, c, counts = classes
    return best_lapse(q[:, s, t, c], counts, k)


def smooth_maximum(profile_of, values: np.ndarray, profile: np.ndarray) -> float:
    """The τ / λ maximising profile_of(v) = max over ε of ℓ(v, ε), from the grid's best by a bounded
    Brent search on log10 v between its grid neighbours (the profile is smooth in λ)."""
    order = np.argsort(values)
    values, profile = values[order], profile[order]
    g = int(np.argmax(profile))
    lo, hi = np.log10(values[max(g - 1, 0)]), np.log10(values[min(g + 1, len(values) - 1)])
    res = minimize_scalar(lambda x: -profile_of(10.0 ** x), bounds=(lo, hi), method="bounded",
                          options={"xatol": 1e-8, "maxiter": 200})
    return float(10.0 ** res.x) if -res.fun > profile[g] else float(values[g])


def step_counts(model: Deterministic, dist: Distances, options: list[OptionDistances], sequences) -> np.ndarray:
    """(S, T, K, N) float32 a sorted along N: θ n counts for option k after sequence s (its training
    examples and the option all within τ of its trajectories) exactly when a <= τ, so the deterministic
    learner's q(k) is #{a_stk <= τ} / Σ_j #{a_stj <= τ} (1 / K when every count is 0)."""
    d = dist.get(model.metric)
    n = dist.shape[1]
    out = np.empty((len(sequences), len(options), options[0].shape[0], n), np.float32)
    for s, seq in enumerate(sequences):
        needed = d[list(seq)].max(0) if len(seq) else np.full(n, -np.inf, np.float32)
        for t, o in enumerate(options):
            out[s, t] = np.maximum(needed[None, :], o.get(model.metric))
    out.sort(-1)
    return out


def step_maximum(a: np.ndarray, classes, k: int, bounds: tuple[float, float]) -> tuple[float, float]:
    """The best step of a deterministic learner's ℓ, a step function of τ that changes only where τ
    reaches one of the values in a (:func:`_step_counts`): every step within `bounds` is scored at its
    start with its best ε; returns the step's (start, end) (end: the next start or the upper bound)."""
    starts = np.unique(a[(a > bounds[0]) & (a <= bounds[1])]).astype(np.float64)
    starts = np.concatenate([[bounds[0]], starts])
    rows = a.reshape(-1, a.shape[-1])
    best, best_ll = 0, -np.inf
    for lo in range(0, len(starts), 2048):  # (C, S·T·K) counts, a block of candidates at a time
        cand = starts[lo:lo + 2048].astype(np.float32)
        counts = np.stack([np.searchsorted(r, cand, side="right") for r in rows], 1).astype(np.float64)
        counts = counts.reshape((len(cand),) + a.shape[:3])
        total = counts.sum(-1, keepdims=True)
        q = np.where(total > 0, counts / np.maximum(total, 1), 1.0 / k)
        ll = profile(q, classes, k)[1]
        i = int(np.argmax(ll))
        if ll[i] > best_ll:
            best, best_ll = lo + i, float(ll[i])
    return float(starts[best]), float(starts[best + 1]) if best + 1 < len(starts) else bounds[1]


def step_value(start: float, end: float) -> float:
    """A τ inside the step [start, end): their geometric middle, or the start where float32 (the precision
    the learner compares distances in) would round the middle onto the end."""
    mid = float(np.sqrt(start * end))
    return mid if start <= np.float32(mid) < np.float32(end) else start
