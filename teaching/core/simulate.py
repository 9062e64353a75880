"""Simulated participants who learn by a model (docs/analysis.md).

A simulated participant of learner model M (with τ / λ and lapse rate ε) watches its condition's
training examples, so it believes P_M(θ | S); in each test it picks option k with the choice model's
probability P(k | S, E) (:mod:`.choice`) and rates each option 1 + Binomial(6, P(k)): options it finds
likelier get higher ratings, with the noise of a 7-point scale.  The web side runs such participants
through the real assignment and flow (studyapp/analysis/simulate.py); :func:`simulate_answers` draws
them directly, for model recovery (:mod:`.recovery`) and benchmarks.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from .answers import Answers, questions_of
from .choice import OptionDistances, log_choice_probabilities
from .fitting import choice_table, option_distances
from .learners import Distances, LearnerModel, check_value, log_posterior, make_model

RATING_STEPS = 6  # a rating is 1 + Binomial(6, P(option)): 1 .. 7


@dataclass(frozen=True)
class SimulatedLearner:
    """Who a simulated participant is: a learner model, its τ / λ (None: the model's default or none) and
    its lapse rate ε in [0, 1] (the chance of a uniform guess in each test)."""

    model: str
    value: float | None = None
    lapse: float = 0.1

    def __post_init__(self):
        make_model(self.model, self.value)  # a ValueError naming a bad model or value
        if not 0 <= float(self.lapse) <= 1:
            raise ValueError(f"the lapse rate must lie in [0, 1], got {self.lapse}")
        if self.value is not None:
            check_value(self.model, self.value)

    @property
    def learner_model(self) -> LearnerModel:
        return make_model(self.model, self.value)

    def __str__(self) -> str:
        return f"{self.learner_model} with lapse rate {self.lapse:g}"


class AnswerModel:
    """P(option) of every test for a learner who saw a given sequence, cached per sequence: what a
    simulated participant draws its answers from.  table: a trajectory table; tests: TestItems."""

    def __init__(self, table, learner: SimulatedLearner, tests, dist: Distances | None = None):
        self.table, self.learner, self.tests = table, learner, tuple(tests)
        self.dist = dist or Distances(table)
        model = learner.learner_model
        self._log_liks = np.stack([model.log_likelihood(OptionDistances(table, t.env_index, t.options))
                                   for t in self.tests])  # (T, K, N)
        self.probabilities = lru_cache(maxsize=None)(self._probabilities)

    def _probabilities(self, sequence: tuple[int, ...]) -> np.ndarray:
        """(T, K) P(option k of test t) for a learner shown table rows `sequence`."""
        belief = log_posterior(self.learner.learner_model, self.dist, list(sequence))
        return log_choice_probabilities(belief, self._log_liks, self.learner.lapse)

    def answer(self, sequence: tuple[int, ...], rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
        """One participant's answers: ((T,) chosen option, (T, K) ratings 1-7)."""
        return draw_answers(self.probabilities(tuple(int(s) for s in sequence)), rng)

    def question(self, sequence, question) -> np.ndarray:
        """(K,) P(option) of one more question (a Question, e.g. a closed loop's check) for a learner shown
        table rows `sequence`."""
        model = self.learner.learner_model
        belief = log_posterior(model, self.dist, [int(s) for s in sequence])
        log_lik = model.log_likelihood(OptionDistances(self.table, question.env_index, question.options))
        return log_choice_probabilities(belief, log_lik, self.learner.lapse)


def draw_answers(p: np.ndarray, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Answers drawn from (T, K) P(option): ((T,) the chosen option, (T, K) ratings 1 + Binomial(6, P)).

    Each test's option is drawn as ``rng.choice(K, p=row / row.sum())`` draws it (one uniform from `rng`, test
    by test, against the row's normalised cumulative sum), all tests at once: the same answers from the same
    generator, without that call's fixed cost for every test of every simulated participant."""
    p = np.asarray(p, np.float64)
    norm = p / p.sum(-1, keepdims=True)
    if not (norm >= 0).all():  # NaN too; rng.choice's own refusals, in its words
        raise ValueError("Probabilities contain NaN" if np.isnan(norm).any() else "Probabilities are not non-negative")
    if (np.abs(norm.sum(-1) - 1.0) > np.sqrt(np.finfo(np.float64).eps)).any():
        raise ValueError("Probabilities do not sum to 1")
    cdf = norm.cumsum(-1)
    cdf /= cdf[:, -1:]
    choice = (cdf <= rng.random(len(p))[:, None]).sum(-1)  # searchsorted(cdf, u, side="right")
    ratings = 1 + rng.binomial(RATING_STEPS, np.clip(p, 0, 1))
    return choice, ratings.astype(np.float64)


def simulate_answers(table, learner: SimulatedLearner, sequences: dict[str, list[int]], tests,
                     n_participants: int, rng: np.random.Generator, dist: Distances | None = None) -> Answers:
    """`n_participants` simulated participants of `learner`, assigned to the named sequences (table rows) in
    turn as a balanced study assigns them (the first ones get one more where they do not divide), each
    answering every test of `tests` (Questions)."""
    tests = tuple(tests)
    model = AnswerModel(table, learner, tests, dist)
    names = tuple(sequences)
    group = np.arange(n_participants) % len(names)
    drawn = [model.answer(tuple(sequences[names[g]]), rng) for g in group]
    k = len(tests[0].options)
    return Answers(sequence_names=names, sequences=tuple(tuple(int(e) for e in sequences[n]) for n in names),
                   tests=tests, group=group,
                   choice=np.array([c for c, _ in drawn], np.int64).reshape(n_participants, len(tests)),
                   ratings=np.array([r for _, r in drawn]).reshape(n_participants, len(tests), k),
                   participant_ids=tuple(f"sim-{i}" for i in range(n_participants)))


# --- what such participants score, in expectation (the designer's pilot and power table) ----------------
@dataclass(frozen=True)
class PredictedScores:
    """What participants of one learner model who saw one sequence score on a test set, by the answer model
    above: accuracy, the expected share of tests in which they pick θ*'s option; mean, the expected mean
    confidence score (−7 .. 7: the chosen option's rating, negated unless it is θ*'s; the paper's measure);
    sd, that mean's standard deviation across participants (tests are drawn independently)."""

    accuracy: float
    mean: float
    sd: float


def model_choices(table, models: dict[str, LearnerModel], sequences: dict[str, list[int]], tests,
                  dist: Distances | None = None) -> dict[str, dict[str, np.ndarray]]:
    """{model label: {sequence name: (T, K) P(option) with no lapse}} for learners of each model (with its
    τ / λ) shown each sequence (table rows), on `tests` (Questions): the fit's choice table.  With no lapse
    these are all a pilot needs to predict scores at any lapse rate (:func:`predicted_scores`)."""
    dist = dist or Distances(table)
    options = option_distances(table, tests)
    names = list(sequences)
    return {label: dict(zip(names, choice_table(model, dist, options, [sequences[n] for n in names]), strict=True))
            for label, model in models.items()}


def predicted_scores(choice: np.ndarray, star: np.ndarray, lapse: float) -> PredictedScores:
    """Expected accuracy and confidence score of the participants :meth:`AnswerModel.answer` draws.

    choice: (T, K) P(option) with no lapse; star: (T,) the position of θ*'s option in each test; lapse: ε in
    [0, 1].  With lapse, P = (1 − ε) P₀ + ε / K (the choice model's mixture).  The chosen option k's rating
    is 1 + Binomial(6, P_k), drawn apart from the choice, so a test's score s = ±r has
    E[s] = Σ_k P_k σ_k (1 + 6 P_k) and E[s²] = Σ_k P_k (6 P_k (1 − P_k) + (1 + 6 P_k)²), σ_k = +1 for θ*'s
    option and −1 for the others; the mean over T independent tests has variance Σ_t Var(s_t) / T²."""
    if not 0 <= lapse <= 1:
        raise ValueError(f"the lapse rate must lie in [0, 1], got {lapse}")
    p0 = np.asarray(choice, np.float64)
    t, k = p0.shape
    p = (1.0 - lapse) * p0 + lapse / k
    sign = np.full((t, k), -1.0)
    sign[np.arange(t), np.asarray(star, np.int64)] = 1.0
    rating = 1.0 + RATING_STEPS * p
    first = (p * sign * rating).sum(axis=1)
    second = (p * (RATING_STEPS * p * (1.0 - p) + rating ** 2)).sum(axis=1)
    return PredictedScores(accuracy=float(p[np.arange(t), star].mean()), mean=float(first.mean()),
                           sd=float(np.sqrt(max(float((second - first ** 2).sum()), 0.0)) / t))


def pilot_predictions(table, models: dict[str, LearnerModel], sequences: dict[str, list[int]], test_set,
                      dist: Distances | None = None) -> dict:
    """A study's model-based pilot as small JSON: what learners of each model choose in each test after each
    sequence, with no lapse, so that scores at any lapse rate follow from it alone (:func:`predicted_scores`).

    models: {user label: model with its τ / λ}; sequences: {condition: table rows shown}; test_set: the study's
    tests as ``select_test_set`` gives them (env_id; options with theta_index and is_theta_star).  Returns
    {"theta_star_option": [T] the position of θ*'s option per test, "choice": {label: {condition: (T, K)}}}."""
    questions, star = questions_of(table, test_set)
    choice = model_choices(table, models, sequences, questions, dist)
    return {"theta_star_option": star.tolist(),
            "choice": {label: {name: np.round(p, 6).tolist() for name, p in by_name.items()}
                       for label, by_name in choice.items()}}
