"""Statistics of the user study (DESIGN §8; paper Secs. "Analysis", "Utility", "Coverage").

Pure functions over pandas DataFrames: no Django import, so the whole analysis can be run
(and tested) on any table of responses.  Every F, t and p comes from statsmodels / SciPy /
pingouin; nothing here evaluates a distribution by hand.

Input tables (built from the database by :mod:`studyapp.analysis.data`, or by hand)
-----------------------------------------------------------------------------------

``participants`` -- one row per participant (excluded ones included):

====================  =======  ==========================================================
column                type     meaning
====================  =======  ==========================================================
participant_id        str      unique id
condition             str      condition name ("exact", "det-euclidean", "random", ...)
attention_ok          bool     passed the attention check (its domain's question)
excluded              bool     optional; defaults to ``not attention_ok``
exclusion_reason      str      optional; "" when not excluded
age, gender           any      optional demographics, passed through
====================  =======  ==========================================================

``answers`` -- one row per (participant, test):

====================  =======  ==========================================================
participant_id        str
test_index            int      0..5, the position of the test in the shared test set
test_cluster          int      strategy cluster 0..C-1 of theta*'s trajectory in that test
test_difficulty       str      optional; low / medium / high for a graded test (BEC-size tertile)
correct               bool     the chosen option is theta*'s trajectory
confidence            int      1..7 rating the participant gave the chosen option
score                 float    optional; defaults to confidence if correct else -confidence
====================  =======  ==========================================================

``training`` -- one row per training example shown in a condition:

====================  =======  ==========================================================
condition             str
position              int      0-based order in the training sequence
environment_id        int      optional
cluster               int      strategy cluster 0..C-1 of theta*'s trajectory there
====================  =======  ==========================================================

Derived per-participant table (:func:`participant_table`) -- the input rows plus
``model`` ("exact" | "approximate" | "random" | "other"), ``distance`` ("reward" |
"euclidean" | "strategy" | NaN), ``determinism`` ("deterministic" | "probabilistic" | NaN),
``coverage`` (bool), ``n_examples`` (int), ``score_<i>`` per test i, ``n_answered`` and
``mean_score`` (mean of the answered tests' scores).

Choices (see docs/analysis.md)
------------------------------
* Exclusions: rows with ``excluded`` are kept in the per-participant table but left out of
  every test, mean and figure.
* distance x determinism: the 2x3 design is incomplete (prob-strategy == det-strategy, so
  there is no probabilistic strategy cell).  We do not duplicate det-strategy participants.
  We report (a) the additive model ``distance + determinism`` over the five approximate
  conditions (estimable; its distance effect has 2 df as in the paper) and (b) the full
  factorial with interaction over the complete 2x2 part {reward, euclidean} x {det, prob}.
* coverage x model: full 2x2 over {random, approx*} x {without, with coverage}; the
  "approx*, without coverage" cell is the approx* condition (det-euclidean by default).
* Type II sums of squares from statsmodels ``anova_lm(typ=2)``; type III from
  ``anova_lm(typ=3)`` on a model fitted with sum-to-zero coding ``C(x, Sum)``.
  Partial eta^2 = SS_effect / (SS_effect + SS_residual).
* Welch's t: ``scipy.stats.ttest_ind(equal_var=False)`` (t, Welch-Satterthwaite df, p and the
  95 % CI of mean(a) - mean(b)); Cohen's d with the pooled SD (pingouin
  ``compute_effsize(eftype="cohen")``); Holm over the comparisons actually tested
  (statsmodels ``multipletests``).
* Pearson: ``scipy.stats.pearsonr`` with its Fisher-z 95 % CI.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import pandas as pd

from ..conditions import (
    ALIASES,
    APPROX_CONDITIONS,
    APPROX_STAR_DEFAULT,
    COVERAGE_APPROX,
    COVERAGE_RANDOM,
    DETERMINISM,
    DISTANCES,
    MIN_PEARSON,
    MIN_PER_GROUP,
    PAPER_CONDITIONS,
    Clusters,
    ConditionError,
    aliased_pairs,
    canonical,
    canonicalize,
    check_distinct_conditions,
    condition_factors,
    default_clusters,
    label,
)

# The implementation lives in the modules below; this module stays the public entry point, so
# ``from studyapp.analysis import stats as S; S.<name>`` keeps working for every name it had.
from .anova import (
    AnovaResult,
    coverage_model_anova,
    coverage_model_frame,
    distance_determinism_anovas,
    factorial_anova,
    paper_anovas,
)
from .comparisons import (
    APPROX_STAR_NAMES,
    check_approx_star,
    comparison_family,
    default_comparisons,
    welch,
    welch_tests,
)
from .correlations import (
    Correlation,
    correlation,
    correlations,
    examples_per_cluster,
    helpful_examples,
    pearson,
    per_test_frame,
)
from .learning import empty_curves, learning_curves
from .tables import ParticipantCounts, condition_summary, difficulty_summary, included, participant_table

__all__ = [
    # conditions
    "ALIASES", "APPROX_CONDITIONS", "APPROX_STAR_DEFAULT", "COVERAGE_APPROX", "COVERAGE_RANDOM",
    "DETERMINISM", "DISTANCES", "MIN_PEARSON", "MIN_PER_GROUP", "PAPER_CONDITIONS", "ConditionError",
    "aliased_pairs", "canonical", "check_distinct_conditions",
    "canonicalize", "Clusters", "condition_factors", "default_clusters", "label",
    # tables
    "condition_summary", "difficulty_summary", "included", "participant_table",
    # anova
    "AnovaResult", "coverage_model_anova", "coverage_model_frame", "distance_determinism_anovas",
    "factorial_anova",
    # comparisons
    "APPROX_STAR_NAMES", "check_approx_star", "comparison_family", "default_comparisons", "welch", "welch_tests",
    # correlations
    "Correlation", "correlation", "correlations", "examples_per_cluster", "helpful_examples",
    "pearson", "per_test_frame",
    # learning
    "empty_curves", "learning_curves",
    # this module
    "Analysis", "analyze", "fmt_p",
]


@dataclass
class Analysis(ParticipantCounts):
    participants: pd.DataFrame
    summary: pd.DataFrame
    anovas: list[AnovaResult]
    welch: pd.DataFrame
    correlations: list[Correlation]
    examples_per_cluster: pd.DataFrame
    per_test: pd.DataFrame
    messages: list[str]
    approx_star: str = APPROX_STAR_DEFAULT
    # the study's domain's strategy clusters (the grid's columns, the figures' names, the helpful examples' siblings)
    clusters: Clusters = field(default_factory=default_clusters)
    # closed-loop conditions' learning curves (learning.CURVE_COLUMNS); no rows when no check was answered
    learning: pd.DataFrame = field(default_factory=empty_curves)
    # scores by test difficulty per condition (tables.DIFFICULTY_COLUMNS); no rows when the tests are not graded
    by_difficulty: pd.DataFrame = field(default_factory=lambda: difficulty_summary(pd.DataFrame()))

    def correlation_table(self) -> pd.DataFrame:
        return pd.DataFrame([c.as_row() for c in self.correlations])


def analyze(participants: pd.DataFrame, answers: pd.DataFrame, training: pd.DataFrame,
            comparisons=None, extra_comparisons=(), approx_star: str = APPROX_STAR_DEFAULT,
            checks: pd.DataFrame | None = None, clusters: Clusters | None = None) -> Analysis:
    """Run the whole analysis.  ``extra_comparisons``: pairs a researcher names, added to the
    planned ones (and to the Holm family).  ``checks``: closed-loop check answers (learning.py's
    input), whose learning curves count only the participants the analysis includes.  A
    ConditionError (a ValueError) when two condition names are one condition, approx* is not an
    approximate model, or the comparisons are not distinct pairs of the study's conditions
    (comparisons.comparison_family).  ``clusters``: the study's domain's (None: the default domain's,
    for tables made by hand)."""
    clusters = clusters or default_clusters()
    participants, training = canonicalize(participants), canonicalize(training)
    approx_star = check_approx_star(approx_star)
    known = set(participants.get("condition", [])) | set(training.get("condition", []))
    # the paper's planned comparisons where the study has both conditions; given ones as given
    planned = list(comparisons) if comparisons is not None else [
        pair for pair in default_comparisons(approx_star) if set(pair) <= known]
    comps = comparison_family(planned, extra_comparisons, known)  # ConditionError before any work
    table = participant_table(participants, answers, training, approx_star)
    conditions = list(dict.fromkeys([*[c for c in PAPER_CONDITIONS if c in set(table["condition"])],
                                     *sorted(set(table["condition"]) | set(training.get("condition", [])))]))
    summary = condition_summary(table, order=PAPER_CONDITIONS)
    messages = []
    anovas = paper_anovas(table, known, approx_star)
    messages += [r.message for r in anovas if not r.ok]
    w, msgs = welch_tests(table, comps, approx_star)
    messages += msgs
    cors = correlations(table, answers, training, clusters)
    messages += [f"Pearson r, {c.name} ({c.level}): {c.message}." for c in cors if not c.ok]
    epc = examples_per_cluster(training, conditions=conditions, clusters=clusters)
    per_test = per_test_frame(table, answers, training, clusters)
    return Analysis(participants=table, summary=summary, anovas=anovas, welch=w, correlations=cors,
                    examples_per_cluster=epc, per_test=per_test, messages=messages, approx_star=approx_star,
                    clusters=clusters, learning=learning_curves(checks, included(table)["participant_id"]),
                    by_difficulty=difficulty_summary(per_test))


def fmt_p(p: float) -> str:
    if p is None or (isinstance(p, float) and math.isnan(p)):
        return ""
    return "< .001" if p < 0.001 else f"{p:.3f}".lstrip("0") if p < 1 else "1.000"
