"""The analysis of a show study: each test asks the participant to move the robot the way they think it
would go, and the way shown is scored under θ* (its regret: θ*'s optimal reward minus the way's reward, in
θ*'s units; optimal when that is 0).

Each participant has two measures over the tests they answered: their mean regret and their share of
optimal ways.  Each is analysed as a choice study's confidence score is: per condition n, mean, SD and SE
(tables.condition_summary), a one-way ANOVA across the study's conditions (anova.oneway_anova), the paper's
factorial ANOVAs where the study has their conditions (anova.paper_anovas: distance x determinism, coverage
x model) and Welch's t-tests of the planned and named pairs, Holm-adjusted within the measure
(comparisons.welch_tests).  Per test and per difficulty level (where the tests are graded), each
condition's answers are summarised too (:func:`by_test`, :func:`by_level`): how many, their mean regret and
SD, their share of optimal ways.  What only makes sense for choices among options (confidence scores, the
option chosen, fits of learner models to choices, the pilot's predicted choices) is not computed; the
report says so in one line each (SKIPPED).

Pure functions over pandas DataFrames, as :mod:`studyapp.analysis.stats`; the input tables are its
``participants`` and ``training`` and, for the answers, one row per (participant, test) with
``participant_id, test_index, optimal, regret`` (:data:`studyapp.analysis.data.SHOW_ANSWER_COLUMNS`).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from ..conditions import APPROX_STAR_DEFAULT, PAPER_CONDITIONS, canonicalize
from .anova import AnovaResult, oneway_anova, paper_anovas
from .comparisons import check_approx_star, comparison_family, default_comparisons, welch_tests
from .learning import SHOW_CURVE_COLUMNS, show_learning_curves
from .tables import ParticipantCounts, condition_summary, included, participant_table

# (column of the participants table, its name in words): the dependent measures, in the report's order.
MEASURES = (("mean_regret", "mean regret (θ*'s units, 0 = optimal)"),
            ("share_optimal", "share of optimal ways"))
# One line each on the report: what a choice study's analysis has and a show study's cannot.
SKIPPED = (
    "Confidence scores and their correlations: not computed, as a show test has no options "
    "to rate; the measures above take their place.",
    "The option chosen and accuracy by test difficulty: not computed, as a show test asks for a way, not a "
    "choice among options.",
    "Learner models fitted to the answers: not fitted, as the models predict choices among options and a show "
    "test has none.",
    "The simulated pilot's predicted scores: not shown, as they predict choices among options.",
)


@dataclass
class Measure:
    """One dependent measure's results: per-condition summary, one-way ANOVA, the paper's factorial
    ANOVAs (those whose conditions the study has), Welch's t-tests."""

    column: str
    name: str
    summary: pd.DataFrame
    anova: AnovaResult
    welch: pd.DataFrame
    factorial: list[AnovaResult] = field(default_factory=list)


@dataclass
class ShowAnalysis(ParticipantCounts):
    participants: pd.DataFrame
    answers: pd.DataFrame
    measures: list[Measure]
    messages: list[str]
    approx_star: str = APPROX_STAR_DEFAULT
    by_test: pd.DataFrame = field(default_factory=pd.DataFrame)
    by_level: pd.DataFrame = field(default_factory=pd.DataFrame)
    # θ*'s L1 norm, where the domain's regrets are in θ*'s raw units: dividing by it gives Lee, Admoni &
    # Simmons' units (θ* scaled to an L1 norm of 1); None where unknown
    theta_star_l1: float | None = None
    # closed-loop conditions' learning curves (learning.SHOW_CURVE_COLUMNS); no rows when no check was answered
    learning: pd.DataFrame = field(default_factory=lambda: pd.DataFrame(columns=SHOW_CURVE_COLUMNS))
    skipped: tuple[str, ...] = field(default=SKIPPED)


def show_table(participants: pd.DataFrame, answers: pd.DataFrame, training: pd.DataFrame,
               approx_star: str = APPROX_STAR_DEFAULT) -> pd.DataFrame:
    """The per-participant table (tables.participant_table's factors, examples and exclusions) with
    ``regret_<i>`` and ``optimal_<i>`` per test i, ``n_answered``, ``mean_regret`` and ``share_optimal``
    (over the tests answered; NaN without an answer)."""
    a = answers.copy()
    a["participant_id"] = a["participant_id"].astype(str)
    # participant_table spreads a per-test "score": here the regret, renamed below
    scored = pd.DataFrame({"participant_id": a["participant_id"], "test_index": a["test_index"].astype(int),
                           "score": a["regret"].astype(float)})
    p = participant_table(participants, scored, training, approx_star)
    p = p.rename(columns={c: "regret_" + c[len("score_"):] for c in p.columns if c.startswith("score_")})
    p = p.rename(columns={"mean_score": "mean_regret"})
    optimal = (a.assign(optimal=a["optimal"].astype(float))
               .pivot_table(index="participant_id", columns="test_index", values="optimal", aggfunc="first"))
    optimal.columns = [f"optimal_{int(i)}" for i in optimal.columns]
    p = p.merge(optimal, left_on="participant_id", right_index=True, how="left")
    optimal_cols = list(optimal.columns)
    p["share_optimal"] = p[optimal_cols].mean(axis=1) if optimal_cols else np.nan
    return p


SUMMARY_COLUMNS = ["condition", "n", "mean_regret", "sd_regret", "share_optimal"]


def _summarise(answers: pd.DataFrame, keys: list[str], order: list[str]) -> pd.DataFrame:
    """Answers (with a condition column) grouped by `keys` + condition, conditions in `order`."""
    if answers.empty:
        return pd.DataFrame(columns=[*keys, *SUMMARY_COLUMNS])
    out = (answers.groupby([*keys, "condition"], dropna=False, sort=False)
           .agg(n=("regret", "size"), mean_regret=("regret", "mean"), sd_regret=("regret", "std"),
                share_optimal=("optimal", "mean")).reset_index())
    out["order"] = out["condition"].map({c: k for k, c in enumerate(order)}).fillna(len(order))
    return out.sort_values([*keys, "order", "condition"]).drop(columns="order").reset_index(drop=True)


def _included_answers(table: pd.DataFrame, answers: pd.DataFrame) -> pd.DataFrame:
    """The answers of the participants the analysis includes, with their condition."""
    people = included(table)[["participant_id", "condition"]]
    a = answers.assign(participant_id=answers["participant_id"].astype(str), regret=answers["regret"].astype(float),
                       optimal=answers["optimal"].astype(float), test_index=answers["test_index"].astype(int))
    return a.merge(people, on="participant_id", how="inner")


def by_test(table: pd.DataFrame, answers: pd.DataFrame, cluster_names=(), order=()) -> pd.DataFrame:
    """One row per (test, condition) over the included participants' answers: test_index, the test's
    cluster (its name where `cluster_names` gives it) and difficulty level ("" ungraded), then n, mean_regret,
    sd_regret (NaN for one answer) and share_optimal."""
    a = _included_answers(table, answers)
    a["cluster"] = [cluster_names[int(c)] if c is not None and not pd.isna(c) and int(c) < len(cluster_names)
                    else ("" if c is None or pd.isna(c) else str(int(c))) for c in a["test_cluster"]]
    a["difficulty"] = a["test_difficulty"].fillna("").astype(str)
    return _summarise(a, ["test_index", "cluster", "difficulty"], list(order))


def by_level(table: pd.DataFrame, answers: pd.DataFrame, order=()) -> pd.DataFrame:
    """One row per (difficulty level, condition), levels low, medium, high: as :func:`by_test` over every
    test of the level; empty when no test is graded."""
    a = _included_answers(table, answers)
    a = a[a["test_difficulty"].notna() & (a["test_difficulty"].astype(str) != "")]
    out = _summarise(a.rename(columns={"test_difficulty": "difficulty"}), ["difficulty"], list(order))
    rank = {"low": 0, "medium": 1, "high": 2}
    return out.sort_values("difficulty", key=lambda d: d.map(rank), kind="stable").reset_index(drop=True)


def _conditions(names) -> list[str]:
    """The study's conditions (with or without participants), the paper's first, in its order."""
    names = set(names)
    return [c for c in PAPER_CONDITIONS if c in names] + sorted(names - set(PAPER_CONDITIONS))


def analyze_show(participants: pd.DataFrame, answers: pd.DataFrame, training: pd.DataFrame,
                 comparisons=None, extra_comparisons=(), approx_star: str = APPROX_STAR_DEFAULT,
                 conditions=(), cluster_names=(), checks=None, theta_star_l1: float | None = None) -> ShowAnalysis:
    """The analysis of a show study's answers, as stats.analyze's arguments: ``extra_comparisons`` join the
    planned pairs (those the study has both conditions of) in each measure's Holm family; ``conditions``: the
    study's (canonical), which the one-way ANOVA expects even before they have participants or examples;
    ``cluster_names``: the domain's, naming each test's cluster in the per-test summary; ``checks``: the
    closed-loop check answers (learning.py's input), whose curves count the included participants only;
    ``theta_star_l1``: θ*'s L1 norm, which the report names for regrets in θ*-over-its-L1-norm units.  A
    ConditionError for an approx* that is no approximate model or comparisons that are not distinct pairs of
    its conditions."""
    participants, training = canonicalize(participants), canonicalize(training)
    approx_star = check_approx_star(approx_star)
    known = set(conditions) | set(participants.get("condition", [])) | set(training.get("condition", []))
    planned = list(comparisons) if comparisons is not None else [
        pair for pair in default_comparisons(approx_star) if set(pair) <= known]
    comps = comparison_family(planned, extra_comparisons, known)  # ConditionError before any work
    table = show_table(participants, answers, training, approx_star)
    conditions = _conditions(known)
    measures, messages = [], []
    for column, name in MEASURES:
        anova = oneway_anova(table, column, conditions, name=f"one-way ANOVA of the {name} across conditions")
        welch, notes = welch_tests(table, comps, approx_star, dv=column)
        measures.append(Measure(column=column, name=name, anova=anova, welch=welch,
                                summary=condition_summary(table, order=PAPER_CONDITIONS, dv=column),
                                factorial=paper_anovas(table, conditions, approx_star, dv=column)))
        messages += ([anova.message] if not anova.ok else []) + [f"{name}: {note}" for note in notes]
    return ShowAnalysis(participants=table, answers=answers, measures=measures, messages=messages,
                        approx_star=approx_star, by_test=by_test(table, answers, cluster_names, conditions),
                        by_level=by_level(table, answers, conditions),
                        learning=show_learning_curves(checks, included(table)["participant_id"]),
                        theta_star_l1=theta_star_l1)
