"""Model and parameter recovery before real data (docs/analysis.md).

For a study's design (its conditions' sequences and its test set), simulate many studies whose
participants all learn by one model (:mod:`.simulate`), fit every model to each (:mod:`.fitting`) and
count which model wins: the *confusion matrix* says which models this design can tell apart.  A study
whose best models tie (cross-validated log-likelihoods within ``TIE_TOLERANCE``: they predict the same for
every answer given) is won by none of them: it is counted apart, with the models that tied.  The
generating model's own fit says whether its τ / λ and lapse rate come back (*parameter recovery*).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .answers import FitError
from .fitting import fit_models, tie_ranks
from .learners import Distances, model_names
from .simulate import SimulatedLearner, simulate_answers

LAPSE_TOLERANCE = 0.05  # a recovered ε within this of the true one counts as recovered
VALUE_TOLERANCE = 1.0  # decades: a recovered τ / λ within this of the true one counts as recovered


@dataclass
class Recovery:
    """generators: {label: SimulatedLearner}; fitted: the fitted models' labels (identical ones pooled);
    confusion: (G, F) int, how often each fitted model won outright (the highest cross-validated
    log-likelihood, no other within TIE_TOLERANCE of it) on a study simulated by each generator (a row may
    sum to less than ``reps``: studies no model explains better than guessing are counted in ``unfitted``,
    studies whose best models tie in ``ties``); ties: {generator: the labels tied at the top, one tuple per
    such study}; values, lapses: {generator: the generator's own fitted τ / λ and ε per simulated study}."""

    n_participants: int
    reps: int
    generators: dict[str, SimulatedLearner]
    fitted: list[str]
    confusion: np.ndarray
    unfitted: dict[str, int] = field(default_factory=dict)
    ties: dict[str, list[tuple[str, ...]]] = field(default_factory=dict)
    values: dict[str, list[float]] = field(default_factory=dict)
    lapses: dict[str, list[float]] = field(default_factory=dict)

    def column(self, generator: str) -> int:
        """The fitted column a generator's model is in (its pooled label may name others too)."""
        name = self.generators[generator].model
        return next(i for i, label in enumerate(self.fitted) if name in label.split(" = "))

    def recovered(self, generator: str) -> float:
        """Share of the generator's studies that its own model won."""
        return float(self.confusion[self.list_index(generator), self.column(generator)] / self.reps)

    def tied(self, generator: str) -> float:
        """Share of the generator's studies whose best models tied (none of them won)."""
        return len(self.ties.get(generator, ())) / self.reps

    def tied_own(self, generator: str) -> float:
        """Share of the generator's studies whose best models tied, its own model among them."""
        name = self.generators[generator].model
        return sum(any(name in label.split(" = ") for label in tie)
                   for tie in self.ties.get(generator, ())) / self.reps

    def list_index(self, generator: str) -> int:
        return list(self.generators).index(generator)

    def lapse_recovered(self, generator: str) -> float:
        """Share of the generator's studies whose fitted ε is within LAPSE_TOLERANCE of the true one."""
        err = np.abs(np.array(self.lapses[generator]) - self.generators[generator].lapse)
        return float((err <= LAPSE_TOLERANCE + 1e-12).mean()) if len(err) else float("nan")

    def value_recovered(self, generator: str) -> float | None:
        """Share whose fitted τ / λ is within VALUE_TOLERANCE decades of the true one (None: no τ / λ)."""
        vals = self.values.get(generator)
        if not vals:
            return None
        err = np.abs(np.log10(vals) - np.log10(self.generators[generator].value))
        return float((err <= VALUE_TOLERANCE + 1e-12).mean())

    def confused(self, threshold: float = 0.25) -> list[tuple[str, str, float]]:
        """(generator, fitted model, share) for every wrong winner of at least `threshold` of the
        generator's studies: what this design cannot tell apart."""
        out = []
        for g, gen in enumerate(self.generators):
            for f, label in enumerate(self.fitted):
                share = self.confusion[g, f] / self.reps
                if f != self.column(gen) and share >= threshold:
                    out.append((gen, label, float(share)))
        return out


def model_recovery(table, sequences: dict[str, list[int]], tests, generators: dict[str, SimulatedLearner],
                   n_participants: int, reps: int, seed: int = 0, names=None, progress=None) -> Recovery:
    """`reps` studies of `n_participants` per generator, each fitted with every model in `names`."""
    rng = np.random.default_rng(seed)
    dist = Distances(table)
    fitted: list[str] = []
    wins: list[list[str]] = []
    out = Recovery(n_participants, reps, dict(generators), fitted, np.zeros((0, 0), np.int64))
    for label, learner in generators.items():
        row = []
        out.values[label], out.lapses[label], out.unfitted[label], out.ties[label] = [], [], 0, []
        for _ in range(reps):
            answers = simulate_answers(table, learner, sequences, tests, n_participants, rng, dist)
            try:
                fits = fit_models(table, answers, names, dist=dist)
            except FitError:
                out.unfitted[label] += 1
                continue
            for f in fits:
                if f.label not in fitted:
                    fitted.append(f.label)
            _, tied = tie_ranks([f.cv_log_lik for f in fits])
            if tied[0]:
                out.ties[label].append(tuple(fits[i].label for i in [0, *tied[0]]))
            else:
                row.append(fits[0].label)
            own = next(f for f in fits if learner.model in f.label.split(" = "))
            out.lapses[label].append(own.lapse)
            if own.value is not None and learner.value is not None and own.param is not None:
                out.values[label].append(own.value)
            if progress:
                progress(label)
        wins.append(row)
    order = model_names()  # columns in the registry's order, whatever order the winners came in
    fitted.sort(key=lambda label: min(order.index(n) for n in label.split(" = ")))
    out.confusion = np.array([[row.count(f) for f in fitted] for row in wins], np.int64).reshape(len(wins),
                                                                                                 len(fitted))
    return out
