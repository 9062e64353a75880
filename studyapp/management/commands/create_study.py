"""Create a study from a JSON spec of conditions (see studyapp/studies.py for the format)."""
import json
from pathlib import Path

from django.core.management.base import BaseCommand, CommandError

from studyapp.studies import SpecError, build_study


class Command(BaseCommand):
    help = "Create a study from a JSON spec: conditions (name + env_ids), optional table and test set."

    def add_arguments(self, parser):
        parser.add_argument("spec", type=Path, help="JSON file")
        parser.add_argument("--replace", action="store_true", help="Replace a study with the same slug "
                            "(refused once it has participants).")

    def handle(self, spec, replace, **options):
        try:
            data = json.loads(spec.read_text())
        except (OSError, json.JSONDecodeError) as exc:
            raise CommandError(f"cannot read spec {spec}: {exc}") from exc
        try:
            study = build_study(data, replace=replace)
        except (SpecError, ValueError) as exc:
            raise CommandError(str(exc)) from exc
        names = ", ".join(c.name for c in study.conditions.all())
        self.stdout.write(f"study {study.slug}: {study.conditions.count()} conditions ({names}), "
                          f"{len(study.test_set)} tests, source {study.source.get('kind')}")
        self.stdout.write(f"participant link: {study.get_absolute_url()}")
