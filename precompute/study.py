"""Study jobs: one task per condition (selector + hyperparameters), then the test set.

The study and its conditions are created first, closed and empty; each
condition task freezes its training sequence on its Condition (the
``training`` JSON the participant pages read) and keeps the selection details
(P(θ*) curve, τ / λ, whether the hyperparameter rule held) on its job Part;
the final task picks the test set, disjoint from every training sequence,
stores it on the Study and opens the study (unless asked not to).  Creating
and freezing go through studyapp/studies.py (new_study, freeze_condition,
freeze_test_set), the same functions `create_study` uses.
"""
from __future__ import annotations

from dataclasses import fields as dataclass_fields
from pathlib import Path

from django.db import transaction

from studyapp.models import Study
from studyapp.specschema import STUDY_FIELDS, check_job
from studyapp.studies import SpecError, new_study
from studyapp.trajectories import cannot_show
from teaching.api import ClosedLoopSpec, TrajectoryTable, condition_params

from .jobs import launch
from .models import Job
from .specs import StudyJobSpec


class StudyJobError(ValueError):
    """Bad input for a study job: reported in one line by the command."""


def create_study_job(table_path, slug: str, name: str | None = None, seed: int | None = None,
                     approx_star: str | None = None, hyperparameters: dict | None = None,
                     conditions=None, open_when_done: bool = True, replace: bool = False,
                     target_per_condition: int | None = None, queue=None, start: bool = True,
                     hand_picked: dict | None = None, test_set_thresholds: dict | None = None,
                     closed_loop: dict | None = None, closed_loop_fit: dict | None = None,
                     test_difficulty: str | None = None, test_kind: str | None = None, **study_fields) -> Job:
    """A job that selects every condition's sequence and the test set on `table_path`.

    Every argument but the table follows a study spec's rules and defaults (studyapp/specschema.py,
    JOB_FIELDS and STUDY_FIELDS), checked before the table is read.  `conditions`: registered selectors,
    each a name, "NAME:KEY=VALUE,..." (teaching's --selector form) or {"selector", "params", "name"}; each
    condition's selector and every parameter it runs with are recorded in the study's source ("selectors")
    and on its task's Part.  `test_difficulty`: none, or every test of that difficulty.  `test_kind`: "choose"
    (the default) or "show" (the way: grid worlds from a file), either graded by `test_difficulty`.
    `hand_picked`: {condition name: environment ids}, conditions shown in the given order (after the
    selected ones).
    `test_set_thresholds`: min_regret and/or min_distance for ``select_test_set``.  `closed_loop`:
    {condition name: closed-loop settings (teaching's ClosedLoopSpec fields; {} for every default)},
    conditions that decide each participant's examples from their answers, prepared by the last task
    once the test set is known (docs/study.md).  `closed_loop_fit`: {closed-loop condition: slug of a
    study} whose best learner-model fit, made by the last task, gives that condition's model, τ / λ and
    lapse rate (where the study cannot be fitted, the settings given stand, and the job's result says
    why).  `study_fields`: completion_code, recruitment and the consent page's texts.
    The table is verified here, once per job: its content hash goes into the job's params, and
    the tasks check the table still records that hash instead of re-hashing it (tasks._table).
    """
    given = {"slug": slug, "name": name, "seed": seed, "approx_star": approx_star, "conditions": conditions,
             "hyperparameters": hyperparameters, "target_per_condition": target_per_condition,
             "hand_picked": hand_picked, "test_set_thresholds": test_set_thresholds, "closed_loop": closed_loop,
             "closed_loop_fit": closed_loop_fit, "test_difficulty": test_difficulty, "test_kind": test_kind,
             **study_fields}
    try:
        args = check_job(given)
    except SpecError as exc:
        raise StudyJobError(str(exc)) from None
    table_path = Path(table_path).resolve()
    table = TrajectoryTable.load(table_path)  # TableError: missing, altered, other world constants
    in_table = {int(e) for e in table.env_ids}
    for condition, ids in args["hand_picked"].items():
        missing = sorted(set(ids) - in_table)
        if missing:
            raise StudyJobError(f"hand-picked condition {condition!r}: environments {missing[:10]} are not in the "
                                "table")
    if args["test_kind"] == Study.SHOW:
        show_problem = _show_problem(table, args)
        if show_problem:
            raise StudyJobError(show_problem)
    for name, source in args["closed_loop_fit"].items():
        if not Study.objects.filter(slug=source).exists():
            raise StudyJobError(f"closed-loop condition {name!r}: there is no study {source!r} to take a fit from")
    selectors = {c["name"]: {"selector": c["selector"],
                             "params": condition_params(c["selector"], c["params"], args["approx_star"])}
                 for c in args["conditions"]}
    conditions = list(selectors) + list(args["hand_picked"])
    loops = args["closed_loop"]
    difficulty = None if args["test_difficulty"] == "none" else args["test_difficulty"]
    source = {"kind": "table", "table": str(table_path), "content_hash": table.meta.get("content_hash"),
              "theta_star": [float(v) for v in table.theta_star], "domain": table.domain.name,
              **{k: args[k] for k in ("seed", "approx_star", "hyperparameters", "hand_picked", "test_set_thresholds")},
              "selectors": selectors, "test_difficulty": difficulty}
    fields = {k: args[k] for k in STUDY_FIELDS if k not in ("slug", "name") and k in args}
    with transaction.atomic():
        try:  # the study app's own rules for a new study (studyapp/studies.py)
            study = new_study(slug=args["slug"], name=args.get("name"), conditions=conditions + list(loops),
                              source=source, replace=replace, **fields)
        except SpecError as exc:
            raise StudyJobError(str(exc)) from None
        spec = StudyJobSpec(study_id=study.pk, slug=study.slug, table=str(table_path),
                            content_hash=source["content_hash"], seed=args["seed"], approx_star=args["approx_star"],
                            hyperparameters=args["hyperparameters"], conditions=conditions,
                            open_when_done=open_when_done, queue=queue, hand_picked=args["hand_picked"],
                            test_set_thresholds=args["test_set_thresholds"], closed_loop=loops,
                            closed_loop_fit=args["closed_loop_fit"], selectors=selectors,
                            test_difficulty=difficulty, test_kind=args["test_kind"])
        job = Job.objects.create(kind=Job.STUDY, chunks_total=len(conditions) + 1, params=spec.to_json())
    if start:
        launch(job)
    return job


def _show_problem(table, args: dict) -> str:
    """Why this job cannot ask to show the way ("" if it can)."""
    problem = cannot_show(table.domain)
    if problem:
        return f"tests that show the way: {problem}"
    return ""


_TRUE, _FALSE = {"1", "yes", "true", "on"}, {"0", "no", "false", "off"}


def parse_closed_loop(text: str) -> tuple[str, dict]:
    """ "NAME" or "NAME:setting=value,..." (the command's --closed-loop) -> (name, settings), each value
    read as its ClosedLoopSpec field's type; StudyJobError names what it cannot read."""
    name, _, rest = text.partition(":")
    name = name.strip()
    if not name:
        raise StudyJobError(f"--closed-loop {text!r}: give the condition's name first, e.g. "
                            f"closed-loop:model=det-euclidean,check_every=2")
    kinds = {f.name: f.type for f in dataclass_fields(ClosedLoopSpec)}
    settings = {}
    for item in filter(None, (p.strip() for p in rest.split(","))):
        key, eq, value = (v.strip() for v in item.partition("="))
        if not eq or key not in kinds:
            raise StudyJobError(f"--closed-loop {name}: {item!r} is not setting=value with a setting of "
                                f"{', '.join(kinds)}")
        try:
            settings[key] = _setting(kinds[key], value)
        except ValueError:
            raise StudyJobError(f"--closed-loop {name}: {key}={value!r} is not a {kinds[key]}") from None
    return name, settings


def _setting(kind: str, value: str):
    if kind == "bool":
        if value.lower() not in _TRUE | _FALSE:
            raise ValueError(value)
        return value.lower() in _TRUE
    if kind == "int":
        return int(value)
    if kind.startswith("float"):  # "float" or "float | None" (τ / λ: "none" for the model's default)
        return None if value.lower() == "none" and "None" in kind else float(value)
    return value
