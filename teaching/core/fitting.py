"""Fitting learner models to participants' answers (equations in docs/analysis.md).

A participant i saw training examples S_i (table rows: their condition's sequence) and answered tests
t = 1..T, each a choice c_it among the K options of a test in environment E_t.  Under learner model M
with hyperparameter v (τ or λ) and lapse rate ε, the choice model (:mod:`.choice`) gives

    P(c_it = k) = (1 - ε) q_M,v(k | S_i, E_t) + ε / K,

so the log-likelihood of the answers is ℓ_i(v, ε) = Σ_t log P(c_it).  Everything below works on q, the
(G, S, T, K) table of choice probabilities without lapse for every value v of a grid of G, every
distinct training sequence s and every test: participants who saw the same examples share it, so the
cost of a fit grows with the grid and the conditions, not with the participants.

* **pooled fit**: the joint maximum of Σ_i ℓ_i over (v, ε) (:mod:`.fitsearch`).  ℓ is concave in ε, so
  every v gets its exact best ε; λ is then searched continuously on that profile from the grid's best, and
  a deterministic model's τ step by step (its ℓ changes only where τ reaches a distance); ``aic`` = 2k - 2ℓ,
  ``bic`` = k ln n - 2ℓ (k: 2 with a hyperparameter that changes the model, else 1; n: answered tests).
* **per participant**: the grid maximum of each ℓ_i (their own τ / λ and ε, ε in steps of 1/200).
* **leave-one-participant-out**: Σ_i ℓ_i at the pooled grid fit of everyone else.  Each participant's
  held-out ℓ_i is also their log evidence for the random-effects model selection (:mod:`.bms`):
  a predictive evidence that charges a model for its flexibility by cross-validation.  Both usual
  alternatives failed the recovery bench with six answers per participant: the BIC approximation at a
  participant's own best τ (ℓ_i - ln 6) let the flexible det-reward win simulated prob-reward studies,
  and the likelihood averaged over a log-uniform prior on τ / λ (1e-5 .. 1e5) let the models without a
  hyperparameter win every study.

A deterministic model's ℓ is a step function of τ: every τ of the best step fits equally, and the fit
reports the middle (geometric) of that step.  Models whose choice probabilities are equal
at every grid value (the deterministic and probabilistic strategy learners: d_strategy is 0 or ∞) are
one model here, reported once under both names.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from . import fitsearch as search
from .answers import Answers, FitError
from .bms import BMSResult, random_effects_bms
from .choice import OptionDistances, log_choice_probabilities
from .learners import (
    Deterministic,
    Distances,
    LearnerModel,
    has_hyperparameter,
    log_posterior,
    make_model,
    model_names,
)

VALUE_GRID = tuple(10.0 ** (k / 4) for k in range(-20, 21))  # τ, λ ∈ 1e-5 .. 1e5, four per decade
# Models whose held-out log-likelihoods agree this closely rank equal: models that predict the same for
# every answer given (exact IRL and the approximate ones at their fitted τ / λ) differ only by rounding there.
TIE_TOLERANCE = 1e-6
EPS_GRID = np.linspace(0.0, 1.0, 201)


@dataclass
class ModelFit:
    """One model's fit (see the module's docstring); ``same_as``: models with identical predictions."""

    name: str
    param: str | None
    value: float | None
    lapse: float
    log_lik: float
    n_params: int
    n_answers: int
    cv_log_lik: float
    per_participant_log_lik: np.ndarray  # (P,) ℓ_i at the participant's own grid fit
    per_participant_value: np.ndarray  # (P,) (NaN without a hyperparameter)
    per_participant_lapse: np.ndarray  # (P,)
    log_evidence: np.ndarray  # (P,) ℓ_i at the fit of everyone else (-inf: ruled out)
    predicted: np.ndarray  # (S, T, K) P(option) at the pooled fit, lapse included
    rating_rho: float | None = None  # Spearman ρ of predicted probability and rating
    same_as: list[str] = field(default_factory=list)
    grid_q: np.ndarray | None = field(default=None, repr=False)  # (G, S, T, K): what pooling identical models compares

    @property
    def aic(self) -> float:
        return 2 * self.n_params - 2 * self.log_lik

    @property
    def bic(self) -> float:
        return self.n_params * np.log(self.n_answers) - 2 * self.log_lik

    @property
    def label(self) -> str:
        return " = ".join([self.name] + self.same_as)


def option_distances(table, tests) -> list[OptionDistances]:
    """One OptionDistances per test (its distances are computed once and reused for every v)."""
    return [OptionDistances(table, t.env_index, t.options) for t in tests]


def choice_table(model: LearnerModel, dist: Distances, options: list[OptionDistances], sequences) -> np.ndarray:
    """(S, T, K) float64 q(k | S_s, E_t): the choice model's probabilities without lapse."""
    log_liks = np.stack([model.log_likelihood(o) for o in options])  # (T, K, N)
    out = np.empty((len(sequences),) + log_liks.shape[:2])  # no sequences (a study of closed loops alone): (0, T, K)
    for s, seq in enumerate(sequences):
        out[s] = log_choice_probabilities(log_posterior(model, dist, list(seq)), log_liks, 0.0)
    return out


def model_grid(model: LearnerModel, grid=VALUE_GRID) -> list[LearnerModel]:
    """The model at every value of `grid`, or just itself when τ / λ change nothing."""
    return [model.with_value(v) for v in grid] if has_hyperparameter(model) else [model]


def _answer_log_lik(q: np.ndarray, answers: Answers, eps: np.ndarray) -> np.ndarray:
    """q (G, S, T, K), eps (E,) -> (G, E, P) ℓ_i on the grid (a test not answered adds 0)."""
    k = q.shape[-1]
    out = np.zeros((q.shape[0], len(eps), answers.n_participants))
    for t in range(q.shape[2]):
        done = answers.choice[:, t] >= 0
        if not done.any():
            continue
        # The logarithm is taken once per distinct (sequence, chosen option): at most S·K of them, where the
        # participants number hundreds; each participant then adds their pair's term.
        pairs, pair_of = np.unique(answers.group[done] * k + answers.choice[done, t], return_inverse=True)
        p = q[:, pairs // k, t, pairs % k]  # (G, U)
        with np.errstate(divide="ignore"):
            term = np.log((1 - eps)[None, :, None] * p[:, None, :] + (eps / k)[None, :, None])  # (G, E, U)
        if done.all():
            out += term[:, :, pair_of.ravel()]
        else:
            out[:, :, done] += term[:, :, pair_of.ravel()]
    return out


def _leave_one_out(ll: np.ndarray) -> np.ndarray:
    """(G, E, P) Σ_{j≠i} ℓ_j: the total less participant i's (-inf only when another one's is; at ε = 0
    an answer the model rules out is -inf, and -inf - -inf would be NaN)."""
    bad = ~np.isfinite(ll)
    finite = np.where(bad, 0.0, ll)
    others_bad = bad.sum(-1, keepdims=True) - bad
    return np.where(others_bad > 0, -np.inf, finite.sum(-1, keepdims=True) - finite)


def fit_model(name: str, table, answers: Answers, *, dist: Distances | None = None, options=None,
              grid=VALUE_GRID) -> ModelFit:
    """Fit learner model `name` to `answers` (the module's docstring says how)."""
    dist = dist or Distances(table)
    options = options or option_distances(table, answers.tests)
    base = make_model(name)
    models = model_grid(base, grid)
    tunable = len(models) > 1
    values = np.array([m.value for m in models]) if tunable else None
    q = np.stack([choice_table(m, dist, options, answers.sequences) for m in models])  # (G, S, T, K)
    ll = _answer_log_lik(q, answers, EPS_GRID)  # (G, E, P)
    n_i = (answers.choice >= 0).sum(1)
    k = 2 if tunable else 1
    # per participant: each one's own grid maximum
    flat = ll.reshape(-1, ll.shape[-1])
    best_i = np.argmax(flat, axis=0)
    own_ll = flat[best_i, np.arange(flat.shape[1])]
    gi, ei = np.unravel_index(best_i, ll.shape[:2])
    # leave one participant out: the grid fit of the others, scored on the one left out
    rest = _leave_one_out(ll)
    loo = np.argmax(rest.reshape(-1, rest.shape[-1]), axis=0)
    held_out = flat[loo, np.arange(flat.shape[1])]  # (P,) ℓ_i at the others' fit
    cv = float(held_out.sum())

    def q_of(v):
        return choice_table(base.with_value(v) if tunable else base, dist, options, answers.sequences)

    # pooled: the joint maximum over (τ / λ, ε), ε exact for every τ / λ (docs/decisions.md, "Fitting")
    classes, kk = search.answer_classes(answers), answers.n_options
    value = None
    if tunable and isinstance(base, Deterministic):
        steps = search.step_counts(base, dist, options, answers.sequences)
        value = search.step_value(*search.step_maximum(steps, classes, kk, (values.min(), values.max())))
    elif tunable:
        value = search.smooth_maximum(lambda v: float(search.profile(q_of(v)[None], classes, kk)[1][0]), values,
                                      search.profile(q, classes, kk)[1])
    predicted_q = q_of(value)
    lapse, log_lik = (float(x[0]) for x in search.profile(predicted_q[None], classes, kk))
    fit = ModelFit(name=name, param=base.param if tunable else None, value=value, lapse=lapse, log_lik=log_lik,
                   n_params=k, n_answers=int(n_i.sum()), cv_log_lik=cv, per_participant_log_lik=own_ll,
                   per_participant_value=values[gi] if tunable else np.full(len(n_i), np.nan),
                   per_participant_lapse=EPS_GRID[ei], log_evidence=held_out,
                   predicted=(1 - lapse) * predicted_q + lapse / kk, grid_q=q)
    fit.rating_rho = rating_correlation(fit.predicted, answers)
    return fit


def rating_correlation(predicted: np.ndarray, answers: Answers) -> float | None:
    """Spearman ρ over every rated option of every answered test: the model's P(option) against the
    participant's 1-7 rating of it (the ratings' link, docs/analysis.md); None without ratings."""
    if answers.ratings is None:
        return None
    p = predicted[answers.group]  # (P, T, K)
    ok = np.isfinite(answers.ratings) & (answers.choice >= 0)[:, :, None]
    if ok.sum() < 3 or np.ptp(p[ok]) == 0 or np.ptp(answers.ratings[ok]) == 0:
        return None
    from scipy.stats import spearmanr  # noqa: PLC0415 (scipy.stats: ~0.5 s at every worker's boot)

    return float(spearmanr(p[ok], answers.ratings[ok]).statistic)


def _pool_identical(fits: list[ModelFit]) -> list[ModelFit]:
    """Keep one fit of each group of models whose q tables are equal at every grid value."""
    kept: list[ModelFit] = []
    for f in fits:
        twin = next((k for k in kept if k.grid_q.shape == f.grid_q.shape
                     and np.allclose(k.grid_q, f.grid_q, rtol=0, atol=1e-12)), None)
        if twin is None:
            kept.append(f)
        else:
            twin.same_as.append(f.name)
    return kept


def fit_models(table, answers: Answers, names=None, *, grid=VALUE_GRID, progress=None,
               dist: Distances | None = None) -> list[ModelFit]:
    """Every model in `names` (default: every registered one) fitted to `answers`, identical models
    pooled, best first by cross-validated log-likelihood (models within TIE_TOLERANCE of each other in the
    registry's order: their order says nothing; :meth:`Comparison.rows` ranks them equal).  FitError (one
    line) when the answers cannot be fitted or when no model explains them better than guessing (every answer
    a lapse)."""
    answers.check()
    dist = dist or Distances(table)
    options = option_distances(table, answers.tests)
    fits = []
    for name in names or model_names():
        fits.append(fit_model(name, table, answers, dist=dist, options=options, grid=grid))
        if progress:
            progress(name)
    fits = _pool_identical(fits)
    if not any(beats_guessing(f, answers.n_options, len(fits)) for f in fits):
        raise FitError("no model explains these answers better than guessing (likelihood-ratio test against a "
                       "uniform guess, p >= 0.05 after Bonferroni): the answers look like lapses")
    return sorted(fits, key=lambda f: -f.cv_log_lik)


def tie_ranks(scores, tol: float = TIE_TOLERANCE) -> tuple[list[int], list[list[int]]]:
    """(M,) scores, higher better -> (M,) each one's rank (1 + how many score more than `tol` higher: tied
    ones share a rank, the next one skips) and, for each, the indices of the others within `tol` of it."""
    scores = np.asarray(scores, np.float64)
    ranks = [1 + int((scores > x + tol).sum()) for x in scores]
    tied = [[j for j in range(len(scores)) if j != i and abs(scores[j] - scores[i]) <= tol]
            for i in range(len(scores))]
    return ranks, tied


def beats_guessing(fit: ModelFit, n_options: int, n_models: int = 1, alpha: float = 0.05) -> bool:
    """Whether `fit` explains its answers better than a uniform guess over `n_options`: the likelihood-ratio
    statistic 2(ℓ - ℓ_guess) against χ² with the fit's free parameters, at `alpha` / `n_models`."""
    stat = 2 * (fit.log_lik - fit.n_answers * -np.log(n_options))
    from scipy.stats import chi2  # noqa: PLC0415 (as above)

    return bool(chi2.sf(max(stat, 0.0), fit.n_params) < alpha / n_models)


@dataclass
class Comparison:
    """Every model's fit, best first by cross-validated log-likelihood, and the random-effects model
    selection over them (``bms``: its arrays follow ``fits``' order; None for a single model)."""

    fits: list[ModelFit]
    bms: BMSResult | None
    n_participants: int

    def rows(self) -> list[dict]:
        """One row per model (identical ones pooled), for tables and CSV.  ``rank``: by cross-validated
        log-likelihood, equal for models within TIE_TOLERANCE of each other (:func:`tie_ranks`);
        ``tied_with``: those models' labels; ``tie_exceedance``: the exceedance probability of the model and
        the ones it ties with together (the chance that the most common model is one of them: the random-effects
        selection splits it among models whose evidence is the same, so one of them alone says little)."""
        best_bic = min(f.bic for f in self.fits)
        nan = np.full(len(self.fits), np.nan)
        freq, ep, pep = ((self.bms.frequency, self.bms.exceedance, self.bms.protected_exceedance) if self.bms
                         else (nan, nan, nan))
        ranks, tied = tie_ranks([f.cv_log_lik for f in self.fits])
        return [{"model": f.label, "param": f.param or "", "value": f.value, "lapse": f.lapse,
                 "log_lik": f.log_lik, "cv_log_lik": f.cv_log_lik, "aic": f.aic, "bic": f.bic,
                 "delta_bic": f.bic - best_bic, "frequency": float(freq[i]), "exceedance": float(ep[i]),
                 "protected_exceedance": float(pep[i]),
                 "rating_rho": f.rating_rho, "n_answers": f.n_answers, "rank": ranks[i],
                 "tied_with": [self.fits[j].label for j in tied[i]],
                 "tie_exceedance": float(ep[i] + sum(ep[j] for j in tied[i]))}
                for i, f in enumerate(self.fits)]


def compare_models(table, answers: Answers, names=None, **kwargs) -> Comparison:
    """:func:`fit_models`, then random-effects model selection on the participants' log evidence
    (only participants who answered a test count)."""
    fits = fit_models(table, answers, names, **kwargs)
    answered = (answers.choice >= 0).any(1)
    log_ev = np.stack([f.log_evidence[answered] for f in fits])
    bms = random_effects_bms(log_ev) if len(fits) > 1 else None
    return Comparison(fits=fits, bms=bms, n_participants=int(answered.sum()))
