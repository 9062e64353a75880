"""Write the study spec's JSON Schema (studyapp/researcher/specjson.py) for editors: manage.py spec_schema [--check]."""
import json
from pathlib import Path

from django.core.management.base import BaseCommand, CommandError

from studyapp.researcher.specjson import spec_schema

PUBLISHED = Path(__file__).resolve().parents[2] / "spec.schema.json"


def rendered() -> str:
    return json.dumps(spec_schema(), indent=2, ensure_ascii=False) + "\n"


class Command(BaseCommand):
    help = "Write studyapp/spec.schema.json from the spec's declared fields (--check: only say whether it is current)."

    def add_arguments(self, parser):
        parser.add_argument("--check", action="store_true", help="exit 1 if the published schema is out of date")

    def handle(self, *args, check=False, **options):
        if check:
            if not PUBLISHED.exists() or PUBLISHED.read_text(encoding="utf-8") != rendered():
                raise CommandError(f"{PUBLISHED.name} is out of date: run `python manage.py spec_schema`")
            self.stdout.write(f"{PUBLISHED.name} is current")
            return
        PUBLISHED.write_text(rendered(), encoding="utf-8")
        self.stdout.write(f"wrote {PUBLISHED}")
