"""Build a study's teaching sequences on Celery workers: one task per condition, then the test set.

    python manage.py build_study --preset demo --slug demo-study --wait
    python manage.py build_study --table /shared/tables/paper --slug paper-2026 \\
        --hyper det-euclidean=0.1 --conditions exact,det-euclidean,random --wait
    python manage.py build_study --preset demo --slug field --conditions exact,scot,bec-scaffold:k=2,highlights:k=5 \\
        --test-difficulty high --wait
    python manage.py build_study --preset demo --slug loop --conditions det-euclidean \\
        --closed-loop closed-loop:model=det-euclidean,check_every=2,feedback=yes --wait

The study is created closed with empty conditions; each condition's task
freezes its sequence (θ*'s trajectories) on the condition, the last task
stores the test set and opens the study (--closed keeps it closed).
"""
from __future__ import annotations

from pathlib import Path

from django.core.management.base import BaseCommand, CommandError

from precompute import jobs
from precompute.study import StudyJobError, create_study_job, parse_closed_loop
from studyapp.researcher.specschema import JOB_FIELDS, STUDY_FIELDS, SpecError, check_job
from teaching.api import CONDITIONS, TableError, parse_hyperparameters

from ._waiting import wait_for_job


def split_conditions(text: str) -> list[str]:
    """--conditions' comma-separated list, where a selector's own KEY=VALUE,KEY=VALUE parameters keep their
    commas: an item with "=" and no ":" continues the selector before it ("bec-scaffold:k=2,levels=3")."""
    out: list[str] = []
    for item in filter(None, (i.strip() for i in text.split(","))):
        if "=" in item and ":" not in item and out and ":" in out[-1]:
            out[-1] += "," + item
        else:
            out.append(item)
    return out


def _help(field) -> str:
    """A study spec field's help and default, as the schema declares them (studyapp/researcher/specschema.py)."""
    return f"{field.help} (default {field.default})"


class Command(BaseCommand):
    help = "Build a study's teaching sequences and test set on Celery workers."

    def add_arguments(self, parser):
        src = parser.add_mutually_exclusive_group(required=True)
        src.add_argument("--table", help="trajectory table directory")
        src.add_argument("--preset", help="use the table precompute_table built for this preset "
                                          "($TABLES_DIR/<preset>)")
        parser.add_argument("--slug", required=True, help="the study's slug (its URL)")
        parser.add_argument("--name", help="the study's title (default: the slug)")
        parser.add_argument("--seed", type=int, help=_help(JOB_FIELDS["seed"]))
        parser.add_argument("--approx-star", help=_help(JOB_FIELDS["approx_star"]))
        parser.add_argument("--hyper", action="append", default=[], metavar="MODEL=VALUE",
                            help="fix τ or λ of a model instead of sweeping (repeatable)")
        parser.add_argument("--conditions", metavar="SELECTOR[:KEY=VALUE,...],...",
                            help="comma-separated registered selectors, each optionally with its parameters, "
                                 "e.g. exact,scot,bec-scaffold:k=2,highlights:k=5 (teaching's --selector form; "
                                 f"default: the paper's {len(CONDITIONS)})")
        parser.add_argument("--test-difficulty", help=_help(JOB_FIELDS["test_difficulty"]))
        parser.add_argument("--test-kind", help=_help(JOB_FIELDS["test_kind"]))
        parser.add_argument("--closed-loop", action="append", default=[], metavar="NAME[:SETTING=VALUE,...]",
                            help="a closed-loop condition NAME (repeatable): each participant's next example "
                                 "chosen from their answers; settings model, value, lapse, example_lapse, "
                                 "max_examples, check_every, feedback, stop_at (docs/study.md)")
        parser.add_argument("--target-per-condition", type=int, help=_help(STUDY_FIELDS["target_per_condition"]))
        parser.add_argument("--closed", action="store_true", help="leave the study closed when done")
        parser.add_argument("--replace", action="store_true", help="rebuild an existing study without participants")
        parser.add_argument("--queue", help="Celery queue (default: settings.PRECOMPUTE_QUEUE)")
        parser.add_argument("--wait", action="store_true", help="block with a progress bar until it finishes")
        parser.add_argument("--no-progress", action="store_true")
        parser.add_argument("--timeout", type=float, help="with --wait: give up after this many seconds")

    def handle(self, *args, **opts):
        table = Path(opts["table"]) if opts["table"] else jobs.tables_dir() / opts["preset"]
        try:
            hyper = parse_hyperparameters(opts["hyper"])
            loops = dict(parse_closed_loop(text) for text in opts["closed_loop"])
        except ValueError as exc:  # StudyJobError is one
            raise CommandError(str(exc)) from None
        conditions = split_conditions(opts["conditions"]) if opts["conditions"] else None
        design = {"slug": opts["slug"], "name": opts["name"], "seed": opts["seed"], "approx_star": opts["approx_star"],
                  "hyperparameters": hyper, "conditions": conditions, "is_open": not opts["closed"],
                  "replace": opts["replace"], "target_per_condition": opts["target_per_condition"],
                  "closed_loop": loops, "test_difficulty": opts["test_difficulty"], "test_kind": opts["test_kind"]}
        try:
            job = create_study_job(table, check_job(design), queue=opts["queue"])
        except TableError as exc:
            hint = " (build it first: manage.py precompute_table --preset NAME --wait)" if opts["preset"] else ""
            raise CommandError(f"{exc}{hint}") from None
        except (SpecError, StudyJobError, jobs.BrokerUnavailable) as exc:
            raise CommandError(str(exc)) from None
        loops = f" + {len(loops)} closed-loop" if loops else ""
        self.stdout.write(f"job {job.pk}: study {opts['slug']!r}, {len(job.params['conditions'])} conditions{loops} "
                          f"+ test set from {job.params['table']}  (page: /precompute/jobs/{job.pk}/)")
        if not opts["wait"]:
            return
        job = wait_for_job(self, job, opts)
        for name, r in job.result.get("conditions", {}).items():
            value = f" (τ/λ={r['value']:g})" if r.get("value") is not None else ""
            params = ",".join(f"{k}={v}" for k, v in (r.get("params") or {}).items())
            chosen = f" [{r['selector']}{':' + params if params else ''}]" if r.get("selector") else ""
            self.stdout.write(f"  {name:18s} {len(r['env_ids']):2d} examples{value}{chosen}: {r['env_ids']}")
        for name, r in job.result.get("closed_loop", {}).items():
            s = r["settings"]
            self.stdout.write(f"  {name:18s} closed loop: {s['model']}, up to {s['max_examples']} examples, a check "
                              f"every {s['check_every']} ({len(r['checks'])} check questions: {r['checks']})")
        self.stdout.write(f"  test set: {job.result.get('test_env_ids')}; study "
                          f"{'open' if job.params['open_when_done'] else 'closed'} at /s/{opts['slug']}/")
