"""What a study collected, as a learner model's fit reads it: its tests (:class:`Question`) and every
participant's answers to them (:class:`Answers`), and the refusal of answers that cannot be fitted
(:class:`FitError`).  teaching.core.fitting fits the models to them; teaching.core.fitsearch runs its search.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Answers", "FitError", "Question", "questions_of"]


class FitError(ValueError):
    """Answers that cannot be fitted: the message says why, in one line."""


@dataclass(frozen=True)
class Question:
    """One test: its environment (a table row) and the θ indices whose optimal trajectories are its
    options, in the order choices are stored.  `shown`: the participant shows the way instead of
    choosing; the options are then every distinct trajectory the table's θ take there, and answer
    len(options) is a way none of them takes."""

    env_index: int
    options: tuple[int, ...]
    shown: bool = False


def questions_of(table, test_set) -> tuple[tuple[Question, ...], np.ndarray]:
    """A study's tests as the fit reads them: (Questions, (T,) int64 the position of θ*'s option in each).
    test_set: dicts as ``select_test_set`` gives them or a study stores them (env_id; options with
    theta_index and is_theta_star).  KeyError names an env_id that is not in `table`."""
    questions = tuple(Question(table.row_of[int(t["env_id"])], tuple(int(o["theta_index"]) for o in t["options"]))
                      for t in test_set)
    star = np.array([next(k for k, o in enumerate(t["options"]) if o["is_theta_star"]) for t in test_set], np.int64)
    return questions, star


@dataclass(frozen=True)
class Answers:
    """What a study collected, as the fit reads it.

    sequences: name -> table rows shown (a condition's training examples); tests: the test set;
    group: (P,) index into ``sequence_names`` of each participant's sequence; choice: (P, T) int,
    the chosen option's index into the test's ``options`` (-1: not answered); ratings: (P, T, K)
    float 1-7 (NaN: not answered), or None.
    """

    sequence_names: tuple[str, ...]
    sequences: tuple[tuple[int, ...], ...]
    tests: tuple[Question, ...]
    group: np.ndarray
    choice: np.ndarray
    ratings: np.ndarray | None = None
    participant_ids: tuple[str, ...] = ()

    @property
    def n_participants(self) -> int:
        return len(self.group)

    @property
    def n_options(self) -> int:
        return len(self.tests[0].options)

    def check(self) -> None:
        """FitError unless these answers can be fitted (the messages a researcher sees)."""
        if not self.tests:
            raise FitError("the study has no test set: there is nothing to fit")
        if len({len(t.options) for t in self.tests}) != 1:
            raise FitError("every test must offer the same number of options")
        answered = self.choice >= 0
        if self.n_participants == 0 or not answered.any():
            raise FitError("no participant answered a test yet: nothing to fit")
        used = np.unique(self.group[answered.any(1)])
        if len({self.sequences[g] for g in used}) < 2:
            raise FitError("every participant who answered saw the same training examples (one condition): "
                           "the models' predictions then differ too little to compare; fit a study of two or more "
                           "conditions")
