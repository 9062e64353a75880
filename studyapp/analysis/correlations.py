"""Pearson correlations of (helpful) training examples with scores, and the examples-per-cluster grid."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from ..conditions import MIN_PEARSON, Clusters, canonical, canonicalize, default_clusters
from .tables import _answers, included


@dataclass
class Correlation:
    name: str
    x: str
    y: str
    level: str
    ok: bool
    n: int = 0
    r: float = np.nan
    p: float = np.nan
    ci_low: float = np.nan
    ci_high: float = np.nan
    message: str = ""
    data: pd.DataFrame = field(default_factory=pd.DataFrame)

    def as_row(self) -> dict:
        return {"correlation": self.name, "level": self.level, "n": self.n, "r": self.r, "p": self.p,
                "ci_low": self.ci_low, "ci_high": self.ci_high, "note": self.message}


def pearson(x, y) -> dict:
    # a heavy import (1-2.5 s): loaded when an analysis runs, not by every web worker (the URLconf imports this module)
    from scipy import stats  # noqa: PLC0415
    r = stats.pearsonr(np.asarray(x, float), np.asarray(y, float))
    ci = r.confidence_interval(0.95)
    return {"r": float(r.statistic), "p": float(r.pvalue), "ci_low": float(ci.low), "ci_high": float(ci.high)}


def correlation(data: pd.DataFrame, x: str, y: str, name: str, level: str) -> Correlation:
    d = data[[x, y]].dropna()
    c = Correlation(name=name, x=x, y=y, level=level, ok=False, n=len(d), data=data)
    if len(d) < MIN_PEARSON:
        c.message = f"not computed: {len(d)} point(s); Pearson r with a 95 % CI needs at least {MIN_PEARSON}"
    elif d[x].nunique() < 2 or d[y].nunique() < 2:
        c.message = f"not computed: {x if d[x].nunique() < 2 else y} is constant over all {len(d)} points"
    else:
        c.ok = True
        for k, v in pearson(d[x], d[y]).items():
            setattr(c, k, v)
    return c


def examples_per_cluster(training: pd.DataFrame, conditions=None, clusters: Clusters | None = None) -> pd.DataFrame:
    """Count of training examples per (condition, strategy cluster): the paper's "examples shown" grid,
    one column per cluster of the study's domain (`clusters`; None: the default domain's)."""
    k = (clusters or default_clusters()).n
    training = canonicalize(training)
    if conditions is not None:
        conditions = [canonical(c) for c in conditions]
    if len(training):
        grid = training.groupby(["condition", "cluster"]).size().unstack(fill_value=0)
    else:
        grid = pd.DataFrame()
    grid = grid.reindex(columns=range(k), fill_value=0)
    if conditions is not None:
        grid = grid.reindex(list(conditions), fill_value=0)
    grid = grid.fillna(0).astype(int)
    grid.columns.name = "cluster"
    grid.index.name = "condition"
    return grid


def helpful_examples(counts: pd.DataFrame, condition: str, test_cluster: int, clusters: Clusters | None = None) -> int:
    """Helpful examples for a test in cluster A1: x = #examples in A1, y = #in its siblings (the other
    clusters of its class in the study's domain, `clusters`; None: the default domain's); x if x > 0 else -y."""
    if condition not in counts.index:
        return 0
    row = counts.loc[condition]
    x = int(row.get(int(test_cluster), 0))
    y = sum(int(row.get(k, 0)) for k in (clusters or default_clusters()).siblings(test_cluster))
    return x if x > 0 else -y


def per_test_frame(table: pd.DataFrame, answers: pd.DataFrame, training: pd.DataFrame,
                   clusters: Clusters | None = None) -> pd.DataFrame:
    """Answers of included participants with condition, n_examples and helpful examples attached."""
    inc = included(table)[["participant_id", "condition", "n_examples"]]
    a = _answers(answers)
    a["participant_id"] = a["participant_id"].astype(str)
    a = a.merge(inc, on="participant_id", how="inner")
    counts = examples_per_cluster(training, conditions=sorted(set(a["condition"])), clusters=clusters)
    a["helpful"] = [helpful_examples(counts, c, t, clusters)
                    for c, t in zip(a["condition"], a["test_cluster"], strict=True)]
    return a


def correlations(table: pd.DataFrame, answers: pd.DataFrame, training: pd.DataFrame,
                 clusters: Clusters | None = None) -> list[Correlation]:
    """Pearson r of number of examples vs score and of helpful examples vs per-test score.

    Two levels each.  "condition x test" is the paper's (Fig. "corr"): one point per
    (condition, test), y = mean score of the included participants on that test.  The
    individual level uses one point per participant (examples vs mean score) or per answer
    (helpful vs score).
    """
    a = per_test_frame(table, answers, training, clusters)
    ct = (a.groupby(["condition", "test_index", "test_cluster"])
          .agg(score=("score", "mean"), n=("score", "size"), n_examples=("n_examples", "first"),
               helpful=("helpful", "first")).reset_index())
    inc = included(table)
    return [
        correlation(ct, "n_examples", "score", "number of examples vs score", "condition x test"),
        correlation(ct, "helpful", "score", "helpful examples vs per-test score", "condition x test"),
        correlation(inc, "n_examples", "mean_score", "number of examples vs mean score", "participant"),
        correlation(a, "helpful", "score", "helpful examples vs per-test score", "answer"),
    ]

