"""How long each condition of a study keeps a participant, estimated before anyone takes part.

A condition's estimate is the time its animations play plus fixed allowances for reading and answering:

    minutes = (PAGES_S + comprehension + n_examples · (EXAMPLE_S + its examples' animation seconds)
               + n_tests · (TEST_S[kind] + the tests' options' animation seconds)
               + n_checks · (TEST_S[kind] + FEEDBACK_S)) / 60

An animation lasts (rows - 1) · dt seconds, as the page's scene plays it (static/studyapp/scenes/*.js), a video
its own length; a choice test's four options are each watched once.  The allowances are round guesses for an attentive
participant (docs/decisions.md, "Estimated durations"): the estimate is for comparing conditions with one
another and with the minutes the consent page announces, not a measurement.  A closed-loop condition is
estimated at its most examples and check questions, each example as long as the study's other examples on
average (its own are chosen as it goes).
"""
from __future__ import annotations

from dataclasses import dataclass

from ..models import Study
from ..participant.closedloop import max_checks
from ..participant.comprehension import questions_of

PAGES_S = 60 + 90 + 20 + 30  # consent, instructions, the attention check, demographics
COMPREHENSION_QUESTION_S = 15
EXAMPLE_S = 8  # reading an example's caption and moving on, besides watching it
TEST_S = {Study.CHOOSE: 30, Study.SHOW: 45}  # rating four options / moving the robot, besides any animation
FEEDBACK_S = 10  # a closed loop's answer after a check


def animation_seconds(payload: dict) -> float:
    """Seconds a stored payload's robot plays: a path's (rows - 1) · dt, or a video's length."""
    shown = payload.get("robot") or ()
    if isinstance(shown, dict):  # a recording (teaching.api.stimulus_of)
        return float(shown.get("seconds") or 0.0)
    return max(len(shown) - 1, 0) * float(payload.get("dt") or 0)


@dataclass(frozen=True)
class Estimate:
    """One condition: its examples (the most, for a closed loop), check questions, seconds of animation
    watched, and the estimated minutes in all."""
    condition: str
    examples: int
    checks: int
    animation_seconds: float
    minutes: float
    closed_loop: bool = False


def _question_seconds(study: Study, question: dict) -> float:
    """A test or check question: answering it, and watching each of its options' animations once."""
    return TEST_S[study.test_kind] + sum(animation_seconds(o) for o in question.get("options", ()))


def estimates(study: Study) -> list[Estimate]:
    """Every condition's :class:`Estimate`, in the study's condition order."""
    n_questions = 0
    if study.comprehension_check:
        try:
            n_questions = len(questions_of(study))  # its own, else its robot's
        except (KeyError, ValueError):
            n_questions = 0  # a robot not registered here: the page says so, and the study cannot run
    fixed = PAGES_S + COMPREHENSION_QUESTION_S * n_questions + sum(_question_seconds(study, t) for t in study.test_set)
    conditions = list(study.conditions.all())
    shown = [animation_seconds(p) for c in conditions if not c.closed_loop for p in c.training]
    typical = sum(shown) / len(shown) if shown else 0.0
    out = []
    for c in conditions:
        if c.closed_loop:
            n, checks = c.closed_loop["settings"]["max_examples"], max_checks(c.closed_loop)
            watched = n * typical
            check_s = sum(_question_seconds(study, t) + FEEDBACK_S for t in c.closed_loop["checks"][:checks])
        else:
            n, checks, watched, check_s = len(c.training), 0, sum(animation_seconds(p) for p in c.training), 0.0
        seconds = fixed + n * EXAMPLE_S + watched + check_s
        out.append(Estimate(c.name, n, checks, watched, seconds / 60, bool(c.closed_loop)))
    return out


def warnings(study: Study, found: list[Estimate]) -> list[str]:
    """What the study's page should say of the estimates: conditions further apart than the study's
    tolerance, and conditions longer than the consent page announces."""
    if not found:
        return []
    out = []
    longest, shortest = max(found, key=lambda e: e.minutes), min(found, key=lambda e: e.minutes)
    if longest.minutes - shortest.minutes > study.duration_tolerance_minutes:
        tolerance = study.duration_tolerance_minutes
        out.append(f"Condition '{longest.condition}' is estimated at {longest.minutes:.0f} minutes and "
                   f"'{shortest.condition}' at {shortest.minutes:.0f}: more than the {tolerance} "
                   "minutes they may differ by. Time on task then differs with the condition; consider other "
                   "conditions, or a larger tolerance if that is intended.")
    over = [e.condition for e in found if e.minutes > study.estimated_minutes]
    if over:
        out.append(f"The consent page says about {study.estimated_minutes} minutes, but "
                   f"{', '.join(repr(n) for n in over)} {'is' if len(over) == 1 else 'are'} estimated to take longer.")
    return out
