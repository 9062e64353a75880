"""Planned pairwise comparisons: Welch's t-tests with Cohen's d, Holm-adjusted across the family."""
from __future__ import annotations

import numpy as np
import pandas as pd

from ..conditions import (
    APPROX_CONDITIONS,
    APPROX_STAR_DEFAULT,
    COVERAGE_APPROX,
    COVERAGE_RANDOM,
    MIN_PER_GROUP,
    ConditionError,
    canonical,
    label,
    negligible_spread,
)
from .tables import included

# A study may call its approx* condition by that name (data.analyze_study looks for these).
APPROX_STAR_NAMES = ("approx*", "approx-star")


def default_comparisons(approx_star: str = APPROX_STAR_DEFAULT) -> list[tuple[str, str]]:
    """The planned comparisons (a, b): effect is mean(a) - mean(b)."""
    return [(approx_star, "exact"), (approx_star, "random"), (COVERAGE_APPROX, "random"),
            (COVERAGE_RANDOM, "random")]


def check_approx_star(approx_star: str) -> str:
    """approx*'s canonical name: one of the approximate models (or a condition called "approx*").
    Anything else is a ConditionError: "random" would put random vs random in the family, and
    "coverage-random" coverage-random vs random twice."""
    name = canonical(approx_star)
    if name not in APPROX_CONDITIONS and name not in APPROX_STAR_NAMES:
        raise ConditionError(f"approx* must be one of the approximate models ({', '.join(APPROX_CONDITIONS)}), "
                             f"not {approx_star!r}")
    return name


def comparison_family(planned, named=(), known=None) -> list[tuple[str, str]]:
    """The Holm family: the planned pairs, then the `named` ones (a researcher's), under canonical
    names.  Each unordered pair enters once (a:b and b:a are one comparison) and no condition is
    compared with itself (t = 0, p = 1, and one more test inflates every other adjusted p); a
    named pair must name conditions in `known` (the study's, canonical) when it is given.  Anything
    else is a ConditionError naming the pair."""
    family, seen = [], {}
    for origin, pairs in (("planned", planned), ("named", named)):
        for a, b in pairs:
            pair = (canonical(a), canonical(b))
            shown = f"{a}:{b}"
            if origin == "named" and known is not None:
                unknown = [n for n in (a, b) if canonical(n) not in known]
                if unknown:
                    raise ConditionError(f"{shown}: {' and '.join(map(repr, unknown))} is not a condition of this "
                                         f"study (its conditions: {', '.join(sorted(known))})")
            if pair[0] == pair[1]:
                raise ConditionError(f"{shown} compares {pair[0]} with itself: a comparison needs two conditions")
            key = frozenset(pair)
            if key in seen:
                raise ConditionError(f"{shown} is {seen[key]} again: each pair of conditions enters the "
                                     "comparisons (and their Holm correction) once")
            seen[key] = f"the {origin} comparison {pair[0]} vs {pair[1]}"
            family.append(pair)
    return family


def welch(x, y) -> dict:
    """Welch's t-test of x vs y: t, df, p, 95 % CI of mean(x) - mean(y), Cohen's d (pooled SD)."""
    # a heavy import (1-2.5 s): loaded when an analysis runs, not by every web worker (the URLconf imports this module)
    import pingouin as pg  # noqa: PLC0415
    from scipy import stats  # noqa: PLC0415

    x = np.asarray(x, float)
    y = np.asarray(y, float)
    r = stats.ttest_ind(x, y, equal_var=False)
    ci = r.confidence_interval(0.95)
    return {"n_a": len(x), "n_b": len(y), "mean_a": x.mean(), "mean_b": y.mean(),
            "diff": x.mean() - y.mean(), "t": float(r.statistic), "df": float(r.df), "p": float(r.pvalue),
            "cohen_d": float(pg.compute_effsize(x, y, paired=False, eftype="cohen")),
            "ci_low": float(ci.low), "ci_high": float(ci.high)}


def welch_tests(table: pd.DataFrame, comparisons=None, approx_star: str = APPROX_STAR_DEFAULT,
                dv: str = "mean_score") -> tuple[pd.DataFrame, list[str]]:
    """Welch's t-tests for the planned comparisons, Holm-adjusted across those that could be run.

    Returns the table (one row per comparison; untestable ones carry a ``note`` and no numbers)
    and a list of messages.
    """
    # a heavy import (1-2.5 s): loaded when an analysis runs, not by every web worker (the URLconf imports this module)
    from statsmodels.stats.multitest import multipletests  # noqa: PLC0415

    comparisons = comparison_family(list(comparisons) if comparisons is not None else default_comparisons(approx_star))
    inc = included(table)
    rows, messages = [], []
    for a, b in comparisons:
        x = inc.loc[inc["condition"] == a, dv].dropna().to_numpy(float)
        y = inc.loc[inc["condition"] == b, dv].dropna().to_numpy(float)
        row = {"a": a, "b": b, "comparison": f"{label(a, approx_star)} vs {label(b, approx_star)}",
               "n_a": len(x), "n_b": len(y), "note": ""}
        if len(x) < MIN_PER_GROUP or len(y) < MIN_PER_GROUP:
            row["note"] = (f"not tested: {a} has {len(x)} and {b} has {len(y)} included participant(s); "
                           f"Welch's t needs at least {MIN_PER_GROUP} per group")
            messages.append(f"{row['comparison']}: {row['note']}.")
        elif negligible_spread(np.sqrt(np.var(x, ddof=1) + np.var(y, ddof=1)), np.concatenate([x, y])):
            row["note"] = ("not tested: within each group every score is the same (zero variance), "
                           "so t is undefined")
            messages.append(f"{row['comparison']}: {row['note']}.")
        else:
            row.update(welch(x, y))
        rows.append(row)
    cols = ["comparison", "a", "b", "n_a", "n_b", "mean_a", "mean_b", "diff", "t", "df", "p", "p_holm",
            "cohen_d", "ci_low", "ci_high", "note"]
    out = pd.DataFrame(rows).reindex(columns=cols)
    tested = out["t"].notna()
    if tested.any():
        out.loc[tested, "p_holm"] = multipletests(out.loc[tested, "p"].to_numpy(float), method="holm")[1]
    return out, messages

