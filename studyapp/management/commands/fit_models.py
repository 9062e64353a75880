"""``python manage.py fit_models STUDY [--models A,B] [--csv FILE] [--figure FILE]``: which learner model
explains the study's answers (docs/analysis.md "Fitting learner models").

Prints the models ranked by cross-validated log-likelihood with τ / λ, lapse rate, ΔBIC and the
random-effects exceedance probability (tied models share a rank and are named as tied); writes the table as
CSV and the predicted-vs-observed accuracy figure
(default ``var/analysis/<slug>/models.csv`` and ``models.png``).
"""
from __future__ import annotations

from pathlib import Path

from django.conf import settings
from django.core.management.base import BaseCommand, CommandError

from studyapp.analysis.modelfit import ModelFitError, accuracy_figure, fit_study
from studyapp.models import Study
from teaching.api import TIE_TOLERANCE


def format_value(row: dict) -> str:
    if row["value"] is None or not row["param"]:
        return "-"
    return f"{'τ' if row['param'] == 'tau' else 'λ'} = {row['value']:.3g}"


def tie_note(rows: list[dict]) -> str:
    """The footnote of a ranking with ties: which models tie (their order is the registry's and means
    nothing) and that the exceedance probability (*) is split among them, with each tie's together."""
    seen, groups = set(), []
    for r in rows:
        if r["tied_with"] and r["model"] not in seen:
            members = [r["model"], *r["tied_with"]]
            seen.update(members)
            ep = r["tie_exceedance"]
            together = "" if ep != ep else f", exceedance together {ep:.3f}"
            groups.append(f"{', '.join(members)} (rank {r['rank']}{together})")
    return (f"Tied (cross-validated log-likelihoods within {TIE_TOLERANCE:g}; their order means nothing; "
            "* the exceedance probability is split among tied models): " + "; ".join(groups))


class Command(BaseCommand):
    help = "Fit every learner model to a study's answers and rank them (cross-validated, BIC, model selection)."

    def add_arguments(self, parser):
        parser.add_argument("study", help="study slug (or numeric id)")
        parser.add_argument("--models", help="comma-separated learner models (default: every one)")
        parser.add_argument("--csv", help="where to write the table (default var/analysis/<slug>/models.csv)")
        parser.add_argument("--figure", help="where to write the figure (default var/analysis/<slug>/models.png)")

    def handle(self, *args, study, models, csv, figure, **opts):
        obj = Study.objects.filter(slug=study).first() or (
            Study.objects.filter(pk=int(study)).first() if study.isdigit() else None)
        if obj is None:
            known = ", ".join(Study.objects.values_list("slug", flat=True)) or "none"
            raise CommandError(f"no study {study!r} (known: {known})")
        names = [m.strip() for m in models.split(",") if m.strip()] if models else None
        try:
            fit = fit_study(obj, names)
        except ModelFitError as exc:
            raise CommandError(f"{obj.slug}: {exc}") from None
        folder = Path(getattr(settings, "VAR_DIR", Path("var"))) / "analysis" / obj.slug
        csv_path, fig_path = Path(csv or folder / "models.csv"), Path(figure or folder / "models.png")
        rows = fit.comparison.rows()
        self.stdout.write(f"Study {obj.slug}: {fit.comparison.n_participants} analysed participants, "
                          f"{rows[0]['n_answers']} answers; models ranked by leave-one-participant-out log-likelihood")
        self.stdout.write(f"{'model':30s} {'τ / λ':>12s} {'lapse':>6s} {'log-lik':>9s} {'CV log-lik':>10s} "
                          f"{'ΔBIC':>7s} {'exceed.':>8s} {'ρ rating':>8s} {'rank':>4s}")
        for r in rows:
            rho = "" if r["rating_rho"] is None else f"{r['rating_rho']:.2f}"
            mark = "*" if r["tied_with"] else " "
            ep = "" if r["exceedance"] != r["exceedance"] else f"{r['exceedance']:.3f}{mark}"
            tie = f"  tied with {', '.join(r['tied_with'])}" if r["tied_with"] else ""
            self.stdout.write(f"{r['model']:30s} {format_value(r):>12s} {r['lapse']:6.3f} {r['log_lik']:9.1f} "
                              f"{r['cv_log_lik']:10.1f} {r['delta_bic']:7.1f} {ep:>8s} {rho:>8s} {r['rank']:4d}{tie}")
        if any(r["tied_with"] for r in rows):
            self.stdout.write(tie_note(rows))
        csv_path.parent.mkdir(parents=True, exist_ok=True)
        csv_path.write_text(fit.csv())
        fig_path.parent.mkdir(parents=True, exist_ok=True)
        accuracy_figure(fit).savefig(fig_path, dpi=110)
        self.stdout.write(self.style.SUCCESS(f"Table: {csv_path}  Figure: {fig_path}"))
