"""Create a study from a JSON spec (studyapp/researcher/studies.py has the format), or from the output
directory of `python -m teaching teach` (its sequences.json and test_set.json):

    python manage.py create_study spec.json
    python manage.py create_study var/teaching/demo --slug pilot-1 --completion-code C1ABCDEF

Options given on the command line override the spec's fields.  Every problem is one line.
"""
import json
from pathlib import Path

from django.core.management.base import BaseCommand, CommandError

from studyapp.models import Study
from studyapp.researcher.studies import SpecError, build_study, spec_from_teach


def read_spec(path: Path, table=None) -> dict:
    """A spec from a JSON file, or the table, conditions and test set of a teach output."""
    if path.is_dir() or path.name == "sequences.json":
        return spec_from_teach(path, table=table)
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise SpecError(f"cannot read spec {path}: {exc}") from None
    if isinstance(data, dict) and isinstance(data.get("conditions"), dict) and "model_sequences" in data:
        return spec_from_teach(path, table=table)  # a sequences.json under another name
    if table and isinstance(data, dict):
        data["table"] = str(table)
    return data


class Command(BaseCommand):
    help = ("Create a study from a JSON spec (conditions + env_ids, optional table and test set) or from "
            "the output directory of `python -m teaching teach`.")

    def add_arguments(self, parser):
        parser.add_argument("spec", type=Path, help="JSON spec, or a `python -m teaching teach` output directory")
        parser.add_argument("--slug", help="the study's URL name (required for a teach output)")
        parser.add_argument("--name", help="title shown to researchers")
        parser.add_argument("--table", help="trajectory table (default: the one the teach output names)")
        parser.add_argument("--completion-code", help="the platform's completion code (Prolific)")
        parser.add_argument("--recruitment", choices=[k for k, _ in Study.RECRUITMENTS])
        parser.add_argument("--target", type=int, help="participants wanted per condition")
        parser.add_argument("--closed", action="store_true", help="create it closed (open it on the dashboard)")
        parser.add_argument("--replace", action="store_true", help="Replace a study with the same slug "
                            "(refused once it has participants).")

    def handle(self, spec, replace, **options):
        try:
            data = read_spec(spec, options["table"])
            if isinstance(data, dict):
                overrides = {"slug": options["slug"], "name": options["name"],
                             "target_per_condition": options["target"], "completion_code": options["completion_code"],
                             "recruitment": options["recruitment"]}
                data.update({k: v for k, v in overrides.items() if v is not None})
                if options["closed"]:
                    data["is_open"] = False
                if not data.get("slug"):
                    raise SpecError("the study needs a slug: give --slug NAME (letters, digits, - and _)")
            study = build_study(data, replace=replace)
        except ValueError as exc:  # SpecError, and the ValueErrors of the trajectory builders
            raise CommandError(str(exc)) from None
        names = ", ".join(c.name for c in study.conditions.all())
        self.stdout.write(f"study {study.slug}: {study.conditions.count()} conditions ({names}), "
                          f"{len(study.test_set)} tests, source {study.source.get('kind')}")
        self.stdout.write(f"participant link: {study.get_absolute_url()}")
