"""Formatting shared by the analysis reports (report.py for a choice study, report_show.py for a show study):
numbers, p values, ANOVA rows, table cells and the count of each kind of participant."""
from __future__ import annotations

import math

import numpy as np
import pandas as pd

from .. import status as ST
from . import figures as FIG
from . import stats as S


def num(v, digits=2):
    if v is None or (isinstance(v, (float, np.floating)) and math.isnan(v)):
        return ""
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, (float, np.floating)) and float(v).is_integer() and abs(v) < 1e6:
        return str(int(v))
    return f"{v:.{digits}f}"


def pval(v):
    return S.fmt_p(float(v)) if v is not None and not pd.isna(v) else ""


def anova_rows(table: pd.DataFrame) -> list[dict]:
    rows = []
    resid_df = table.loc["Residual", "df"]
    for eff, r in table.iterrows():
        rows.append({"effect": eff, "ss": num(r["SS"], 3), "df": num(r["df"]),
                     "f": num(r["F"], 2), "p": pval(r["p"]), "eta": num(r["partial_eta2"], 3),
                     "apa": "" if eff == "Residual" else
                     f"F({num(r['df'])}, {num(resid_df)}) = {r['F']:.2f}, p {pval_apa(r['p'])}",
                     "sig": (not pd.isna(r["p"])) and r["p"] < 0.05})
    return rows


def anova_item(a, digits: int = 2) -> dict:
    """A factorial ANOVA (anova.AnovaResult) for the page: its cells, type II and III tables and APA lines
    (templates/studyapp/analysis/_report_anova.html)."""
    item = {"name": a.name, "ok": a.ok, "message": a.message, "note": a.note, "n": a.n, "factors": a.factors,
            "cells": [{"a": r[a.factors[0]], "b": r[a.factors[1]], "n": int(r["n"]), "mean": num(r["mean"], digits),
                       "sd": num(r["sd"], digits)} for _, r in a.cells.iterrows()] if a.cells is not None else []}
    if a.ok:
        item["type2"] = anova_rows(a.type2)
        item["type3"] = anova_rows(a.type3)
        item["apa"] = [(typ, "; ".join(f"{r['effect']}: {r['apa']}, partial η² = {r['eta']}" for r in rows if r["apa"]))
                       for typ, rows in (("type II", item["type2"]), ("type III", item["type3"]))]
    return item


def pval_apa(p):
    return "< .001" if p < 0.001 else f"= {S.fmt_p(p)}"


def cell(v):
    if isinstance(v, (bool, np.bool_)):
        return "yes" if v else "no"
    if v is None or (not isinstance(v, str) and pd.isna(v)):
        return ""
    if isinstance(v, (float, np.floating)):
        return num(v)
    return str(v)


# Listed only when a study has such participants, so a study without them reads as it always did.
ENDED_GROUPS = ((ST.RETURNED, "returned (the platform says)"), (ST.TIMED_OUT, "timed out"),
                (ST.SCREENED_OUT, "screened out (comprehension)"))


def participant_groups(table: pd.DataFrame) -> list[tuple[str, int]]:
    """(label, count) of every kind of participant in the analysis's table; the counts add up to its rows.

    By status (studyapp.status, the exports' column); a table made by hand without one counts its
    rows as complete unless ``excluded`` or ``completed == False`` says otherwise."""
    excluded = table["excluded"].astype(bool)
    if "status" in table:
        status = table["status"]
    else:
        done = table["completed"].astype(bool) if "completed" in table else pd.Series(True, index=table.index)
        status = pd.Series(np.where(excluded, ST.EXCLUDED, np.where(done, ST.COMPLETE, ST.INCOMPLETE)),
                           index=table.index)
    answered = table["n_answered"] > 0 if "n_answered" in table else pd.Series(False, index=table.index)
    attention = table["exclusion_reason"] == "failed attention check" if "exclusion_reason" in table else excluded
    incomplete, out = status == ST.INCOMPLETE, status == ST.EXCLUDED
    return [(ST.COMPLETE, int((status == ST.COMPLETE).sum())),
            ("incomplete (some tests answered)", int((incomplete & answered).sum())),
            ("incomplete (no test answered)", int((incomplete & ~answered).sum())),
            ("excluded (attention)", int((out & attention).sum())),
            ("excluded (by the researcher)", int((out & ~attention).sum())),
            ("declined (no consent)", int((status == ST.DECLINED).sum()))] + [
        (label, int((status == ended).sum())) for ended, label in ENDED_GROUPS if (status == ended).any()]


def welch_lines(welch: pd.DataFrame, digits: int = 2, tag: str = "") -> list[str]:
    """The Welch table's rows (comparisons.welch_tests) as the printed summary's lines, `tag` after each
    comparison's name (a show study's measure), `digits` for differences and intervals."""
    lines = []
    for _, w in welch.iterrows():
        if pd.isna(w["t"]):
            lines.append(f"Welch {w['comparison']}{tag}: {w['note']}")
        else:
            lines.append(f"Welch {w['comparison']}{tag}: diff = {w['diff']:.{digits}f} "
                         f"[{w['ci_low']:.{digits}f}, {w['ci_high']:.{digits}f}], t({w['df']:.1f}) = {w['t']:.2f}, "
                         f"p {pval_apa(w['p'])}, Holm p {pval_apa(w['p_holm'])}, d = {w['cohen_d']:.2f}")
    return lines


def welch_rows(welch: pd.DataFrame, digits: int = 2) -> list[dict]:
    """The Welch table's rows (comparisons.welch_tests), formatted; `digits` for means and differences."""
    rows = []
    for _, w in welch.iterrows():
        tested = not pd.isna(w["t"])
        rows.append({"comparison": w["comparison"], "n": f"{int(w['n_a'])} / {int(w['n_b'])}",
                     "means": f"{num(w['mean_a'], digits)} / {num(w['mean_b'], digits)}" if tested else "",
                     "diff": num(w["diff"], digits), "t": num(w["t"]), "df": num(w["df"], 1), "p": pval(w["p"]),
                     "p_holm": pval(w["p_holm"]), "d": num(w["cohen_d"]),
                     "ci": f"[{num(w['ci_low'], digits)}, {num(w['ci_high'], digits)}]" if tested else "",
                     "tested": tested, "note": w["note"],
                     "sig": tested and w["p_holm"] < 0.05, "stars": FIG.stars(w["p_holm"]) if tested else ""})
    return rows
