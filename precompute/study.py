"""Study jobs: one task per condition (selector + hyperparameters), then the test set.

The study and its conditions are created first, closed and empty; each
condition task freezes its training sequence on its Condition (the
``training`` JSON the participant pages read) and keeps the selection details
(P(θ*) curve, τ / λ, whether the hyperparameter rule held) on its job Part;
the final task picks the test set, disjoint from every training sequence,
stores it on the Study and opens the study (unless asked not to).  Creating
and freezing go through studyapp/researcher/studies.py (new_study, freeze_condition,
freeze_test_set), the same functions `create_study` uses.
"""
from __future__ import annotations

from dataclasses import fields as dataclass_fields
from pathlib import Path

from django.db import transaction

from studyapp.models import Study
from studyapp.researcher.specschema import CheckedStudy
from studyapp.researcher.studies import SpecError, kept_suboptimal, new_study
from studyapp.trajectories import cannot_show
from teaching.api import ClosedLoopSpec, TrajectoryTable, condition_params

from .jobs import launch
from .models import Job
from .specs import StudyJobSpec


class StudyJobError(ValueError):
    """Bad input for a study job: reported in one line by the command, and by the designer under `field`
    (a job field's name; "" for none)."""

    def __init__(self, message: str, field: str = ""):
        super().__init__(message)
        self.field = field


def create_study_job(table_path, checked: CheckedStudy, queue: str | None = None, start: bool = True) -> Job:
    """A job that selects every condition's sequence and the test set on `table_path`, for the study
    `checked` designs (specschema.check_job or job_problems: its fields are JOB_FIELDS and STUDY_FIELDS,
    checked there and not again here).

    Its conditions: the selected ones (each a registered selector with the parameters it runs with, recorded
    in the study's source, "selectors", and on its task's Part), then the hand-picked ones (shown in the
    given order), then the closed-loop ones, prepared by the last task once the test set is known
    (docs/study.md), with the fit a closed_loop_fit names made by that task too (where the study cannot be
    fitted, the settings given stand, and the job's result says why).  Here is checked only what needs the
    table or the database: hand-picked environments in the table, tests that show the way on a robot that
    has them, a study to take a fit from, and (by studies.new_study) the language and the slug.
    StudyJobError names the field.  The table is verified here, once per job: its content hash goes into the
    job's params, and the tasks check the table still records that hash instead of re-hashing it
    (tasks._table).  `queue`: the Celery queue (default settings.PRECOMPUTE_QUEUE); `start`: launch it now.
    """
    table_path = Path(table_path).resolve()
    table = TrajectoryTable.load(table_path)  # TableError: missing, altered, other world constants
    _check_on_table(table, checked)
    selectors = {c["name"]: {"selector": c["selector"],
                             "params": condition_params(c["selector"], c["params"], checked["approx_star"])}
                 for c in checked["conditions"]}
    conditions = list(selectors) + list(checked["hand_picked"])
    difficulty = None if checked["test_difficulty"] == "none" else checked["test_difficulty"]
    source = {"kind": "table", "table": str(table_path), "content_hash": table.meta.get("content_hash"),
              "theta_star": [float(v) for v in table.theta_star], "domain": table.domain.name,
              **{k: checked[k] for k in ("seed", "approx_star", "hyperparameters", "hand_picked",
                                         "test_set_thresholds")},
              "selectors": selectors, "test_difficulty": difficulty, **kept_suboptimal(table.meta)}
    with transaction.atomic():
        try:  # what only the robot and the database can say (studyapp/researcher/studies.py)
            study = new_study(checked, source, replace=checked["replace"])
        except SpecError as exc:
            raise StudyJobError(str(exc), exc.field) from None
        spec = StudyJobSpec(study_id=study.pk, slug=study.slug, table=str(table_path),
                            content_hash=source["content_hash"], seed=checked["seed"],
                            approx_star=checked["approx_star"], hyperparameters=dict(checked["hyperparameters"]),
                            conditions=conditions, open_when_done=checked["is_open"], queue=queue,
                            hand_picked=dict(checked["hand_picked"]),
                            test_set_thresholds=dict(checked["test_set_thresholds"]),
                            closed_loop=dict(checked["closed_loop"]), closed_loop_fit=dict(checked["closed_loop_fit"]),
                            selectors=selectors, test_difficulty=difficulty, test_kind=checked["test_kind"])
        job = Job.objects.create(kind=Job.STUDY, chunks_total=len(conditions) + 1, params=spec.to_json())
    if start:
        launch(job)
    return job


def _check_on_table(table, checked: CheckedStudy) -> None:
    """What the design says that only the table and the database can refute: StudyJobError naming the field."""
    in_table = {int(e) for e in table.env_ids}
    for condition, ids in checked["hand_picked"].items():
        missing = sorted(set(ids) - in_table)
        if missing:
            raise StudyJobError(f"hand-picked condition {condition!r}: environments {missing[:10]} are not in the "
                                "table", "hand_picked")
    show_problem = cannot_show(table.domain) if checked["test_kind"] == Study.SHOW else None
    if show_problem:
        raise StudyJobError(f"tests that show the way: {show_problem}", "test_kind")
    for name, source in checked["closed_loop_fit"].items():
        if not Study.objects.filter(slug=source).exists():
            raise StudyJobError(f"closed-loop condition {name!r}: there is no study {source!r} to take a fit from",
                                "closed_loop_fit")


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
