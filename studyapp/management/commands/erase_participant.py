"""``python manage.py erase_participant PID [--study SLUG] [--yes]``: erase a participant's data at their
request (studyapp.data.privacy): every participant row of that platform id, with everything stored under it."""
from __future__ import annotations

from django.core.management.base import BaseCommand, CommandError

from studyapp.data import privacy
from studyapp.models import Study


class Command(BaseCommand):
    help = "Erase every participant row of a platform id (PROLIFIC_PID or workerId) and all stored under it."

    def add_arguments(self, parser):
        parser.add_argument("platform_id", help="the participant's PROLIFIC_PID or MTurk workerId")
        parser.add_argument("--study", help="only in this study (slug); default: every study")
        parser.add_argument("--yes", action="store_true", help="erase without asking")

    def handle(self, *args, platform_id, study, yes, **opts):
        where = None
        if study:
            where = Study.objects.filter(slug=study).first()
            if where is None:
                raise CommandError(f"no study {study!r}")
        try:
            found = privacy.find(platform_id, where)
        except privacy.ErasureError as exc:
            raise CommandError(str(exc)) from None
        self.stdout.write(f"to erase: {found.summary()}")
        if not yes and input("Erase them for good? Type 'yes': ").strip().lower() != "yes":
            raise CommandError("nothing was erased")
        try:
            gone = privacy.erase(platform_id, where)
        except privacy.ErasureError as exc:
            raise CommandError(str(exc)) from None
        self.stdout.write(f"erased {gone.summary()}")
