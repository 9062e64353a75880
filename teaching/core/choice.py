"""The choice model: which of a test's options a learner picks (docs/analysis.md).

After training examples S, learner model M believes P_M(θ | S) (:func:`learners.posterior`).  A test
in environment E shows K options, each the optimal trajectory ξ_k of some θ_{o_k} there.  Option k's
weight is the belief-weighted likelihood, under M, of ξ_k being the robot's trajectory:

    w_k = Σ_θ P_M(θ | S) · P_M(ξ_k | θ, E)

with P_M(ξ | θ, E) the same likelihood M uses to learn (exact IRL: ξ optimal for θ; det: the
distance from θ's optimal trajectory to ξ within τ; prob: exp(-λ d)), here measured from θ's optimal
trajectory to ξ_k instead of to θ*'s.  The choice probability mixes the normalised weights with a
lapse rate ε (a uniform guess):

    P(k | S, E) = (1 - ε) · w_k / Σ_j w_j + ε / K.

When every w_k is 0 (no θ the learner believes in would produce any option), the learner has nothing to
go by and guesses: P(k) = 1 / K.

The weights are computed in log space, log w_k = logsumexp_θ(log P_M(θ | S) + log P_M(ξ_k | θ, E)), and
normalised by their logsumexp: at large λ d every exp(-λ d) is below float32's (and float64's) smallest
number, and computed directly all weights would be 0 (a guess) where the model picks the nearest option.
"""
from __future__ import annotations

from functools import cached_property

import numpy as np

from .learners import METRICS, LearnerModel


class OptionDistances:
    """How far each θ's optimal trajectory in one environment is from each of K option trajectories:
    the :class:`learners.Distances` interface with rows = options, so every learner model's
    ``likelihood`` gives (K, N) P_M(ξ_k | θ_n, E) unchanged.

    table: a trajectory table; env_index: the environment (a row of the table); options: (K,) the
    θ indices whose optimal trajectories the options are.
    """

    def __init__(self, table, env_index: int, options):
        self.table = table
        self.env_index = int(env_index)
        self.options = np.asarray(options, np.int64)
        if self.options.ndim != 1 or not len(self.options):
            raise ValueError("options must be a non-empty list of theta indices")
        if self.options.min() < 0 or self.options.max() >= table.n_thetas:
            raise ValueError(f"option theta indices must lie in [0, {table.n_thetas})")

    @property
    def shape(self) -> tuple[int, int]:
        return (len(self.options), self.table.n_thetas)

    @cached_property
    def theta_norms(self) -> np.ndarray:
        return np.linalg.norm(np.asarray(self.table.thetas, np.float64), axis=1).astype(np.float32)

    @cached_property
    def reward(self) -> np.ndarray:
        """θ_n·(φ(ξ^θn) - φ(ξ_k)) >= 0: how much reward θ n gives up if the robot takes option k."""
        phi = np.asarray(self.table.features[self.env_index], np.float64)  # (N, D)
        thetas = np.asarray(self.table.thetas, np.float64)
        own = np.einsum("nd,nd->n", phi, thetas)  # (N,) θ_n·φ(ξ^θn)
        return (own[None, :] - phi[self.options] @ thetas.T).astype(np.float32)

    @cached_property
    def euclidean(self) -> np.ndarray:
        """The Euclidean learner's distance (the domain's) from θ n's trajectory to option k's."""
        states = np.asarray(self.table.states(self.env_index, np.arange(self.table.n_thetas)))  # (N, T+1, S)
        d = self.table.domain.euclidean_distance(states[None, :], states[self.options][:, None])
        return np.asarray(d, np.float32)

    @cached_property
    def strategy(self) -> np.ndarray:
        s = np.asarray(self.table.strategy[self.env_index])
        return np.where(s[None, :] == s[self.options][:, None], np.float32(0), np.float32(np.inf))

    def get(self, metric: str) -> np.ndarray:
        if metric not in METRICS:
            raise ValueError(f"unknown distance metric {metric!r}; choose from {METRICS}")
        return getattr(self, metric)


def _logsumexp(a: np.ndarray, axis: int = -1) -> np.ndarray:
    """log Σ exp(a) along `axis` (-inf where every term is -inf), without leaving float64's range."""
    m = np.max(a, axis=axis, keepdims=True)
    m = np.where(np.isfinite(m), m, 0.0)
    with np.errstate(divide="ignore"):  # no term has weight: log 0
        return np.log(np.exp(a - m).sum(axis)) + np.squeeze(m, axis)


def log_choice_probabilities(log_belief: np.ndarray, log_likelihood: np.ndarray, lapse: float) -> np.ndarray:
    """(N,) log P(θ | S), (..., K, N) log P(ξ_k | θ) (float64; -inf: ruled out; leading axes: several tests at
    once), lapse ε in [0, 1] -> (..., K) P(k).

    The module's equation in log space; a guess (1 / K each) where no option has any weight."""
    if not 0 <= lapse <= 1:
        raise ValueError(f"the lapse rate must lie in [0, 1], got {lapse}")
    log_w = _logsumexp(np.asarray(log_likelihood, np.float64) + np.asarray(log_belief, np.float64), -1)  # (..., K)
    k = log_w.shape[-1]
    norm = _logsumexp(log_w, -1)[..., None]
    with np.errstate(invalid="ignore"):  # -inf - -inf where no option has weight: replaced by the guess
        p = np.where(np.isfinite(norm), np.exp(log_w - norm), 1.0 / k)
    return (1.0 - lapse) * p + lapse / k


def choice_probabilities(belief: np.ndarray, likelihood: np.ndarray, lapse: float) -> np.ndarray:
    """(N,) belief P(θ | S), (K, N) likelihoods P(ξ_k | θ), lapse ε in [0, 1] -> (K,) P(k).

    The module's equation (:func:`log_choice_probabilities` on their logarithms)."""
    with np.errstate(divide="ignore"):
        return log_choice_probabilities(np.log(np.asarray(belief, np.float64)),
                                        np.log(np.asarray(likelihood, np.float64)), lapse)


def option_choice(model: LearnerModel, belief: np.ndarray, table, env_index: int, options,
                  lapse: float) -> np.ndarray:
    """(K,) P(participant picks option k) of a test in environment `env_index` whose options are the
    optimal trajectories of θ indices `options`, for a learner of `model` believing `belief` (N,)."""
    log_lik = model.log_likelihood(OptionDistances(table, env_index, options))
    with np.errstate(divide="ignore"):
        return log_choice_probabilities(np.log(np.asarray(belief, np.float64)), log_lik, lapse)
