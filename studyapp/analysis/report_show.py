"""HTML report, printed summary and CSVs of a show study's analysis (:class:`~studyapp.analysis.shown.ShowAnalysis`).

The same files as a choice study's report (report.py, which hands a ShowAnalysis here), with each table
carrying its measure: ``participants.csv`` (regret_<i>, optimal_<i>, mean_regret, share_optimal),
``answers.csv``, ``conditions.csv``, ``anova.csv`` and ``welch.csv`` (a ``measure`` column), ``by_test.csv``
and ``by_level.csv`` (each condition's answers per test and per difficulty level), ``learning_curves.csv``
(closed-loop conditions' checks, where any was answered), and
``index.html`` (``templates/studyapp/analysis/show_report.html``).  No figures: the choice report's figures
are of confidence scores.
"""
from __future__ import annotations

import re
from pathlib import Path

import pandas as pd
from django.template.loader import render_to_string

from .. import status as ST
from . import stats as S
from .formatting import anova_item, anova_rows, cell, num, participant_groups, pval_apa, welch_lines, welch_rows
from .shown import ShowAnalysis

# a share is a fraction of tests: more digits than a regret's mean would need to tell conditions apart
DIGITS = {"mean_regret": 2, "share_optimal": 3}


def _per_test(columns, prefix: str) -> list[str]:
    return sorted([c for c in columns if re.fullmatch(prefix + r"_\d+", c)], key=lambda c: int(c.rpartition("_")[2]))


def participant_columns(table: pd.DataFrame) -> list[str]:
    return ["participant_id", "condition", "model", "distance", "determinism", "coverage", "n_examples",
            *_per_test(table.columns, "regret"), *_per_test(table.columns, "optimal"), "n_answered",
            "mean_regret", "share_optimal", "attention_ok", "excluded"]


def measure_context(m, approx_star: str) -> dict:
    digits = DIGITS.get(m.column, 2)
    a = m.anova
    item = {"column": m.column, "name": m.name,
            "summary": [{"condition": S.label(c, approx_star), "recruited": int(r["n_recruited"]),
                         "excluded": int(r["n_excluded"]), "n": int(r["n"]), "mean": num(r["mean"], digits),
                         "sd": num(r["sd"], digits), "se": num(r["se"], digits)} for c, r in m.summary.iterrows()],
            "anova": {"name": a.name, "ok": a.ok, "message": a.message,
                      "cells": [{"condition": S.label(r["condition"], approx_star), "n": int(r["n"]),
                                 "mean": num(r["mean"], digits), "sd": num(r["sd"], digits)}
                                for _, r in a.cells.iterrows()]},
            "welch": welch_rows(m.welch, digits),
            "factorial": [anova_item(f, digits) for f in m.factorial]}
    if a.ok:
        rows = anova_rows(a.type2)
        item["anova"]["rows"] = rows
        item["anova"]["apa"] = "; ".join(r["apa"] + f", partial η² = {r['eta']}" for r in rows if r["apa"])
    return item


def summary_rows(df: pd.DataFrame, approx_star: str) -> list[dict]:
    """by_test / by_level rows for the page: numbers at the report's digits, conditions by their labels."""
    return [{**{k: r[k] for k in ("test_index", "cluster", "difficulty") if k in r},
             "condition": S.label(r["condition"], approx_star), "n": int(r["n"]),
             "mean_regret": num(r["mean_regret"], DIGITS["mean_regret"]), "sd_regret": num(r["sd_regret"], 2),
             "share_optimal": num(r["share_optimal"], DIGITS["share_optimal"])} for _, r in df.iterrows()]


def context(analysis: ShowAnalysis, title: str = "Study analysis") -> dict:
    p = analysis.participants
    cols = participant_columns(p)
    return {"title": title, "approx_star": analysis.approx_star, "n_participants": len(p),
            "n_included": analysis.n_included, "n_excluded": analysis.n_excluded, "messages": analysis.messages,
            "measures": [measure_context(m, analysis.approx_star) for m in analysis.measures],
            "skipped": list(analysis.skipped), "participant_columns": cols,
            "participant_rows": [[cell(r[c]) for c in cols] + [bool(r["excluded"])] for _, r in p[cols].iterrows()],
            "headline": headline(analysis),
            "theta_star_l1": None if analysis.theta_star_l1 is None else f"{analysis.theta_star_l1:g}",
            "by_test": summary_rows(analysis.by_test, analysis.approx_star),
            "by_level": summary_rows(analysis.by_level, analysis.approx_star),
            "learning": [{"condition": S.label(r["condition"], analysis.approx_star),
                          "check": int(r["check_number"]), "n": int(r["n"]), "n_optimal": int(r["n_optimal"]),
                          "p_optimal": num(r["p_optimal"], 2), "ci": f"[{num(r['ci_low'], 2)}, {num(r['ci_high'], 2)}]",
                          "mean_regret": num(r["mean_regret"], 2), "se_regret": num(r["se_regret"], 2),
                          "examples": num(r["mean_examples"], 1)} for _, r in analysis.learning.iterrows()]}


def render_fragment(analysis: ShowAnalysis, title: str = "Study analysis") -> str:
    return render_to_string("studyapp/analysis/show_report.html", context(analysis, title))


def render_page(analysis: ShowAnalysis, title: str = "Study analysis") -> str:
    ctx = context(analysis, title)
    ctx["fragment"] = render_to_string("studyapp/analysis/show_report.html", ctx)
    return render_to_string("studyapp/analysis/report_page.html", ctx)


def headline(analysis: ShowAnalysis) -> list[str]:
    """A few lines of plain-text summary (printed by ``manage.py analyze``)."""
    groups = ", ".join(f"{n} {label}" for label, n in participant_groups(analysis.participants)
                       if n or label == ST.COMPLETE)
    lines = [f"{len(analysis.participants)} participants: {groups}; {analysis.n_included} analysed; "
             f"show study (measures: {', '.join(m.name for m in analysis.measures)})"]
    for m in analysis.measures:
        a = m.anova
        if a.ok:
            r, resid = a.type2.loc["condition"], a.type2.loc["Residual", "df"]
            lines.append(f"ANOVA of the {m.name} across conditions: F({r['df']:.0f}, {resid:.0f}) = {r['F']:.2f}, "
                         f"p {pval_apa(r['p'])}")
        else:
            lines.append(a.message)
        for f in m.factorial:
            if f.ok:
                effects = "; ".join(f"{effect} F({r['df']:.0f}, {f.type2.loc['Residual', 'df']:.0f}) = {r['F']:.2f}, "
                                    f"p {pval_apa(r['p'])}" for effect, r in f.type2.drop(index="Residual").iterrows())
                lines.append(f"{f.name} of the {m.name} (type II): {effects}")
            else:
                lines.append(f.message)
        lines += welch_lines(m.welch, digits=3, tag=f" ({m.name})")
    for cond, curve in analysis.learning.groupby("condition", sort=False):
        lines.append(f"Learning curve {cond} (showed an optimal way at check k): " + "; ".join(
            f"{int(r['check_number'])}: {int(r['n_optimal'])}/{int(r['n'])} = {r['p_optimal']:.2f} "
            f"[{r['ci_low']:.2f}, {r['ci_high']:.2f}], mean regret {r['mean_regret']:.2f}"
            for _, r in curve.iterrows()))
    return lines


def _with_measure(df: pd.DataFrame, m) -> pd.DataFrame:
    out = df.copy()
    out.insert(0, "measure", m.name)
    return out


def write_csvs(analysis: ShowAnalysis, out: Path) -> list[Path]:
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    anova = []
    for m in analysis.measures:
        a = m.anova
        if a.ok:
            anova.append(_with_measure(a.type2.reset_index(), m))
        else:
            anova.append(pd.DataFrame([{"measure": m.name, "effect": "", "note": a.message}]))
        anova.append(_with_measure(a.cells, m).assign(type="cell counts"))
        for f in m.factorial:  # the paper's designs, type II and III, each row naming its ANOVA
            if f.ok:
                anova += [_with_measure(t.reset_index(), m).assign(anova=f.name, type=typ)
                          for typ, t in (("type II", f.type2), ("type III", f.type3))]
            else:
                anova.append(pd.DataFrame([{"measure": m.name, "anova": f.name, "effect": "", "note": f.message}]))
    tables = {"participants.csv": analysis.participants, "answers.csv": analysis.answers,
              "conditions.csv": pd.concat([_with_measure(m.summary.reset_index(), m) for m in analysis.measures],
                                          ignore_index=True),
              "welch.csv": pd.concat([_with_measure(m.welch, m) for m in analysis.measures], ignore_index=True),
              "anova.csv": pd.concat(anova, ignore_index=True),
              "by_test.csv": analysis.by_test, "by_level.csv": analysis.by_level}
    if len(analysis.learning):
        tables["learning_curves.csv"] = analysis.learning
    written = []
    for name, df in tables.items():
        df.to_csv(out / name, index=False)
        written.append(out / name)
    return written


def write_report(analysis: ShowAnalysis, out, title: str = "Study analysis") -> dict:
    """Write index.html (self-contained) and the CSVs to ``out``; no figures (the module's docstring)."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "index.html").write_text(render_page(analysis, title), encoding="utf-8")
    return {"html": out / "index.html", "figures": [], "csv": write_csvs(analysis, out)}
