"""``python manage.py export_study STUDY {wide,long,dictionary} [--out FILE] [--pseudonymise]``: a study's CSV export
without the web server, written piece by piece as the dashboard streams it (studyapp.data.exports)."""
from __future__ import annotations

from django.core.management.base import BaseCommand, CommandError

from studyapp.data import exports
from studyapp.models import Study


class Command(BaseCommand):
    help = "Write a study's long or wide CSV (or the data dictionary) to a file or standard output."

    def add_arguments(self, parser):
        parser.add_argument("study", help="study slug")
        parser.add_argument("kind", choices=["wide", "long", "dictionary"])
        parser.add_argument("--out", help="file to write (default: standard output)")
        parser.add_argument("--pseudonymise", action="store_true",
                            help="platform and session ids replaced by stable pseudonyms (for sharing)")

    def handle(self, *args, study, kind, out, pseudonymise, **opts):
        obj = Study.objects.filter(slug=study).first()
        if obj is None:
            known = ", ".join(Study.objects.values_list("slug", flat=True)) or "none"
            raise CommandError(f"no study {study!r} (known: {known})")
        pieces = (exports.STREAMS[kind](obj, pseudonymise) if kind in exports.STREAMS
                  else [exports.dictionary_csv(obj)])
        if not out:
            for piece in pieces:
                self.stdout.write(piece, ending="")
            return
        with open(out, "w", encoding="utf-8", newline="") as f:  # the rows already end in the CSV \r\n
            for piece in pieces:
                f.write(piece)
        self.stderr.write(f"wrote {out}")
