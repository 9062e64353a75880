"""HTML report and CSV export of an :class:`~studyapp.analysis.stats.Analysis`.

The report is an HTML *fragment* (``templates/studyapp/analysis/report.html``) so the
dashboard can embed it; :func:`write_report` wraps it in a standalone page for
``manage.py analyze``.  Figures are embedded as PNG data URIs (the fragment is
self-contained) and also written as files by :func:`write_report`.

A show study's analysis (shown.ShowAnalysis) has its own report, :mod:`studyapp.analysis.report_show`,
which the functions here hand it to.

Uses Django's template engine (settings must be configured) but no models.
"""
from __future__ import annotations

import re
from pathlib import Path

import pandas as pd
from django.template.loader import render_to_string

from .. import status as ST
from . import figures as FIG
from . import report_show as RS
from . import stats as S
from .formatting import anova_item, cell, num, participant_groups, pval, pval_apa, welch_lines, welch_rows
from .shown import ShowAnalysis


def context(analysis: S.Analysis, title: str = "Study analysis", figures: dict | None = None) -> dict:
    """Everything the template needs, already formatted."""
    if figures is None:
        figures = {k: FIG.data_uri(FIG.to_bytes(f)) for k, f in FIG.all_figures(analysis).items()}
    summ = analysis.summary
    summary_rows = [{"condition": S.label(c, analysis.approx_star), "recruited": int(r["n_recruited"]),
                     "excluded": int(r["n_excluded"]), "n": int(r["n"]), "mean": num(r["mean"]),
                     "sd": num(r["sd"]), "se": num(r["se"]),
                     "n_examples": int(analysis.examples_per_cluster.loc[c].sum())
                     if c in analysis.examples_per_cluster.index else ""}
                    for c, r in summ.iterrows()]
    anovas = [anova_item(a) for a in analysis.anovas]
    welch = welch_rows(analysis.welch)
    cors = [{"name": c.name, "level": c.level, "n": c.n, "r": num(c.r), "p": pval(c.p),
             "ci": f"[{num(c.ci_low)}, {num(c.ci_high)}]" if c.ok else "", "ok": c.ok, "message": c.message}
            for c in analysis.correlations]
    epc = analysis.examples_per_cluster
    p = analysis.participants
    score_cols = sorted([c for c in p.columns if re.fullmatch(r"score_\d+", c)], key=lambda c: int(c[6:]))
    cols = ["participant_id", "condition", "model", "distance", "determinism", "coverage", "n_examples",
            *score_cols, "mean_score", "attention_ok", "excluded"]
    part_rows = [[cell(r[c]) for c in cols] + [bool(r["excluded"])] for _, r in p[cols].iterrows()]
    return {
        "title": title, "approx_star": analysis.approx_star,
        "n_participants": len(p), "n_included": analysis.n_included, "n_excluded": analysis.n_excluded,
        "messages": analysis.messages, "summary": summary_rows, "anovas": anovas, "welch": welch,
        "correlations": cors, "figures": figures,
        "clusters": [analysis.clusters.name(c) for c in epc.columns],
        "examples": [{"condition": S.label(c, analysis.approx_star), "counts": [int(v) for v in epc.loc[c]],
                      "total": int(epc.loc[c].sum())} for c in epc.index],
        "participant_columns": cols, "participant_rows": part_rows,
        "headline": headline(analysis), "learning": learning_rows(analysis),
        "by_difficulty": [{"condition": S.label(r["condition"], analysis.approx_star), "difficulty": r["difficulty"],
                           "n": int(r["n"]), "answers": int(r["n_answers"]), "mean": num(r["mean"]),
                           "sd": num(r["sd"]), "se": num(r["se"]), "accuracy": num(r["accuracy"])}
                          for _, r in analysis.by_difficulty.iterrows()],
    }


def learning_rows(analysis: S.Analysis) -> list[dict]:
    """The learning-curve table's rows, formatted (none without closed-loop check answers)."""
    return [{"condition": S.label(r["condition"], analysis.approx_star), "check": int(r["check_number"]),
             "n": int(r["n"]), "n_correct": int(r["n_correct"]), "p": num(r["p_correct"]),
             "ci": f"[{num(r['ci_low'])}, {num(r['ci_high'])}]", "mean": num(r["mean_score"]),
             "se": num(r["se_score"]), "examples": num(r["mean_examples"], 1)}
            for _, r in analysis.learning.iterrows()]


def headline(analysis: S.Analysis | ShowAnalysis) -> list[str]:
    """A few lines of plain-text summary (printed by ``manage.py analyze``)."""
    if isinstance(analysis, ShowAnalysis):
        return RS.headline(analysis)
    groups = ", ".join(f"{n} {label}" for label, n in participant_groups(analysis.participants)
                       if n or label == ST.COMPLETE)
    lines = [f"{len(analysis.participants)} participants: {groups}; {analysis.n_included} analysed; "
             f"approx* = {analysis.approx_star}"]
    for a in analysis.anovas:
        if not a.ok:
            lines.append(a.message)
            continue
        parts = [f"{eff}: F({r['df']:.0f}, {a.type3.loc['Residual', 'df']:.0f}) = {r['F']:.2f}, p {pval_apa(r['p'])}"
                 for eff, r in a.type3.iterrows() if eff != "Residual"]
        lines.append(f"ANOVA {a.name} [type III]: " + "; ".join(parts))
    lines += welch_lines(analysis.welch)
    for c in analysis.correlations:
        if c.ok:
            lines.append(f"Pearson {c.name} ({c.level}): r = {c.r:.2f} [{c.ci_low:.2f}, {c.ci_high:.2f}], "
                         f"p {pval_apa(c.p)}, n = {c.n}")
        else:
            lines.append(f"Pearson {c.name} ({c.level}): {c.message}")
    for cond, curve in analysis.learning.groupby("condition", sort=False):
        lines.append(f"Learning curve {cond} (chose θ* at check k): " + "; ".join(
            f"{int(r['check_number'])}: {int(r['n_correct'])}/{int(r['n'])} = {r['p_correct']:.2f} "
            f"[{r['ci_low']:.2f}, {r['ci_high']:.2f}]" for _, r in curve.iterrows()))
    return lines


def render_fragment(analysis: S.Analysis | ShowAnalysis, title: str = "Study analysis",
                    figures: dict | None = None) -> str:
    if isinstance(analysis, ShowAnalysis):
        return RS.render_fragment(analysis, title)
    return render_to_string("studyapp/analysis/report.html", context(analysis, title, figures))


def render_page(analysis: S.Analysis | ShowAnalysis, title: str = "Study analysis", figures: dict | None = None) -> str:
    if isinstance(analysis, ShowAnalysis):
        return RS.render_page(analysis, title)
    ctx = context(analysis, title, figures)
    ctx["fragment"] = render_to_string("studyapp/analysis/report.html", ctx)
    return render_to_string("studyapp/analysis/report_page.html", ctx)


def write_csvs(analysis: S.Analysis | ShowAnalysis, out: Path) -> list[Path]:
    if isinstance(analysis, ShowAnalysis):
        return RS.write_csvs(analysis, out)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    written = []

    def w(df, name, index=False):
        path = out / name
        df.to_csv(path, index=index)
        written.append(path)

    w(analysis.participants, "participants.csv")
    w(analysis.per_test, "answers.csv")
    w(analysis.summary, "conditions.csv", index=True)
    w(analysis.welch, "welch.csv")
    w(analysis.correlation_table(), "correlations.csv")
    w(analysis.examples_per_cluster, "examples_per_cluster.csv", index=True)
    if len(analysis.learning):
        w(analysis.learning, "learning_curves.csv")
    if len(analysis.by_difficulty):
        w(analysis.by_difficulty, "scores_by_difficulty.csv")
    anova_rows = []
    for a in analysis.anovas:
        if a.ok:
            for typ, t in (("II", a.type2), ("III", a.type3)):
                d = t.reset_index()
                d.insert(0, "type", typ)
                d.insert(0, "anova", a.name)
                anova_rows.append(d)
        else:
            anova_rows.append(pd.DataFrame([{"anova": a.name, "type": "", "effect": "", "note": a.message}]))
        if a.cells is not None:
            cells = a.cells.copy()
            cells.insert(0, "anova", a.name)
            anova_rows.append(cells.rename(columns={a.factors[0]: "level_a", a.factors[1]: "level_b"})
                              .assign(type="cell counts"))
    w(pd.concat(anova_rows, ignore_index=True) if anova_rows else pd.DataFrame(), "anova.csv")
    return written


def write_report(analysis: S.Analysis | ShowAnalysis, out, title: str = "Study analysis") -> dict:
    """Write index.html (self-contained), figure PNG/SVG files and the CSVs to ``out`` (a show study's:
    report_show.write_report)."""
    if isinstance(analysis, ShowAnalysis):
        return RS.write_report(analysis, out, title)
    out = Path(out)
    (out / "figures").mkdir(parents=True, exist_ok=True)
    uris, files = {}, []
    for name, fig in FIG.all_figures(analysis).items():
        svg = out / "figures" / f"{name}.svg"
        fig.savefig(svg, format="svg", bbox_inches="tight")
        png = FIG.to_bytes(fig)  # closes the figure
        (out / "figures" / f"{name}.png").write_bytes(png)
        uris[name] = FIG.data_uri(png)
        files += [svg, out / "figures" / f"{name}.png"]
    html = render_page(analysis, title, uris)
    (out / "index.html").write_text(html, encoding="utf-8")
    csvs = write_csvs(analysis, out)
    return {"html": out / "index.html", "figures": files, "csv": csvs}
