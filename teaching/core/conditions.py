"""The study's conditions as registered selectors, and running them on a table.

Every condition of the paper is a selector (:mod:`teaching.core.selectors`) built from the numeric
parts in :mod:`teaching.core.selection`: the greedy sequence of every learner model (named after
it), random, coverage-approx* and coverage-random.  They share one :class:`SelectionContext` per
run.  :func:`teach` runs them all, :func:`condition_sequence` any one registered selector (the
example-based ones of :mod:`teaching.core.summaries` included), :func:`build_sequences` returns
the paper's nine as environment ids.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from tqdm.auto import tqdm

from .learners import LEARNER_NAMES, Distances, LearnerModel, make_model
from .selection import (
    APPROX_STAR,
    CONDITIONS,
    DEFAULT_SETTINGS,
    RANDOM_LENGTH,
    SelectionSettings,
    Sequence,
    SweepRow,
    coverage_sequence,
    evaluated,
    fitted_model,
    greedy_sequence,
    random_draws,
    showable,
)
from .selectors import (
    Param,
    Selector,
    check_params,
    get_selector,
    integer_at_least,
    register_selector,
    selector_names,
)

UNIFORM_STREAM = 0x756E69  # random-uniform's own stream of the run's seed, apart from the random baseline's


@dataclass
class TeachingResult:
    """Everything the selectors produce for one table (indices are table rows)."""

    models: dict[str, LearnerModel]  # the 8 user models (LEARNER_NAMES) with their chosen τ / λ
    sequences: dict[str, Sequence]  # per model name, plus random / coverage conditions
    sweeps: dict[str, list[SweepRow]]
    rule_met: dict[str, bool]
    random_p: np.ndarray  # exact-IRL P(θ*) of the 1000 random draws


class SelectionContext:
    """What the selectors of one run share: the table, its distances, the seed, the settings and
    the fixed τ / λ; each learner model fitted once (its sweep, if any) and the random stream
    drawn once, whichever selector asks first.  One (M, N) float32 buffer is reused for every
    likelihood matrix, so a selector uses its matrix before asking for another."""

    def __init__(self, table, *, seed: int = 0, hyperparameters: dict | None = None,
                 settings: SelectionSettings = DEFAULT_SETTINGS, dist: Distances | None = None,
                 like: SelectionContext | None = None):
        """like: a context of the same table, hyperparameters and settings under another seed, whose fitted
        models, shared derivations (:meth:`shared`: the table's alone) and buffer this one reuses: no seed changes
        them."""
        self.table, self.seed, self.settings = table, seed, settings
        self.hyperparameters = dict(hyperparameters or {})
        self.dist = dist or Distances(table)
        self.eligible = showable(table)
        self._buffer = None if like is None else like._buffer
        self._fitted: dict[str, tuple] = {} if like is None else like._fitted
        self._random = None
        self._shared: dict[str, object] = {} if like is None else like._shared

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

    def shared(self, key: str, compute):
        """compute() once per run under ``key``: what several selectors derive from the table alike
        (e.g. the BECs of the showable environments and SCOT's cover, which bec-scaffold builds on).  From the
        table alone, never the seed: contexts made ``like`` this one share them."""
        if key not in self._shared:
            self._shared[key] = compute()
        return self._shared[key]

    def evaluated(self, envs: list[int], model_name: str) -> Sequence:
        """``envs`` with P(θ*) after each under the fitted model ``model_name``."""
        return evaluated(envs, self.fitted(model_name)[0], self.dist)


def _model_name(value) -> str:
    make_model(value)  # raises for an unknown name
    return str(value)


def greedy_selector(model_name: str) -> Selector:
    """The greedy sequence under learner model ``model_name`` (its τ / λ fixed or swept):
    the condition named after the model."""
    return Selector(model_name, lambda ctx: greedy_sequence(ctx.likelihood(model_name), ctx.settings, ctx.eligible),
                    scored_by=lambda params: model_name,
                    doc=f"greedy maximisation of P(θ*) under the {model_name} learner")


_MODEL_PARAM = {"model": Param(APPROX_STAR, _model_name, "the learner model (approx*)")}
for _name in LEARNER_NAMES:
    register_selector(greedy_selector(_name))
register_selector(Selector(
    "random", lambda ctx: ctx.evaluated(ctx.random()[0], "exact"),
    doc="the median by exact-IRL P(θ*) of RANDOM_DRAWS random sequences of RANDOM_LENGTH environments"))


def uniform_random(ctx: SelectionContext, length: int) -> Sequence:
    """`length` environments drawn uniformly and independently (repeats allowed) from the showable ones, scored
    under the exact learner: the plain random baseline, whose expected learning curve has a closed form where
    the random median above has none."""
    pool = np.flatnonzero(ctx.eligible)
    if not pool.size:
        raise ValueError("no showable environment to draw from (each shows none of its class's strategies)")
    rng = np.random.default_rng([ctx.seed, UNIFORM_STREAM])
    return ctx.evaluated(rng.choice(pool, size=length).tolist(), "exact")


register_selector(Selector(
    "random-uniform", uniform_random,
    params={"length": Param(RANDOM_LENGTH, integer_at_least(1), "examples drawn")},
    doc="environments drawn uniformly at random (repeats allowed) from the showable ones, one stream per seed"))
register_selector(Selector(
    "coverage-approx*", lambda ctx, model: coverage_sequence(ctx.likelihood(model), ctx.table, ctx.settings),
    params=_MODEL_PARAM, scored_by=lambda params: params["model"],
    doc="greedy under approx* until the gain is below ε, then the best example of each missing cluster"))
register_selector(Selector(
    "coverage-random", lambda ctx, model: ctx.evaluated(ctx.random()[1], model),
    params=_MODEL_PARAM, scored_by=lambda params: params["model"],
    doc="one random environment per strategy cluster θ* shows, scored under approx*"))


def _condition_params(name: str, approx_star: str) -> dict:
    """A condition's parameters when named the paper's way (approx* for both coverage conditions)."""
    return {"model": approx_star} if "model" in get_selector(name).params else {}


def condition_params(name: str, params: dict | None = None, approx_star: str = APPROX_STAR) -> dict:
    """Every parameter :func:`condition_sequence` runs selector ``name`` with: ``params`` checked, approx*
    as a coverage condition's ``model`` where params name none, defaults for the rest (ValueError, one line)."""
    return check_params(name, {**_condition_params(name, approx_star), **(params or {})})


def condition_sequence(table, name: str, *, seed: int = 0, approx_star: str = APPROX_STAR,
                       hyperparameters: dict | None = None, settings: SelectionSettings = DEFAULT_SETTINGS,
                       dist: Distances | None = None, params: dict | None = None):
    """One condition's sequence on its own (the unit of a worker's task): the same result as
    ``teach(...).sequences[name]``.  ``name``: any registered selector (:func:`selector_names`);
    params: its parameters (approx_star fills a coverage condition's ``model`` when params do not).
    Returns (Sequence, the model it is scored under, rule met or None)."""
    if name not in selector_names():
        raise ValueError(f"unknown condition {name!r}; choose from {', '.join(selector_names())}")
    params = condition_params(name, params, approx_star)
    ctx = SelectionContext(table, seed=seed, hyperparameters=hyperparameters, settings=settings, dist=dist)
    selector = get_selector(name)
    sequence = selector.select(ctx, **params)
    model, _, met = ctx.fitted(selector.scored_by(params))
    return sequence, model, met


def teach(table, *, seed: int = 0, approx_star: str = APPROX_STAR, hyperparameters: dict | None = None,
          settings: SelectionSettings = DEFAULT_SETTINGS, progress: bool = False,
          dist: Distances | None = None, added: dict[str, tuple[str, dict]] | None = None) -> TeachingResult:
    """Run every selector on ``table``: hyperparameter sweeps, the 8 learners' sequences,
    random, coverage-approx* and coverage-random.  Seeded and deterministic.

    hyperparameters: {model name: τ or λ} fixes a value instead of sweeping.  settings: the
    sweep grid, ε, the longest sequence and repeats (:class:`SelectionSettings`).  Each model is
    swept once and the random stream drawn once (one :class:`SelectionContext`), so this is
    cheaper than calling :func:`condition_sequence` per condition, with the same results.
    added: {label: (selector name, its parameters)}: more sequences under those labels (e.g. from
    :func:`teaching.core.selectors.parse_selector`), run on the same context after the conditions.
    """
    hyperparameters = dict(hyperparameters or {})
    for name, value in hyperparameters.items():
        make_model(name, value)  # validates name and value
    taken = {*LEARNER_NAMES, approx_star, "random", "coverage-approx*", "coverage-random"}
    for label, (name, params) in (added or {}).items():  # before the sweeps: a bad one fails at once
        if label in taken:
            raise ValueError(f"selector {label!r}: the teach output already has a sequence of that name")
        check_params(name, params)
    make_model(approx_star)
    if table.n_envs == 0:
        raise ValueError("the table has no environments")
    ctx = SelectionContext(table, seed=seed, hyperparameters=hyperparameters, settings=settings, dist=dist)
    models, sequences, sweeps, rule_met = {}, {}, {}, {}
    names = LEARNER_NAMES + (() if approx_star in LEARNER_NAMES else (approx_star,))
    bar = tqdm(total=len(names) + 1 + len(added or {}), desc="teaching", disable=not progress)
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
    for label, (name, params) in (added or {}).items():
        try:
            sequences[label] = get_selector(name).select(ctx, **check_params(name, params))
        except ValueError as exc:  # e.g. a table an example-based selector has nothing to choose from
            raise ValueError(f"selector {label!r}: {exc}") from None
        bar.update()
    bar.close()
    return TeachingResult(models, sequences, sweeps, rule_met, ctx.random()[2])


def build_sequences(table, *, seed: int = 0, approx_star: str = APPROX_STAR, **kwargs) -> dict[str, list[int]]:
    """The study's conditions (CONDITIONS) -> environment *ids* in the order to show.

    approx_star: the model that coverage-approx* augments (APPROX_STAR, the paper's
    best, by default).  Other keyword arguments go to :func:`teach`.
    """
    result = teach(table, seed=seed, approx_star=approx_star, **kwargs)
    ids = np.asarray(table.env_ids)
    return {c: [int(i) for i in ids[result.sequences[c].envs]] for c in CONDITIONS}
