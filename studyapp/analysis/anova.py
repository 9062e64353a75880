"""Two-way ANOVAs (type II and type III) of the approximate-inference and coverage experiments.

Why the distance x determinism design is analysed twice, and the SS types used: see the
"Choices" in :mod:`studyapp.analysis.stats`.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from ..conditions import APPROX_STAR_DEFAULT, COVERAGE_APPROX, COVERAGE_RANDOM, MIN_PER_GROUP, negligible_spread
from .tables import included


@dataclass
class AnovaResult:
    name: str
    factors: tuple[str, ...]
    ok: bool
    message: str = ""
    type2: pd.DataFrame | None = None
    type3: pd.DataFrame | None = None
    cells: pd.DataFrame | None = None
    n: int = 0
    interaction: bool = True
    note: str = ""


def _anova_table(raw: pd.DataFrame, names: dict) -> pd.DataFrame:
    raw = raw.drop(index=[i for i in raw.index if i == "Intercept"])
    ss_res = float(raw.loc["Residual", "sum_sq"])
    rows = []
    for idx, r in raw.iterrows():
        eff = names.get(idx, idx)
        is_res = idx == "Residual"
        rows.append({
            "effect": "Residual" if is_res else eff,
            "SS": float(r["sum_sq"]), "df": float(r["df"]),
            "F": np.nan if is_res else float(r["F"]),
            "p": np.nan if is_res else float(r["PR(>F)"]),
            "partial_eta2": np.nan if is_res else float(r["sum_sq"]) / (float(r["sum_sq"]) + ss_res),
        })
    return pd.DataFrame(rows).set_index("effect")


def _within_spread(d: pd.DataFrame, group, dv: str) -> float:
    """The root mean square of `dv` about the means of its groups (`group`: a column, or a list of them
    for cells): zero when every group is constant."""
    within = d[dv] - d.groupby(group)[dv].transform("mean")
    return float(np.sqrt(np.mean(within**2))) if len(d) else 0.0


def factorial_anova(data: pd.DataFrame, factors: tuple[str, str], dv: str = "mean_score",
                    interaction: bool = True, name: str = "", min_per_cell: int = MIN_PER_GROUP,
                    expect_cells=None) -> AnovaResult:
    """Two-way ANOVA of ``dv`` on two categorical factors; type II and type III (sum coding).

    ``expect_cells``: the (level_a, level_b) cells the design should have; a missing or
    too-small cell yields ``ok=False`` with a message instead of numbers.
    """
    # a heavy import (1-2.5 s): loaded when an analysis runs, not by every web worker (the URLconf imports this module)
    import statsmodels.formula.api as smf  # noqa: PLC0415
    from statsmodels.stats.anova import anova_lm  # noqa: PLC0415

    a, b = factors
    d = data[[a, b, dv]].dropna().copy()
    d[a] = d[a].astype(str)
    d[b] = d[b].astype(str)
    cells = d.groupby([a, b])[dv].agg(n="size", mean="mean", sd="std").reset_index()
    res = AnovaResult(name=name, factors=factors, ok=False, cells=cells, n=len(d), interaction=interaction)
    if expect_cells is not None:
        have = {(r[a], r[b]): int(r["n"]) for _, r in cells.iterrows()}
        missing = [f"({x}, {y}): {have.get((x, y), 0)}" for x, y in expect_cells if have.get((x, y), 0) < min_per_cell]
        if missing:
            res.message = (f"{name or 'ANOVA'} not computed: too few participants after exclusions in "
                           f"cell(s) {'; '.join(missing)} (need at least {min_per_cell} in every cell).")
            return res
    elif (cells["n"] < min_per_cell).any() or d[a].nunique() < 2 or d[b].nunique() < 2:
        res.message = (f"{name or 'ANOVA'} not computed: need two levels of each factor and {min_per_cell}+ "
                       "participants per cell.")
        return res
    n_par = len(cells) if interaction else d[a].nunique() + d[b].nunique() - 1
    if len(d) - n_par < 1:
        res.message = f"{name or 'ANOVA'} not computed: no residual degrees of freedom ({len(d)} participants)."
        return res
    op = "*" if interaction else "+"
    names2 = {f"C({a})": a, f"C({b})": b, f"C({a}):C({b})": f"{a} x {b}"}
    names3 = {f"C({a}, Sum)": a, f"C({b}, Sum)": b, f"C({a}, Sum):C({b}, Sum)": f"{a} x {b}"}
    # Within-cell spread, not the model's residual: an additive model's residual also holds the
    # cells' departure from additivity, which would make constant cells look like data.
    if negligible_spread(_within_spread(d, [a, b], dv), d[dv]):
        same = negligible_spread(float(d[dv].std(ddof=0)), d[dv])
        res.message = (f"{name or 'ANOVA'} not computed: " + (
            "every included participant has the same score, so there is nothing to explain."
            if same else "no variance within cells (every participant in a cell has the same score), "
            "so F is undefined; compare the cell means directly."))
        return res
    m2 = smf.ols(f"{dv} ~ C({a}) {op} C({b})", data=d).fit()
    m3 = smf.ols(f"{dv} ~ C({a}, Sum) {op} C({b}, Sum)", data=d).fit()
    res.type2 = _anova_table(anova_lm(m2, typ=2), names2)
    res.type3 = _anova_table(anova_lm(m3, typ=3), names3)
    res.ok = True
    return res


def oneway_anova(table: pd.DataFrame, dv: str, conditions, name: str = "",
                 min_per_group: int = MIN_PER_GROUP) -> AnovaResult:
    """One-way ANOVA of ``dv`` across the `conditions` (the study's, canonical), over the included
    participants: its F and p are scipy.stats.f_oneway's (type II SS from statsmodels, as the factorial
    ones; with one factor every SS type is the same, so ``type3`` is None).  A condition with fewer than
    `min_per_group` participants yields ``ok=False`` naming it, as a factorial ANOVA's short cell."""
    import statsmodels.formula.api as smf  # noqa: PLC0415  (heavy: loaded when an analysis runs)
    from statsmodels.stats.anova import anova_lm  # noqa: PLC0415

    inc = included(table)
    d = inc.loc[inc["condition"].isin(list(conditions)), ["condition", dv]].dropna()
    cells = (d.groupby("condition")[dv].agg(n="size", mean="mean", sd="std")
             .reindex(list(conditions)).reset_index())
    cells["n"] = cells["n"].fillna(0).astype(int)
    res = AnovaResult(name=name, factors=("condition",), ok=False, cells=cells, n=len(d), interaction=False)
    short = [f"{c}: {n}" for c, n in zip(cells["condition"], cells["n"], strict=True) if n < min_per_group]
    if len(cells) < 2:
        res.message = (f"{name or 'ANOVA'} not computed: it compares two or more conditions, and the study has "
                       f"{len(cells)}.")
    elif short:
        res.message = (f"{name or 'ANOVA'} not computed: too few participants after exclusions in "
                       f"condition(s) {'; '.join(short)} (need at least {min_per_group} in every condition).")
    elif negligible_spread(_within_spread(d, "condition", dv), d[dv]):
        res.message = (f"{name or 'ANOVA'} not computed: no variance within conditions (every participant in a "
                       "condition has the same value), so F is undefined; compare the means directly.")
    else:
        fit = smf.ols(f"{dv} ~ C(condition)", data=d).fit()
        res.type2 = _anova_table(anova_lm(fit, typ=2), {"C(condition)": "condition"})
        res.ok = True
    return res


def distance_determinism_anovas(table: pd.DataFrame, dv: str = "mean_score") -> list[AnovaResult]:
    """The approximate-inference experiment (paper Sec. "Analysis"), honest about the missing cell; `dv`
    the participants' measure (a show study's mean regret or share of optimal ways)."""
    inc = included(table)
    approx = inc[(inc["model"] == "approximate") & ~inc["coverage"]]
    additive_cells = [(x, y) for x, y in [("reward", "deterministic"), ("euclidean", "deterministic"),
                                         ("strategy", "deterministic"), ("reward", "probabilistic"),
                                         ("euclidean", "probabilistic")]]
    r1 = factorial_anova(approx, ("distance", "determinism"), dv=dv, interaction=False,
                         name="distance + determinism (five approximate models, additive)",
                         expect_cells=additive_cells)
    r1.note = ("All five approximate models; strategy appears only as deterministic (prob-strategy == "
               "det-strategy), so the interaction is not estimable here and the model is additive. "
               "Without an interaction term type II and type III coincide.")
    sub = approx[approx["distance"].isin(["reward", "euclidean"])]
    r2 = factorial_anova(sub, ("distance", "determinism"), dv=dv, interaction=True,
                         name="distance x determinism (complete 2x2: reward/euclidean x det/prob)",
                         expect_cells=[c for c in additive_cells if c[0] != "strategy"])
    r2.note = "The complete part of the design, with interaction; type II and III differ when cells are unbalanced."
    return [r1, r2]


# The conditions each of the paper's ANOVAs compares: a study without every one of them has no such
# design, and gets no such ANOVA (a message about its empty cells would only be noise); a study that has
# them all gets it, with a message if a cell lacks participants.
ADDITIVE_CONDITIONS = ("det-reward", "det-euclidean", "det-strategy", "prob-reward", "prob-euclidean")
SQUARE_CONDITIONS = ("det-reward", "det-euclidean", "prob-reward", "prob-euclidean")


def coverage_conditions(approx_star: str = APPROX_STAR_DEFAULT) -> tuple[str, ...]:
    return ("random", COVERAGE_RANDOM, approx_star, COVERAGE_APPROX)


def paper_anovas(table: pd.DataFrame, conditions, approx_star: str = APPROX_STAR_DEFAULT,
                 dv: str = "mean_score") -> list[AnovaResult]:
    """The paper's ANOVAs of `dv` whose conditions are all among the study's `conditions` (canonical names)."""
    present = set(conditions)
    out = []
    if set(SQUARE_CONDITIONS) <= present:  # the additive design holds the square one: neither without it
        additive, square = distance_determinism_anovas(table, dv)
        out += [anova for anova, needs in ((additive, ADDITIVE_CONDITIONS), (square, SQUARE_CONDITIONS))
                if set(needs) <= present]
    if set(coverage_conditions(approx_star)) <= present:
        out.append(coverage_model_anova(table, approx_star, dv))
    return out


def coverage_model_frame(table: pd.DataFrame, approx_star: str = APPROX_STAR_DEFAULT) -> pd.DataFrame:
    inc = included(table)
    keep = inc["condition"].isin(coverage_conditions(approx_star))
    d = inc[keep].copy()
    d["model"] = np.where(d["condition"].isin(["random", COVERAGE_RANDOM]), "random", "approx*")
    d["coverage"] = np.where(d["coverage"], "with", "without")
    return d


def coverage_model_anova(table: pd.DataFrame, approx_star: str = APPROX_STAR_DEFAULT,
                         dv: str = "mean_score") -> AnovaResult:
    d = coverage_model_frame(table, approx_star)
    r = factorial_anova(d, ("coverage", "model"), dv=dv, interaction=True,
                        name="coverage x model ({random, approx*} x {without, with coverage})",
                        expect_cells=[(c, m) for c in ("without", "with") for m in ("random", "approx*")])
    r.note = f"approx* = {approx_star}; its no-coverage cell is the {approx_star} condition."
    return r

