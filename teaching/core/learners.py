"""Learner models: how a person updates P(θ) from optimal trajectories (DESIGN §5).

P(θ | ξ^{θ*}_{E_1:n}) ∝ P(θ) Π_i P(ξ^{θ*}_{E_i} | θ) with a uniform prior over Θ
(the table's thetas, θ* = thetas[0]).

Every model is a map from a distance matrix d (M, N) — how far θ n's optimal
trajectory in environment m is from θ*'s — to a likelihood matrix in [0, 1]:

* exact IRL:               1 if d_reward <= ε_exact, else 0
* deterministic × metric:  1 if d <= τ, else 0
* probabilistic × metric:  exp(-λ d)  (unnormalised, as in the paper)

with metric ∈ {reward, euclidean, strategy}; d_strategy is 0 within a cluster
and ∞ across, so probabilistic × strategy equals deterministic × strategy.

* hierarchical:            [same strategy] · exp(-λ d_euclidean)

The paper's Discussion proposes the last one: people first determine which
strategy the robot takes, then the most likely trajectory within that strategy
cluster.  A θ whose optimal trajectory takes another strategy than the example
is ruled out (the strategy learner), and among the rest nearness counts as for
the probabilistic Euclidean learner.  It is not one of the paper's seven ideal
users (MODEL_NAMES); every model registered is in :func:`model_names`.

To add a model, subclass :class:`LearnerModel` (implement ``likelihood``) and
:func:`register_model` a factory for it; the selectors only call
``likelihood``.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np
from scipy.special import logsumexp

# d_reward / |θ| at or below this counts as "optimal" for exact IRL.  It is in normalised
# reward units (θ·φ / |θ|), the planner's own yardstick: the optimum does not change when θ
# is scaled, so neither may the test for it (raw units would make the test 640x stricter for
# one θ than for another).  The planner's trajectories are within ~3e-8 of optimal in 99 % of
# (E, θ) against an independent reference, so a trajectory within 1e-6 is optimal for θ to
# solver precision (docs/teaching.md, docs/benchmarks.md).
EXACT_TOLERANCE = 1e-6
METRICS = ("reward", "euclidean", "strategy")


class Distances:
    """Distance matrices of one table, computed once and shared by all models.

    ``reward``, ``euclidean``, ``strategy``: (M, N) float32 (strategy is 0 / inf).
    Each costs 4·M·N bytes (85 MB at paper size) and is built on first use.
    """

    def __init__(self, table, chunk: int = 1024):
        self.table = table
        self.chunk = chunk

    @cached_property
    def theta_norms(self) -> np.ndarray:
        """(N,) |θ|: d_reward / |θ| is in normalised reward units."""
        return np.linalg.norm(np.asarray(self.table.thetas, np.float64), axis=1).astype(np.float32)

    @property
    def shape(self) -> tuple[int, int]:
        return (self.table.n_envs, self.table.n_thetas)

    @cached_property
    def reward(self) -> np.ndarray:
        """θ·φ(ξ^θ) - θ·φ(ξ^θ*); written as θ·(φ_θ - φ_θ*) so column 0 is exactly 0."""
        feats, thetas = self.table.features, np.asarray(self.table.thetas, np.float64)
        out = np.empty(self.shape, np.float32)
        for lo in range(0, self.shape[0], self.chunk):
            f = np.asarray(feats[lo:lo + self.chunk], np.float64)
            out[lo:lo + self.chunk] = np.einsum("mnf,nf->mn", f - f[:, :1], thetas)
        return out

    @cached_property
    def euclidean(self) -> np.ndarray:
        return np.ascontiguousarray(self.table.d_euclid, dtype=np.float32)

    @cached_property
    def strategy(self) -> np.ndarray:
        s = np.asarray(self.table.strategy)
        return np.where(s == s[:, :1], np.float32(0), np.float32(np.inf))

    def get(self, metric: str) -> np.ndarray:
        if metric not in METRICS:
            raise ValueError(f"unknown distance metric {metric!r}; choose from {METRICS}")
        return getattr(self, metric)


def _rows(d: np.ndarray, rows) -> np.ndarray:
    return d if rows is None else d[np.asarray(rows, dtype=np.int64)]


class LearnerModel:
    """P(ξ^{θ*}_E | θ) as a function of a table's distances.

    Subclasses set ``name`` and implement ``likelihood``; ``param`` names the
    hyperparameter ("tau", "lambda" or None) and ``value`` holds it.
    """

    name: str = "model"
    param: str | None = None
    value: float | None = None

    def likelihood(self, dist: Distances, rows=None, out: np.ndarray | None = None) -> np.ndarray:
        """(R, N) float32 in [0, 1] for environments ``rows`` (all M when None)."""
        raise NotImplementedError

    def log_likelihood(self, dist: Distances, rows=None) -> np.ndarray:
        """(R, N) float64 log P(ξ | θ) (-inf: ruled out).  A model whose likelihood can fall below
        float32's smallest number (exp(-λ d) at large λ d) overrides this to compute it in log space,
        so that such θs keep their order instead of all becoming 0."""
        with np.errstate(divide="ignore"):
            return np.log(self.likelihood(dist, rows).astype(np.float64))

    def with_value(self, value: float) -> LearnerModel:
        """The same model with another hyperparameter value."""
        if self.param is None:
            return self
        return replace(self, value=check_value(self.name, value))

    def __str__(self) -> str:
        return self.name if self.param is None else f"{self.name}({self.param}={self.value:g})"


def check_value(name: str, value) -> float:
    v = float(value)
    if not np.isfinite(v) or v <= 0:
        raise ValueError(f"{name}: hyperparameter must be a finite number > 0, got {value!r}")
    return v


@dataclass(frozen=True)
class ExactIRL(LearnerModel):
    name: str = "exact"
    tolerance: float = EXACT_TOLERANCE  # normalised reward units

    def likelihood(self, dist, rows=None, out=None):
        d = _rows(dist.reward, rows)
        out = np.empty(d.shape, np.float32) if out is None else out
        out[...] = d <= self.tolerance * dist.theta_norms
        return out


@dataclass(frozen=True)
class Deterministic(LearnerModel):
    metric: str = "euclidean"
    value: float = 1.0
    param: str = "tau"

    @property
    def name(self) -> str:  # type: ignore[override]
        return f"det-{self.metric}"

    def likelihood(self, dist, rows=None, out=None):
        d = _rows(dist.get(self.metric), rows)
        out = np.empty(d.shape, np.float32) if out is None else out
        out[...] = d <= self.value
        return out


@dataclass(frozen=True)
class Probabilistic(LearnerModel):
    metric: str = "euclidean"
    value: float = 1.0
    param: str = "lambda"

    @property
    def name(self) -> str:  # type: ignore[override]
        return f"prob-{self.metric}"

    def likelihood(self, dist, rows=None, out=None):
        d = _rows(dist.get(self.metric), rows)
        out = np.empty(d.shape, np.float32) if out is None else out
        np.multiply(d, np.float32(-self.value), out=out)  # inf (other strategy) -> exp(-inf) = 0
        np.exp(out, out=out)
        return out

    def log_likelihood(self, dist, rows=None):
        return -self.value * _rows(dist.get(self.metric), rows).astype(np.float64)  # inf -> -inf


@dataclass(frozen=True)
class Hierarchical(LearnerModel):
    """Strategy first, then the trajectory within it (the paper's Discussion)."""

    value: float = 1.0
    param: str = "lambda"
    name: str = "hierarchical"

    def likelihood(self, dist, rows=None, out=None):
        d = _rows(dist.euclidean, rows)
        out = np.empty(d.shape, np.float32) if out is None else out
        np.multiply(d, np.float32(-self.value), out=out)
        np.exp(out, out=out)
        out[_rows(dist.strategy, rows) != 0] = 0  # another strategy: ruled out
        return out

    def log_likelihood(self, dist, rows=None):
        out = -self.value * _rows(dist.euclidean, rows).astype(np.float64)
        out[_rows(dist.strategy, rows) != 0] = -np.inf
        return out


_REGISTRY: dict[str, Callable[[float | None], LearnerModel]] = {
    "exact": lambda v: ExactIRL(),
    "det-reward": lambda v: Deterministic("reward", 1.0 if v is None else v),
    "det-euclidean": lambda v: Deterministic("euclidean", 1.0 if v is None else v),
    "det-strategy": lambda v: Deterministic("strategy", 1.0 if v is None else v),
    "prob-reward": lambda v: Probabilistic("reward", 1.0 if v is None else v),
    "prob-euclidean": lambda v: Probabilistic("euclidean", 1.0 if v is None else v),
    "prob-strategy": lambda v: Probabilistic("strategy", 1.0 if v is None else v),
}
# The paper's 7 ideal users, in the order of its figures.
MODEL_NAMES = tuple(_REGISTRY)
_REGISTRY["hierarchical"] = lambda v: Hierarchical(1.0 if v is None else v)
# The ideal users the platform evaluates and teaches for: the paper's seven and the hierarchical learner.
LEARNER_NAMES = MODEL_NAMES + ("hierarchical",)


def register_model(name: str, factory: Callable[[float | None], LearnerModel]) -> None:
    """Make a new model available to make_model / the CLI under ``name``."""
    _REGISTRY[name] = factory


def model_names() -> tuple[str, ...]:
    return tuple(_REGISTRY)


def make_model(name: str, value: float | None = None) -> LearnerModel:
    """The model called ``name`` (see MODEL_NAMES) with τ or λ = value (default 1)."""
    if name not in _REGISTRY:
        raise ValueError(f"unknown learner model {name!r}; choose from {', '.join(_REGISTRY)}")
    if value is not None:
        check_value(name, value)
    return _REGISTRY[name](value)


def parse_hyperparameters(items) -> dict[str, float]:
    """{model name: τ or λ} from "MODEL=VALUE" strings (a command line's repeated --hyper), each
    checked by make_model.  Raises ValueError with a one-line message naming the bad item."""
    out = {}
    for item in items:
        name, sep, value = item.partition("=")
        if not sep:
            raise ValueError(f"--hyper expects MODEL=VALUE, got {item!r}")
        try:
            v = float(value)
        except ValueError:
            raise ValueError(f"--hyper {item!r}: {value!r} is not a number") from None
        make_model(name, v)
        out[name] = v
    return out


def has_hyperparameter(model: LearnerModel) -> bool:
    """False for exact IRL and the strategy models (their distance is 0 or ∞, so τ/λ do nothing)."""
    return model.param is not None and getattr(model, "metric", None) != "strategy"


# --- posterior ---------------------------------------------------------------
def log_weights(model: LearnerModel, dist: Distances, sequence) -> np.ndarray:
    """(N,) log Π_i P(ξ^{θ*}_{E_i} | θ) over the environment indices in ``sequence``."""
    seq = np.asarray(sequence, dtype=np.int64)
    if seq.size == 0:
        return np.zeros(dist.shape[1])
    lik = model.likelihood(dist, rows=seq).astype(np.float64)
    with np.errstate(divide="ignore"):
        return np.log(lik).sum(0)


def posterior(model: LearnerModel, dist: Distances, sequence) -> np.ndarray:
    """(N,) P_M(θ | ξ^{θ*}_{E_1:n}) under a uniform prior over the table's thetas."""
    lw = log_weights(model, dist, sequence)
    if not np.isfinite(lw).any():
        return np.zeros_like(lw)
    return np.exp(lw - logsumexp(lw))


def log_posterior(model: LearnerModel, dist: Distances, sequence) -> np.ndarray:
    """(N,) log P_M(θ | ξ^{θ*}_{E_1:n}) from the model's log-likelihoods in float64 (-inf: ruled out;
    all -inf when every θ is), for the choice model: a θ whose posterior is below float32's range
    still counts there when the options' likelihoods of the others are smaller still."""
    seq = np.asarray(sequence, dtype=np.int64)
    if seq.size == 0:
        return np.full(dist.shape[1], -np.log(dist.shape[1]))
    lw = model.log_likelihood(dist, rows=seq).sum(0)
    if not np.isfinite(lw).any():
        return lw
    return lw - logsumexp(lw)


def p_theta_star(model: LearnerModel, dist: Distances, sequence) -> float:
    """P_M(θ* | ξ^{θ*}_{E_1:n}); θ* is the table's theta 0."""
    lw = log_weights(model, dist, sequence)
    if not np.isfinite(lw[0]):
        return 0.0
    return float(np.exp(lw[0] - logsumexp(lw)))


def p_curve(model: LearnerModel, dist: Distances, sequence) -> np.ndarray:
    """(n,) P_M(θ* | ξ_{E_1:t}) for t = 1..n."""
    seq = np.asarray(sequence, dtype=np.int64)
    if seq.size == 0:
        return np.zeros(0)
    with np.errstate(divide="ignore"):
        lw = np.cumsum(np.log(model.likelihood(dist, rows=seq).astype(np.float64)), axis=0)
    out = np.zeros(len(seq))
    ok = np.isfinite(lw[:, 0])
    out[ok] = np.exp(lw[ok, 0] - logsumexp(lw[ok], axis=1))
    return out
