"""``python manage.py mark_returned SLUG (ID ... | --file F)``: mark the participants a recruiting platform
lists as returned (Prolific's returned submissions; MTurk's returned assignments) as returned, freeing their
places at once (studyapp.participant.outcomes)."""
from __future__ import annotations

from pathlib import Path

from django.core.management.base import BaseCommand, CommandError

from studyapp.models import Study
from studyapp.participant import outcomes


class Command(BaseCommand):
    help = "Mark participants returned by platform id (PROLIFIC_PID, workerId) or session id; frees their places."

    def add_arguments(self, parser):
        parser.add_argument("study", help="the study's slug")
        parser.add_argument("ids", nargs="*", help="platform ids or session ids")
        parser.add_argument("--file", help="a file of ids: one per line, or separated by commas or spaces")

    def handle(self, *args, study, ids, file, **opts):
        where = Study.objects.filter(slug=study).first()
        if where is None:
            raise CommandError(f"no study {study!r}")
        text = " ".join(ids)
        if file:
            try:
                text += "\n" + Path(file).read_text(encoding="utf-8")
            except (OSError, UnicodeDecodeError) as exc:
                raise CommandError(f"cannot read {file}: {exc}") from None
        try:
            parsed = outcomes.parse_ids(text)
        except ValueError as exc:
            raise CommandError(str(exc)) from None
        if not parsed:
            raise CommandError("no ids given: name them, or --file with one per line")
        self.stdout.write(outcomes.mark_returned(where, parsed).summary())
