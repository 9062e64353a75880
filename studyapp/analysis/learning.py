"""Learning curves from the check questions of closed-loop conditions.

Pure pandas and statsmodels, no Django: the curves can be computed (and tested) on any table of check
answers.  A closed-loop condition asks each participant check questions between its examples
(studyapp.participant.closedloop); the k-th check a participant answered is their check number k.  The curve of a
condition says, per check number, how often its participants chose θ*'s option by then.

Input ``checks`` -- one row per check answer (:func:`studyapp.analysis.data.checks_frame`):

====================  =======  ==========================================================
participant_id        str
condition             str      the closed-loop condition's name
check_number          int      1, 2, ...: the participant's k-th check, in the order answered
loop_index            int      the check's step within the participant's loop (LoopStep.index)
examples_before       int      examples the participant had seen before this check
correct               bool     θ*'s option was chosen (a show check: the way shown was optimal)
score                 float    confidence score, -7..7 (the chosen option's rating, negated if wrong);
                               NaN for a show check
regret                float    a show check: the way's regret under θ* (θ*'s units); NaN for a choice
====================  =======  ==========================================================

Output of :func:`learning_curves` -- one row per (condition, check_number), in :data:`CURVE_COLUMNS`:
``n`` participants who answered that check, ``n_correct``, ``p_correct`` = n_correct / n with its 95 %
Wilson interval (``ci_low``, ``ci_high``; statsmodels ``proportion_confint``), ``mean_score`` and its
standard error ``se_score`` (SD with ddof 1 over sqrt(n); empty for n = 1), and ``mean_examples``, the mean
number of examples seen before that check.  A show study's checks ask to show the way:
:func:`show_learning_curves` gives the same per check number with the share of optimal ways and the mean
regret in their place (:data:`SHOW_CURVE_COLUMNS`).
"""
from __future__ import annotations

import numpy as np
import pandas as pd
from statsmodels.stats.proportion import proportion_confint

from ..conditions import canonicalize

CHECK_COLUMNS = ["participant_id", "condition", "check_number", "loop_index", "examples_before", "correct", "score",
                 "regret"]
CURVE_COLUMNS = ["condition", "check_number", "n", "n_correct", "p_correct", "ci_low", "ci_high", "mean_score",
                 "se_score", "mean_examples"]
SHOW_CURVE_COLUMNS = ["condition", "check_number", "n", "n_optimal", "p_optimal", "ci_low", "ci_high", "mean_regret",
                      "se_regret", "mean_examples"]
CHANCE = 0.25  # a check question has four options: a guess picks θ*'s one in four times
CI_METHOD = "wilson"


def empty_curves() -> pd.DataFrame:
    return pd.DataFrame(columns=CURVE_COLUMNS)


def learning_curves(checks: pd.DataFrame | None, participant_ids=None, alpha: float = 0.05) -> pd.DataFrame:
    """The learning curves of `checks` (the module's input table), counting only the participants in
    `participant_ids` (those the rest of the analysis includes; None: everyone in `checks`).  Empty
    (:data:`CURVE_COLUMNS`, no rows) when there is no check answer to count."""
    if checks is None or not len(checks):
        return empty_curves()
    c = canonicalize(checks)
    c["participant_id"] = c["participant_id"].astype(str)
    if participant_ids is not None:
        c = c[c["participant_id"].isin({str(i) for i in participant_ids})]
    if not len(c):
        return empty_curves()
    c = c.assign(correct=c["correct"].astype(bool).astype(int), score=c["score"].astype(float))
    g = c.groupby(["condition", "check_number"], sort=True)
    out = pd.DataFrame({"n": g.size(), "n_correct": g["correct"].sum(), "mean_score": g["score"].mean(),
                        "sd": g["score"].std(ddof=1), "mean_examples": g["examples_before"].mean()}).reset_index()
    out["p_correct"] = out["n_correct"] / out["n"]
    low, high = proportion_confint(out["n_correct"].to_numpy(), out["n"].to_numpy(), alpha=alpha, method=CI_METHOD)
    out["ci_low"], out["ci_high"] = np.asarray(low, float), np.asarray(high, float)
    out["se_score"] = out["sd"] / np.sqrt(out["n"])
    out["check_number"] = out["check_number"].astype(int)
    out[["n", "n_correct"]] = out[["n", "n_correct"]].astype(int)
    return out[CURVE_COLUMNS]


def show_learning_curves(checks: pd.DataFrame | None, participant_ids=None, alpha: float = 0.05) -> pd.DataFrame:
    """The learning curves of a show study's checks, as :func:`learning_curves` (the same counting, the
    same Wilson interval): ``n_optimal`` and ``p_optimal`` the participants whose way was optimal at check k,
    ``mean_regret`` and ``se_regret`` their regret's mean and standard error (:data:`SHOW_CURVE_COLUMNS`)."""
    if checks is None or not len(checks):
        return pd.DataFrame(columns=SHOW_CURVE_COLUMNS)
    curves = learning_curves(checks.assign(score=checks["regret"]), participant_ids, alpha)
    return curves.rename(columns={"n_correct": "n_optimal", "p_correct": "p_optimal", "mean_score": "mean_regret",
                                  "se_score": "se_regret"})[SHOW_CURVE_COLUMNS]


def number_checks(checks: pd.DataFrame) -> pd.DataFrame:
    """`checks` (rows in their order, index reset) with ``check_number``: 1, 2, ... per participant by
    ``loop_index``, the order in which each participant answered their checks."""
    checks = checks.reset_index(drop=True)
    by_step = checks.sort_values("loop_index", kind="stable")
    return checks.assign(check_number=by_step.groupby("participant_id").cumcount() + 1)
