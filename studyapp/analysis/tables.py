"""The derived per-participant table, exclusions and the per-condition summary.

Column schema of the input and derived tables: :mod:`studyapp.analysis.stats`.
"""
from __future__ import annotations

import numpy as np
import pandas as pd

from teaching.api import DIFFICULTIES

from ..conditions import APPROX_STAR_DEFAULT, canonicalize, condition_factors


def _answers(answers: pd.DataFrame) -> pd.DataFrame:
    a = answers.copy()
    if "score" not in a.columns or a["score"].isna().any():
        computed = np.where(a["correct"].astype(bool), a["confidence"], -a["confidence"]).astype(float)
        a["score"] = a["score"].fillna(pd.Series(computed, index=a.index)) if "score" in a else computed
    a["score"] = a["score"].astype(float)
    a["test_index"] = a["test_index"].astype(int)
    return a


def participant_table(participants: pd.DataFrame, answers: pd.DataFrame, training: pd.DataFrame,
                      approx_star: str = APPROX_STAR_DEFAULT) -> pd.DataFrame:
    """Per-participant table: condition, factors, number of examples, per-test scores, mean, exclusion."""
    p = canonicalize(participants)
    training = canonicalize(training)
    p["participant_id"] = p["participant_id"].astype(str)
    p["attention_ok"] = p["attention_ok"].astype(bool)
    if "excluded" not in p.columns:
        p["excluded"] = ~p["attention_ok"]
    p["excluded"] = p["excluded"].astype(bool)
    if "exclusion_reason" not in p.columns:
        p["exclusion_reason"] = np.where(p["excluded"],
                                         np.where(p["attention_ok"], "excluded", "failed attention check"), "")
    factors = pd.DataFrame([condition_factors(c, approx_star) for c in p["condition"]], index=p.index,
                           columns=["model", "distance", "determinism", "coverage"])
    factors["coverage"] = factors["coverage"].astype(bool)
    p = pd.concat([p.drop(columns=[c for c in factors.columns if c in p.columns]), factors], axis=1)
    counts = training.groupby("condition").size() if len(training) else pd.Series(dtype=int)
    p["n_examples"] = p["condition"].map(counts).fillna(0).astype(int)

    a = _answers(answers)
    a["participant_id"] = a["participant_id"].astype(str)
    wide = a.pivot_table(index="participant_id", columns="test_index", values="score", aggfunc="first")
    wide.columns = [f"score_{int(i)}" for i in wide.columns]
    p = p.merge(wide, left_on="participant_id", right_index=True, how="left")
    score_cols = [c for c in p.columns if c.startswith("score_")]
    p["n_answered"] = p[score_cols].notna().sum(axis=1) if score_cols else 0
    p["mean_score"] = p[score_cols].mean(axis=1) if score_cols else np.nan
    return p


def included(table: pd.DataFrame) -> pd.DataFrame:
    """Participants that enter the analysis: not excluded and with at least one answered test (a show
    study's table, analysis/shown.py, has no confidence score: its n_answered says)."""
    answered = table["mean_score"].notna() if "mean_score" in table else table["n_answered"] > 0
    return table[~table["excluded"] & answered]


class ParticipantCounts:
    """How many of an analysis' participants (its ``participants`` table) are analysed and excluded."""

    participants: pd.DataFrame

    @property
    def n_included(self) -> int:
        return int(len(included(self.participants)))

    @property
    def n_excluded(self) -> int:
        return int(self.participants["excluded"].sum())


def condition_summary(table: pd.DataFrame, order=None, dv: str = "mean_score") -> pd.DataFrame:
    """n, mean, SD and SE of the measure `dv` (by default the mean confidence score) per condition (after
    exclusions)."""
    inc = included(table)
    g = inc[inc[dv].notna()].groupby("condition")[dv]
    out = pd.DataFrame({"n": g.size(), "mean": g.mean(), "sd": g.std(ddof=1)})
    out["se"] = out["sd"] / np.sqrt(out["n"])
    n_all = table.groupby("condition").size()
    n_excl = table[table["excluded"]].groupby("condition").size()
    out = out.reindex(n_all.index)
    out["n"] = out["n"].fillna(0).astype(int)
    out.insert(0, "n_recruited", n_all)
    out.insert(1, "n_excluded", n_excl.reindex(n_all.index).fillna(0).astype(int))
    if order:
        known = [c for c in order if c in out.index]
        out = out.loc[known + [c for c in out.index if c not in known]]
    out.index.name = "condition"
    return out


DIFFICULTY_COLUMNS = ["condition", "difficulty", "n", "n_answers", "mean", "sd", "se", "accuracy"]


def difficulty_summary(per_test: pd.DataFrame) -> pd.DataFrame:
    """Scores by test difficulty per condition, from the included participants' answers (per_test, with
    ``test_difficulty``): n participants, answers, mean / SD / SE over participants of their mean score on
    that difficulty's tests, and the share of those answers with θ*'s option.  No rows when no test
    carries a difficulty (a study whose tests were drawn from any environment)."""
    if "test_difficulty" not in per_test or per_test["test_difficulty"].isna().all():
        return pd.DataFrame(columns=DIFFICULTY_COLUMNS)
    a = per_test[per_test["test_difficulty"].notna()]
    person = (a.groupby(["condition", "test_difficulty", "participant_id"])
              .agg(score=("score", "mean"), answers=("score", "size"), correct=("correct", "sum")).reset_index())
    g = person.groupby(["condition", "test_difficulty"])
    out = pd.DataFrame({"n": g.size(), "n_answers": g["answers"].sum(), "mean": g["score"].mean(),
                        "sd": g["score"].std(ddof=1)})
    out["se"] = out["sd"] / np.sqrt(out["n"])
    out["accuracy"] = g["correct"].sum() / out["n_answers"]
    out = out.reset_index().rename(columns={"test_difficulty": "difficulty"})
    rank = {d: i for i, d in enumerate(DIFFICULTIES)}  # easy (a large BEC) to hard
    out = out.sort_values(["condition", "difficulty"], key=lambda col: col.map(rank) if col.name == "difficulty"
                          else col, kind="stable")
    return out[DIFFICULTY_COLUMNS].reset_index(drop=True)
