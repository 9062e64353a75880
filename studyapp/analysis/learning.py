"""Learning curves from the check questions of closed-loop conditions.

Pure pandas and statsmodels, no Django: the curves can be computed (and tested) on any table of check
answers.  A closed-loop condition asks each participant check questions between its examples
(studyapp.closedloop); the k-th check a participant answered is their check number k.  The curve of a
condition says, per check number, how often its participants chose θ*'s option by then.

Input ``checks`` -- one row per check answer (:func:`studyapp.analysis.data.checks_frame`):

====================  =======  ==========================================================
participant_id        str
condition             str      the closed-loop condition's name
check_number          int      1, 2, ...: the participant's k-th check, in the order answered
loop_index            int      the check's step within the participant's loop (LoopStep.index)
examples_before       int      examples the participant had seen before this check
correct               bool     θ*'s option was chosen
score                 float    confidence score, -7..7 (the chosen option's rating, negated if wrong)
====================  =======  ==========================================================

Output of :func:`learning_curves` -- one row per (condition, check_number), in :data:`CURVE_COLUMNS`:
``n`` participants who answered that check, ``n_correct``, ``p_correct`` = n_correct / n with its 95 %
Wilson interval (``ci_low``, ``ci_high``; statsmodels ``proportion_confint``), ``mean_score`` and its
standard error ``se_score`` (SD with ddof 1 over sqrt(n); empty for n = 1), and ``mean_examples``, the mean
number of examples seen before that check.
"""
from __future__ import annotations

import numpy as np
import pandas as pd
from statsmodels.stats.proportion import proportion_confint

from .conditions import canonicalize

CHECK_COLUMNS = ["participant_id", "condition", "check_number", "loop_index", "examples_before", "correct", "score"]
CURVE_COLUMNS = ["condition", "check_number", "n", "n_correct", "p_correct", "ci_low", "ci_high", "mean_score",
                 "se_score", "mean_examples"]
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


def number_checks(checks: pd.DataFrame) -> pd.DataFrame:
    """`checks` (rows in their order, index reset) with ``check_number``: 1, 2, ... per participant by
    ``loop_index``, the order in which each participant answered their checks."""
    checks = checks.reset_index(drop=True)
    by_step = checks.sort_values("loop_index", kind="stable")
    return checks.assign(check_number=by_step.groupby("participant_id").cumcount() + 1)
