"""Teaching algorithms: choose the environments whose θ* trajectories to show (DESIGN §6).

All selectors work on a likelihood matrix L (M, N) float32 = P(ξ^{θ*}_{E_m} | θ_n)
from a :class:`~teaching.core.learners.LearnerModel`, and return environment
*indices* (rows of the table).  These are the numeric parts; the conditions built from them
(the greedy sequence of every learner model, random, coverage-approx*, coverage-random) are
selectors registered in :mod:`teaching.core.conditions`, which also runs them (``teach``,
``condition_sequence``, ``build_sequences``).

With weights w_n = Π_{shown} L[E, n] (uniform prior), showing E next gives
P(θ*) = w_0 L[E, 0] / (L[E] · w), so one greedy step is one matrix-vector
product.  For the deterministic models L is 0/1 and L·w counts surviving θ
exactly in float32.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .domain import n_clusters
from .learners import Distances, LearnerModel, has_hyperparameter, make_model, p_curve

GRID = tuple(10.0 ** k for k in range(-5, 6))  # τ, λ ∈ {1e-5, ..., 1e5}
MAX_EXAMPLES = 10
MIN_RISE = 0.1  # P(θ*) must rise this much from the first to the last example
COVERAGE_EPSILON = 1e-3  # gain in P(θ*) below which coverage takes over
RANDOM_DRAWS, RANDOM_LENGTH = 1000, 8
# An improvement must exceed this relative amount: float32 products cannot resolve less.
IMPROVEMENT_RTOL = 1e-6
CONDITIONS = ("exact", "det-reward", "det-euclidean", "det-strategy", "prob-reward", "prob-euclidean",
              "random", "coverage-approx*", "coverage-random")
# Conditions a study may add to the paper's nine: a learner model's greedy sequence, like the six above.
EXTRA_CONDITIONS = ("hierarchical",)
ALL_CONDITIONS = CONDITIONS + EXTRA_CONDITIONS
# approx*: the model coverage-approx* augments (and coverage-random is scored under).  The paper
# uses its best approximate learner, det-euclidean; every default in the project names this one.
APPROX_STAR = "det-euclidean"


@dataclass(frozen=True)
class SelectionSettings:
    """How the selectors search, shared by every condition of one run: the τ / λ grid the
    hyperparameter rule sweeps, the coverage gain threshold ε, the longest sequence, and whether
    an example may be shown twice.  One object instead of four parameters threaded through
    teach -> fitted_model -> sweep -> greedy / coverage_augmented."""

    grid: tuple[float, ...] = GRID
    epsilon: float = COVERAGE_EPSILON
    max_examples: int = MAX_EXAMPLES
    allow_repeats: bool = True


DEFAULT_SETTINGS = SelectionSettings()


@dataclass
class Sequence:
    """Environment indices in the order shown, and P(θ*) after each one (shape (n,))."""

    envs: list[int]
    p: list[float]
    prior: float
    added_for_coverage: list[int] = field(default_factory=list)

    @property
    def n_unique(self) -> int:
        return len(set(self.envs))


def theta_star_clusters(table) -> np.ndarray:
    """(M,) strategy cluster of θ*'s trajectory in each environment."""
    return np.asarray(table.strategy[:, 0], dtype=np.int64)


def showable(table) -> np.ndarray:
    """(M,) bool: environments whose θ* trajectory shows one of its class's strategies.  The
    others (the domain's "no strategy" label: a trajectory none of its class's strategies
    describes) are never shown to participants."""
    return theta_star_clusters(table) < n_clusters(table.domain)


def _candidate_p(lik: np.ndarray, w: np.ndarray) -> np.ndarray:
    """(M,) P(θ*) after adding each environment to the examples with weights w (N,)."""
    score = lik @ w
    num = lik[:, 0] * w[0]
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(score > 0, num / score, 0.0)


def greedy(lik: np.ndarray, *, max_examples: int = MAX_EXAMPLES, allow_repeats: bool = True,
           stop_gain: float = 0.0, eligible: np.ndarray | None = None) -> tuple[Sequence, np.ndarray]:
    """Greedy maximisation of P(θ* | ξ_{E_1:t}) (paper, "(Submodular) Example Selection").

    lik: (M, N) float32.  Adds the environment with the highest resulting
    P(θ*) (lowest index on ties) until ``max_examples`` or until nothing
    improves P(θ*) — or, with ``stop_gain`` > 0, until the best gain is below
    it.  Repeats are allowed by default: for a probabilistic learner the same
    example lowers wrong θs again (the paper's rule counts *unique* examples).
    eligible: (M,) bool, the environments that may be shown (default all).
    Returns the sequence and the final weights w (N,) float32.
    """
    m, n = lik.shape
    w = np.ones(n, np.float32)
    p_now = 1.0 / n
    seq = Sequence(envs=[], p=[], prior=p_now)
    used = np.zeros(m, bool)
    for _ in range(max_examples):
        p = _candidate_p(lik, w)
        if not allow_repeats:
            p[used] = -1.0
        if eligible is not None:
            p[~eligible] = -1.0
        best = int(np.argmax(p))
        if p[best] <= p_now * (1 + IMPROVEMENT_RTOL) or p[best] - p_now < stop_gain:
            break
        seq.envs.append(best)
        seq.p.append(float(p[best]))
        used[best] = True
        p_now = float(p[best])
        w *= lik[best]
        w /= w.max()  # keep weights away from float32 underflow; P is scale-free
    return seq, w


def coverage_augmented(lik: np.ndarray, clusters: np.ndarray, *, n_clusters: int, epsilon: float = COVERAGE_EPSILON,
                       max_examples: int = MAX_EXAMPLES, allow_repeats: bool = True) -> Sequence:
    """Greedy until the gain drops below ε, then one example per strategy cluster not yet shown.

    clusters: (M,) θ*'s cluster per environment, n_clusters (C) meaning no strategy.  Each added example is the
    best under the model among environments of a missing cluster (the
    cluster whose best example gives the highest P(θ*) goes first).
    Clusters in which θ* never shows its trajectory cannot be covered and
    are skipped; environments where θ* shows no strategy (NO_STRATEGY) are
    never shown.
    """
    eligible = clusters < n_clusters
    seq, w = greedy(lik, max_examples=max_examples, allow_repeats=allow_repeats, stop_gain=epsilon,
                    eligible=eligible)
    missing = set(np.unique(clusters[eligible]).tolist()) - set(clusters[seq.envs].tolist())
    while missing:
        p = _candidate_p(lik, w)
        p[~np.isin(clusters, list(missing))] = -1.0
        best = int(np.argmax(p))
        seq.envs.append(best)
        seq.p.append(float(p[best]))
        seq.added_for_coverage.append(best)
        missing.discard(int(clusters[best]))
        w *= lik[best]
        if w.max() > 0:
            w /= w.max()
    return seq


@dataclass
class SweepRow:
    value: float
    sequence: Sequence

    @property
    def rise(self) -> float:
        p = self.sequence.p
        return p[-1] - p[0] if p else 0.0


def sweep(model: LearnerModel, dist: Distances, settings: SelectionSettings = DEFAULT_SETTINGS, *,
          buffer: np.ndarray | None = None) -> list[SweepRow]:
    """Greedy sequences of ``model`` for every τ / λ in ``settings.grid`` (showable environments only).
    buffer: an (M, N) float32 array to reuse for each likelihood matrix."""
    rows = []
    eligible = showable(dist.table)
    for value in settings.grid:
        lik = model.with_value(value).likelihood(dist, out=buffer)
        rows.append(SweepRow(float(value), greedy_sequence(lik, settings, eligible)))
    return rows


def greedy_sequence(lik: np.ndarray, settings: SelectionSettings, eligible: np.ndarray) -> Sequence:
    """:func:`greedy` on lik (M, N) with ``settings``' cap and repeats, over ``eligible`` (M,) bool."""
    return greedy(lik, max_examples=settings.max_examples, allow_repeats=settings.allow_repeats,
                  eligible=eligible)[0]


def coverage_sequence(lik: np.ndarray, table, settings: SelectionSettings) -> Sequence:
    """:func:`coverage_augmented` on lik (M, N) over ``table``'s θ* clusters with ``settings``."""
    return coverage_augmented(lik, theta_star_clusters(table), n_clusters=n_clusters(table.domain),
                              epsilon=settings.epsilon, max_examples=settings.max_examples,
                              allow_repeats=settings.allow_repeats)


def choose_hyperparameter(rows: list[SweepRow], min_rise: float = MIN_RISE) -> tuple[float, bool]:
    """The paper's rule: among values whose P(θ*) rises by >= min_rise from the first to
    the last example, the one showing the most unique examples.

    Ties go to the higher final P(θ*), then to the smaller value.  When no
    value qualifies, returns the one with the largest rise (same tie-breaks)
    and False, so callers can report that the rule was not met.
    """
    def key(r):
        return (r.sequence.n_unique, r.sequence.p[-1] if r.sequence.p else 0.0, -r.value)

    ok = [r for r in rows if r.rise >= min_rise - 1e-12]
    if ok:
        return max(ok, key=key).value, True
    return max(rows, key=lambda r: (r.rise,) + key(r)).value, False


def random_baseline(dist: Distances, rng: np.random.Generator, n_draws: int = RANDOM_DRAWS,
                    length: int = RANDOM_LENGTH) -> tuple[list[int], np.ndarray, int]:
    """Draw n_draws random sequences of ``length`` distinct environments, rank them by
    exact-IRL P(θ*) (stable: ties keep draw order), return the median one.

    Returns (sequence, P of every draw (n_draws,), index of the chosen draw).
    """
    rows = np.flatnonzero(showable(dist.table))
    length = min(length, len(rows))
    draws = np.stack([rows[rng.choice(len(rows), size=length, replace=False)] for _ in range(n_draws)])
    exact = make_model("exact")
    p = np.array([_p_of(exact, dist, d) for d in draws])
    order = np.argsort(p, kind="stable")
    chosen = int(order[(n_draws - 1) // 2])
    return draws[chosen].tolist(), p, chosen


def _p_of(model, dist, seq) -> float:
    curve = p_curve(model, dist, seq)
    return float(curve[-1]) if len(curve) else 1.0 / dist.shape[1]


def coverage_random(clusters: np.ndarray, rng: np.random.Generator, n_clusters: int) -> list[int]:
    """One random environment from each cluster 0 .. n_clusters - 1 in which θ* appears, in cluster order."""
    out = []
    for c in range(n_clusters):
        members = np.flatnonzero(clusters == c)
        if len(members):
            out.append(int(rng.choice(members)))
    return out


def fitted_model(name: str, dist: Distances, hyperparameters: dict, settings: SelectionSettings = DEFAULT_SETTINGS,
                 *, buffer=None):
    """The learner model `name` with its τ / λ: the value in `hyperparameters`, else the
    paper's sweep rule.  Returns (model, sweep rows, rule met); the last two are None
    when nothing was swept."""
    model = make_model(name, hyperparameters.get(name))
    if not has_hyperparameter(model) or name in hyperparameters:
        return model, None, None
    rows = sweep(model, dist, settings, buffer=buffer)
    value, met = choose_hyperparameter(rows)
    return model.with_value(value), rows, met


def random_draws(table, dist: Distances, seed: int):
    """(random envs, coverage-random envs, exact-IRL P(θ*) of every random draw), from one
    seeded stream: the random baseline draws first, coverage-random after it."""
    rng = np.random.default_rng(seed)
    envs, random_p, _ = random_baseline(dist, rng)
    return envs, coverage_random(theta_star_clusters(table), rng, n_clusters(table.domain)), random_p


def evaluated(envs: list[int], model, dist) -> Sequence:
    """``envs`` (table rows, in showing order) with P(θ*) after each under ``model``."""
    return Sequence(envs=list(envs), p=p_curve(model, dist, envs).tolist(), prior=1.0 / dist.shape[1])
