"""Teaching algorithms: choose the environments whose θ* trajectories to show (DESIGN §6).

All selectors work on a likelihood matrix L (M, N) float32 = P(ξ^{θ*}_{E_m} | θ_n)
from a :class:`~teaching.core.learners.LearnerModel`, and return environment
*indices* (rows of the table); :func:`build_sequences` maps them to ids.  Each condition is a
selector in the registry (:mod:`teaching.core.selectors`): the greedy sequence of every learner
model (named after it), random, coverage-approx* and coverage-random register themselves here.

With weights w_n = Π_{shown} L[E, n] (uniform prior), showing E next gives
P(θ*) = w_0 L[E, 0] / (L[E] · w), so one greedy step is one matrix-vector
product.  For the deterministic models L is 0/1 and L·w counts surviving θ
exactly in float32.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from tqdm.auto import tqdm

from .domain import n_clusters
from .learners import LEARNER_NAMES, Distances, LearnerModel, has_hyperparameter, make_model, p_curve
from .selectors import Param, Selector, check_params, get_selector, register_selector, selector_names

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
        rows.append(SweepRow(float(value), _greedy(lik, settings, eligible)))
    return rows


def _greedy(lik: np.ndarray, settings: SelectionSettings, eligible: np.ndarray) -> Sequence:
    return greedy(lik, max_examples=settings.max_examples, allow_repeats=settings.allow_repeats,
                  eligible=eligible)[0]


def _coverage(lik: np.ndarray, table, settings: SelectionSettings) -> Sequence:
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


@dataclass
class TeachingResult:
    """Everything the selectors produce for one table (indices are table rows)."""

    models: dict[str, LearnerModel]  # the 8 user models (LEARNER_NAMES) with their chosen τ / λ
    sequences: dict[str, Sequence]  # per model name, plus random / coverage conditions
    sweeps: dict[str, list[SweepRow]]
    rule_met: dict[str, bool]
    random_p: np.ndarray  # exact-IRL P(θ*) of the 1000 random draws


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


class SelectionContext:
    """What the selectors of one run share: the table, its distances, the seed, the settings and
    the fixed τ / λ; each learner model fitted once (its sweep, if any) and the random stream
    drawn once, whichever selector asks first.  One (M, N) float32 buffer is reused for every
    likelihood matrix, so a selector uses its matrix before asking for another."""

    def __init__(self, table, *, seed: int = 0, hyperparameters: dict | None = None,
                 settings: SelectionSettings = DEFAULT_SETTINGS, dist: Distances | None = None):
        self.table, self.seed, self.settings = table, seed, settings
        self.hyperparameters = dict(hyperparameters or {})
        self.dist = dist or Distances(table)
        self.eligible = showable(table)
        self._buffer = None
        self._fitted: dict[str, tuple] = {}
        self._random = None

    @property
    def buffer(self) -> np.ndarray:
        if self._buffer is None:
            self._buffer = np.empty(self.dist.shape, np.float32)
        return self._buffer

    def fitted(self, name: str) -> tuple[LearnerModel, list[SweepRow] | None, bool | None]:
        """(model with its τ / λ, sweep rows or None, rule met or None): :func:`fitted_model`, once."""
        if name not in self._fitted:
            self._fitted[name] = fitted_model(name, self.dist, self.hyperparameters, self.settings,
                                              buffer=self.buffer)
        return self._fitted[name]

    def likelihood(self, name: str) -> np.ndarray:
        """(M, N) float32 likelihood matrix of the fitted model ``name`` (in the shared buffer)."""
        return self.fitted(name)[0].likelihood(self.dist, out=self.buffer)

    def random(self) -> tuple[list[int], list[int], np.ndarray]:
        """:func:`random_draws` of this run's seed, once."""
        if self._random is None:
            self._random = random_draws(self.table, self.dist, self.seed)
        return self._random

    def evaluated(self, envs: list[int], model_name: str) -> Sequence:
        """``envs`` with P(θ*) after each under the fitted model ``model_name``."""
        return _evaluated(envs, self.fitted(model_name)[0], self.dist)


def _model_name(value) -> str:
    make_model(value)  # raises for an unknown name
    return str(value)


def greedy_selector(model_name: str) -> Selector:
    """The greedy sequence under learner model ``model_name`` (its τ / λ fixed or swept):
    the condition named after the model."""
    return Selector(model_name, lambda ctx: _greedy(ctx.likelihood(model_name), ctx.settings, ctx.eligible),
                    scored_by=lambda params: model_name,
                    doc=f"greedy maximisation of P(θ*) under the {model_name} learner")


_MODEL_PARAM = {"model": Param(APPROX_STAR, _model_name, "the learner model (approx*)")}
for _name in LEARNER_NAMES:
    register_selector(greedy_selector(_name))
register_selector(Selector(
    "random", lambda ctx: ctx.evaluated(ctx.random()[0], "exact"),
    doc="the median by exact-IRL P(θ*) of RANDOM_DRAWS random sequences of RANDOM_LENGTH environments"))
register_selector(Selector(
    "coverage-approx*", lambda ctx, model: _coverage(ctx.likelihood(model), ctx.table, ctx.settings),
    params=_MODEL_PARAM, scored_by=lambda params: params["model"],
    doc="greedy under approx* until the gain is below ε, then the best example of each missing cluster"))
register_selector(Selector(
    "coverage-random", lambda ctx, model: ctx.evaluated(ctx.random()[1], model),
    params=_MODEL_PARAM, scored_by=lambda params: params["model"],
    doc="one random environment per strategy cluster θ* shows, scored under approx*"))


def _condition_params(name: str, approx_star: str) -> dict:
    """A condition's parameters when named the paper's way (approx* for both coverage conditions)."""
    return {"model": approx_star} if "model" in get_selector(name).params else {}


def condition_sequence(table, name: str, *, seed: int = 0, approx_star: str = APPROX_STAR,
                       hyperparameters: dict | None = None, settings: SelectionSettings = DEFAULT_SETTINGS,
                       dist: Distances | None = None, params: dict | None = None):
    """One condition's sequence on its own (the unit of a worker's task): the same result as
    ``teach(...).sequences[name]``.  ``name``: any registered selector (:func:`selector_names`);
    params: its parameters (approx_star fills a coverage condition's ``model`` when params do not).
    Returns (Sequence, the model it is scored under, rule met or None)."""
    if name not in selector_names():
        raise ValueError(f"unknown condition {name!r}; choose from {', '.join(selector_names())}")
    params = check_params(name, {**_condition_params(name, approx_star), **(params or {})})
    ctx = SelectionContext(table, seed=seed, hyperparameters=hyperparameters, settings=settings, dist=dist)
    selector = get_selector(name)
    sequence = selector.select(ctx, **params)
    model, _, met = ctx.fitted(selector.scored_by(params))
    return sequence, model, met


def teach(table, *, seed: int = 0, approx_star: str = APPROX_STAR, hyperparameters: dict | None = None,
          settings: SelectionSettings = DEFAULT_SETTINGS, progress: bool = False,
          dist: Distances | None = None) -> TeachingResult:
    """Run every selector on ``table``: hyperparameter sweeps, the 8 learners' sequences,
    random, coverage-approx* and coverage-random.  Seeded and deterministic.

    hyperparameters: {model name: τ or λ} fixes a value instead of sweeping.  settings: the
    sweep grid, ε, the longest sequence and repeats (:class:`SelectionSettings`).  Each model is
    swept once and the random stream drawn once (one :class:`SelectionContext`), so this is
    cheaper than calling :func:`condition_sequence` per condition, with the same results.
    """
    hyperparameters = dict(hyperparameters or {})
    for name, value in hyperparameters.items():
        make_model(name, value)  # validates name and value
    make_model(approx_star)
    if table.n_envs == 0:
        raise ValueError("the table has no environments")
    ctx = SelectionContext(table, seed=seed, hyperparameters=hyperparameters, settings=settings, dist=dist)
    models, sequences, sweeps, rule_met = {}, {}, {}, {}
    names = LEARNER_NAMES + (() if approx_star in LEARNER_NAMES else (approx_star,))
    bar = tqdm(total=len(names) + 1, desc="teaching", disable=not progress)
    for name in names:
        model, rows, met = ctx.fitted(name)
        if rows is not None:
            sweeps[name], rule_met[name] = rows, met
        models[name] = model
        sequences[name] = greedy_selector(name).select(ctx)
        if name == approx_star:
            sequences["coverage-approx*"] = get_selector("coverage-approx*").select(ctx, model=approx_star)
        bar.update()
    for name in ("random", "coverage-random"):
        sequences[name] = get_selector(name).select(ctx, **_condition_params(name, approx_star))
    bar.update()
    bar.close()
    return TeachingResult(models, sequences, sweeps, rule_met, ctx.random()[2])


def _evaluated(envs: list[int], model, dist) -> Sequence:
    return Sequence(envs=list(envs), p=p_curve(model, dist, envs).tolist(), prior=1.0 / dist.shape[1])


def build_sequences(table, *, seed: int = 0, approx_star: str = APPROX_STAR, **kwargs) -> dict[str, list[int]]:
    """The study's conditions (CONDITIONS) -> environment *ids* in the order to show.

    approx_star: the model that coverage-approx* augments (APPROX_STAR, the paper's
    best, by default).  Other keyword arguments go to :func:`teach`.
    """
    result = teach(table, seed=seed, approx_star=approx_star, **kwargs)
    ids = np.asarray(table.env_ids)
    return {c: [int(i) for i in ids[result.sequences[c].envs]] for c in CONDITIONS}


from . import summaries  # noqa: E402, F401  (registers the example-based selectors: SCOT, ...)
