"""Simulated participants for a study, through the real assignment and flow (for tests, demos and pilots).

Each simulated participant arrives through :func:`studyapp.participant.assignment.assign` and answers every
step with :func:`studyapp.participant.flow.record`, so scores, exclusions and completion are exactly the app's.
Two kinds of participant answer the tests:

* **learners** (``learner=SimulatedLearner(model, τ or λ, lapse)``): they learn from their condition's
  training examples by that learner model and pick each test's option by the choice model, rating each
  option 1 + Binomial(6, P(option)) (teaching.core.simulate; docs/analysis.md).  In a closed-loop condition
  they learn from what the loop showed them (examples and feedback) and answer its check questions the same
  way, so the loop's next steps follow from their answers as from a person's;
* **fixed-probability bots** (no learner, for tests of the flow and the statistics): they pick θ*'s option
  with probability ``p_correct[condition]`` (default ``base``) and rate the chosen option 5-7 (others 1-3).

Participants who fail the attention check answer carelessly: a learner guesses uniformly, a bot answers
the opposite way (probability ``1 - p``), so an analysis that forgot the exclusions would see the effect
shrink.
"""
from __future__ import annotations

import numpy as np
from django.http import QueryDict

from teaching.api import AnswerModel, SimulatedLearner, draw_answers

from ..models import LoopStep, StepKind
from ..participant import assignment, closedloop, flow
from ..participant.pages import page_for
from .modelfit import study_design

EFFECT = {"coverage-approx*": 0.95, "det-euclid": 0.95, "det-euclidean": 0.95}
BASE = 0.35


def post(**fields) -> QueryDict:
    q = QueryDict(mutable=True)
    for k, v in fields.items():
        q.setlist(k, [str(x) for x in v] if isinstance(v, list) else [str(v)])
    return q


class StudyLearner:
    """What learner participants of one study answer: their model's P(option) per condition (cached)."""

    def __init__(self, study, learner: SimulatedLearner):
        self.design = study_design(study)
        self.attentive = AnswerModel(self.design.table, learner, self.design.tests)
        self.careless = AnswerModel(self.design.table, SimulatedLearner(learner.model, learner.value, 1.0),
                                    self.design.tests, self.attentive.dist)

    def answers(self, condition: str, attentive: bool, rng, shown=None) -> tuple[np.ndarray, np.ndarray]:
        """((T,) chosen option indices, (T, K) ratings) of one participant of `condition` (who saw table rows
        `shown`, in a closed loop)."""
        model = self.attentive if attentive else self.careless
        return model.answer(self.design.sequences[condition] if shown is None else shown, rng)

    def shown(self, participant) -> tuple[int, ...]:
        """The table rows a closed loop has shown `participant` so far (examples and feedback, in order)."""
        pack = closedloop.pack_of_data(participant.condition.closed_loop)
        return tuple(pack.row_of(s.env_id) for s in participant.loop_steps.all()
                     if s.kind in (LoopStep.EXAMPLE, LoopStep.FEEDBACK) and s.index < participant.position)

    def check_answer(self, participant, index: int, attentive: bool, rng) -> tuple[int, list[int]]:
        """(option index, ratings) of `participant`'s answer to the check question at loop step `index`,
        by the choice model after what the loop has shown them."""
        model = self.attentive if attentive else self.careless
        question = closedloop.pack_of_data(participant.condition.closed_loop).loop.checks[
            participant.loop_steps.get(index=index).question]
        choice, ratings = draw_answers(model.question(self.shown(participant), question)[None], rng)
        return int(choice[0]), [int(r) for r in ratings[0]]


def _bot_answer(options, rng, p_star: float) -> tuple[int, list[int]]:
    star = [k for k, o in enumerate(options) if o["is_theta_star"]][0]
    others = [k for k in range(len(options)) if k != star]
    choice = star if rng.random() < p_star else int(rng.choice(others))
    ratings = [int(rng.integers(1, 4)) for _ in options]
    ratings[choice] = int(rng.integers(5, 8))
    return choice, ratings


class Simulated:
    """One simulated participant's state as the pages ask it (studyapp.participant.pages: each page's ``simulate``):
    the random generator, whether they pay attention, and how they choose a question's option."""

    def __init__(self, participant, rng, attentive: bool, p_star: float, learner: StudyLearner | None):
        self.rng, self.attentive, self.p_star, self.learner = rng, attentive, p_star, learner
        loop = bool(participant.condition.closed_loop)
        self.learned = learner.answers(participant.condition.name, attentive, rng) if learner and not loop else None

    def choose(self, participant, step, options) -> tuple[int, list[int]]:
        """(option index, ratings) of the answer to a test or check question with these options."""
        if self.learner and step.kind == StepKind.CHECK:
            return self.learner.check_answer(participant, step.item, self.attentive, self.rng)
        if self.learner:
            if self.learned is None:  # a closed loop: what it showed is known once the tests begin
                self.learned = self.learner.answers(participant.condition.name, self.attentive, self.rng,
                                                    shown=self.learner.shown(participant))
            return int(self.learned[0][step.item]), [int(r) for r in self.learned[1][step.item]]
        return _bot_answer(options, self.rng, self.p_star)


def run_participant(study, rng, attentive: bool = True, effect: dict | None = None, base: float = BASE,
                    learner: StudyLearner | None = None):
    """One simulated participant from arrival to completion; returns it.  With `learner`, its tests are
    answered by the learner model, else by a fixed-probability bot (the module's docstring).  A show study's
    tests ask for a way, not a choice among options, which these participants cannot give: a ValueError."""
    if study.test_kind == study.SHOW:
        raise ValueError(f"study {study.slug!r} is a show study: simulated participants choose among options, "
                         "and its tests ask for a way")
    p = assignment.assign(study)
    p_star = (EFFECT if effect is None else effect).get(p.condition.name, base)
    sim = Simulated(p, rng, attentive, p_star if attentive else 1 - p_star, learner)
    while True:  # step by step: a closed-loop condition decides its next step once the last is answered
        step = flow.current_step(p)
        fields = page_for(study, step.kind).simulate(sim, p, step)
        if fields is None:
            return p
        p = flow.record(p, step.index, post(**fields))


def simulate(study, n_per_condition: int = 9, seed: int = 1, fail_every: int = 7, effect: dict | None = None,
             learner: SimulatedLearner | None = None):
    """n_per_condition x (number of conditions) participants; every ``fail_every``-th fails the
    attention check.  With `learner` they learn by that model (else fixed-probability bots, `effect`).
    Returns the random generator (to simulate more later)."""
    rng = np.random.default_rng(seed)
    n_cond = study.conditions.count()
    answering = StudyLearner(study, learner) if learner else None
    for i in range(n_per_condition * n_cond):
        run_participant(study, rng, attentive=(i % fail_every != 3), effect=effect, learner=answering)
    return rng
