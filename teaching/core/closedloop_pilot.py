"""A closed-loop condition in a study's simulated pilot.

An open-loop condition shows every participant one sequence, so the pilot's ideal users each see it once
(evaluation.study_matrix).  A closed loop shows what the answers call for, so the pilot runs simulated
participants of each user model through it (closedloop.run_learner: they learn by that model and answer
each check by the choice model with lapse rate ε) and averages over them what the open-loop pilot
computes for one sequence: P_user(θ*) after everything they were shown (examples and feedback), and the
choice model's P(option) in each final test with no lapse (so the page can apply any lapse rate,
simulate.predicted_scores).  Deterministic models often send every participant down one path; the
average is then over one sequence, as it should be.
"""
from __future__ import annotations

from collections import Counter

import numpy as np

from .answers import questions_of
from .closedloop import CHECK, ClosedLoop, run_learner
from .fitting import choice_table, option_distances
from .learners import Distances, LearnerModel, p_theta_star
from .simulate import SimulatedLearner

PILOT_PARTICIPANTS = 40  # per user model: P(θ*) to about ±0.05 where paths differ
PILOT_LAPSE = 0.1  # ε of the simulated participants' check answers (the pilot page's default lapse rate)


def shown_sequences(loop: ClosedLoop, table, model: LearnerModel, n: int, lapse: float, seed: int,
                    dist: Distances) -> list[tuple[int, ...]]:
    """The table rows (examples and feedback, in order) each of `n` simulated participants of `model` saw."""
    rng = np.random.default_rng(seed)
    learner = SimulatedLearner(model.name, model.value if model.param else None, lapse)
    out = []
    for _ in range(n):
        events, _decisions = run_learner(loop, table, learner, rng, dist)
        out.append(tuple(int(e.env_index) for e in events if e.kind != CHECK))
    return out


def loop_pilot(loop: ClosedLoop, table, models: dict[str, LearnerModel], test_set=None,
               n: int = PILOT_PARTICIPANTS, lapse: float = PILOT_LAPSE, seed: int = 0,
               dist: Distances | None = None) -> dict:
    """The pilot's row of one closed-loop condition: {"p": {user: mean P_user(θ*)}, "choice": {user: (T, K)
    mean P(option) with no lapse, as a list} (with a test set), "participants": n, "lapse": lapse}.

    models: {user label: model with its τ / λ} (the pilot's users); test_set: the study's final tests as
    select_test_set gives them."""
    dist = dist or Distances(table)
    questions = questions_of(table, test_set)[0] if test_set else ()
    options = option_distances(table, questions) if questions else []
    p, choice = {}, {}
    for u, (label, model) in enumerate(models.items()):
        paths = Counter(shown_sequences(loop, table, model, n, lapse, seed + u, dist))
        seqs = list(paths)  # each path once, weighted by how many participants took it
        weights = np.array([paths[s] for s in seqs], np.float64) / n
        p[label] = float(sum(w * p_theta_star(model, dist, list(s)) for w, s in zip(weights, seqs, strict=True)))
        if options:
            q = choice_table(model, dist, options, seqs)  # (S, T, K)
            choice[label] = np.round(np.tensordot(weights, q, axes=1), 6).tolist()
    out = {"p": p, "participants": n, "lapse": lapse}
    if options:
        out["choice"] = choice
    return out
