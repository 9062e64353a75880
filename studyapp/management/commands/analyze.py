"""``python manage.py analyze STUDY [--out DIR] [--compare A:B ...]``: the user-study analysis.

Writes ``index.html`` (tables + figures, self-contained), ``figures/*.png|svg`` and CSVs
(participants, answers, conditions, anova, welch, correlations, examples_per_cluster) to the
output folder (default ``var/analysis/<slug>/``) and prints a short summary.
"""
from __future__ import annotations

from pathlib import Path

from django.conf import settings
from django.core.management.base import BaseCommand, CommandError

from studyapp.analysis import data as D
from studyapp.analysis import report as R
from studyapp.analysis import stats as S
from studyapp.models import Participant, Study


class Command(BaseCommand):
    help = "Analyse a study: ANOVAs, Welch's t-tests, correlations, figures; writes an HTML report and CSVs."

    def add_arguments(self, parser):
        parser.add_argument("study", help="study slug (or numeric id)")
        parser.add_argument("--out", help="output folder (default: var/analysis/<slug>)")
        parser.add_argument("--compare", action="append", default=[], metavar="A:B",
                            help="extra Welch comparison of condition A vs B (repeatable; joins the Holm family): "
                                 "two of the study's conditions, a pair not already compared")
        parser.add_argument("--approx-star", default=S.APPROX_STAR_DEFAULT,
                            help="the approximate model that is approx* (default %(default)s)")
        parser.add_argument("--include-incomplete", action="store_true",
                            help="also analyse participants who did not finish")

    def handle(self, *args, study, out, compare, approx_star, include_incomplete, **opts):
        qs = Study.objects.filter(slug=study)
        if not qs.exists() and study.isdigit():
            qs = Study.objects.filter(pk=int(study))
        obj = qs.first()
        if obj is None:
            known = ", ".join(Study.objects.values_list("slug", flat=True)) or "none"
            raise CommandError(f"no study {study!r} (known: {known})")
        pairs = []
        for c in compare:
            a, sep, b = c.partition(":")
            if not sep or not a or not b:
                raise CommandError(f"--compare takes A:B, got {c!r}")
            pairs.append((a, b))
        try:
            analysis = D.analyze_study(obj, include_incomplete=include_incomplete, extra_comparisons=pairs,
                                       approx_star=approx_star)
        except S.ConditionError as exc:  # aliased conditions, an unknown approx*, a repeated or unknown pair
            raise CommandError(str(exc)) from None
        folder = Path(out) if out else Path(getattr(settings, "VAR_DIR", Path("var"))) / "analysis" / obj.slug
        written = R.write_report(analysis, folder, title=f"Analysis of {obj.name}")
        self.stdout.write(f"Study {obj.slug}: " + R.headline(analysis)[0])
        if not include_incomplete:  # say who is not in the headline's count
            unfinished = (Participant.objects.filter(study=obj, completed_at__isnull=True)
                          .exclude(platform=Participant.PREVIEW).count())
            if unfinished:
                self.stdout.write(f"  {unfinished} unfinished participants left out (--include-incomplete "
                                  "names them and analyses those who answered a test)")
        for line in R.headline(analysis)[1:]:
            self.stdout.write("  " + line)
        self.stdout.write(self.style.SUCCESS(
            f"Report: {written['html']}  ({len(written['csv'])} CSV files, {len(written['figures'])} figure files)"))
