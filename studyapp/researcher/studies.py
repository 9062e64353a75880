"""Creating studies from a JSON spec, and the demo study.

Spec (a JSON file for ``manage.py create_study``; its fields, their defaults and rules are declared
once in studyapp/researcher/specschema.py, and documented in docs/study.md)::

    {
      "slug": "study-2026", "name": "What the robot prefers", "target_per_condition": 30,
      "recruitment": "prolific", "completion_code": "C1ABCDEF",
      "table": "var/tables/demo",
      "conditions": [{"name": "exact", "env_ids": [12, 4031, ...]}, ...],
      "test_set": [{"env_id": 77, "options": [{"theta_index": 0, "is_theta_star": true}, ...]}, ...]
    }

or, for tests where the participant shows the way (grid worlds from a file), ``"test_set": [{"env_id": 77,
"kind": "show"}, ...]`` (``teaching.api.select_show_tests``); the study's ``test_kind`` follows its tests.

Every trajectory a participant sees is read from the table: theta*'s optimal
trajectory in each training environment, and each test option's (the ``test_set``
as produced by ``teaching.core.testset.select_test_set``).  A spec without a table is
refused: nothing else could say what theta* does.  ``table_spec`` runs the whole
pipeline (selection and test set) on a table, for the demo and the tests.

``spec_from_teach`` turns the output directory of ``python -m teaching teach``
(sequences.json + test_set.json) into the table, conditions and test set of a
spec; ``table_hash`` then makes sure the table is the one the sequences were
selected on.  Every malformed spec is a ``SpecError`` with a one-line message.
"""
from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
from django.conf import settings
from django.db import transaction

from teaching.api import (
    CONDITIONS,
    TableError,
    TeachOutputError,
    TrajectoryTable,
    build_sequences,
    condition_params,
    default_domain_name,
    domain_names,
    get_domain,
    read_teach,
    select_test_set,
)

from .. import trajectories
from ..i18n import language_problem
from ..models import Condition, Study
from ..participant import closedloop
from . import specschema
from .specschema import (
    SpecError,
)

# The paper's nine conditions (Secs. "User Study" and "User Study on Coverage"), spelled as the
# teaching selectors name them so a study built from either source reads the same.
PAPER_CONDITIONS = list(CONDITIONS)
DEMO_SLUG = "demo"
DEMO_TABLE_ENV = "DEMO_TABLE"
DEMO_TABLE_NAME = "demo"  # the demo table is settings.TABLES_DIR/demo, where `make demo` writes it

DEMO_COMPLETION_CODE = "DEMO2026"  # Prolific rejects a per-participant code: the demo sets one
PILOT_KEY = "pilot"  # study.source["pilot"]: the simulated pilot (studyapp/researcher/pilot.py)
SCENE_VIEW_KEY = "scene_view"  # study.source["scene_view"]: the one scale, stored when closed loops widen it


def spec_from_teach(teach_dir, table=None) -> dict:
    """The table, conditions and test set of a spec from `python -m teaching teach`'s output
    (read by teaching's one reader of it, teaching.api.read_teach).

    teach_dir: its output directory (or the sequences.json in it).  `table` overrides the table
    path recorded in sequences.json (e.g. the table moved); its content hash must still match.
    """
    try:
        output = read_teach(teach_dir)
    except TeachOutputError as exc:
        raise SpecError(str(exc)) from None
    if output.no_tests is not None:
        raise SpecError(f"the teach output in {output.dir} has no test set: {output.no_tests}")
    conditions = [{"name": name, "env_ids": ids} for name, ids in output.conditions.items()]
    spec = {"table": str(table or output.table_path), "table_hash": output.table_hash, "conditions": conditions,
            "test_set": output.tests}
    pilot = _teach_pilot(output, [c["name"] for c in conditions])
    if pilot:
        spec["pilot"] = pilot
    return spec


def _teach_pilot(output, names: list[str]) -> dict | None:
    """The simulated pilot of a teach output (its matrix.json, the extended rows: the paper's nine
    conditions) restricted to the study's conditions, in the study's order; None if it has none."""
    try:
        m = output.matrix()
    except TeachOutputError as exc:
        raise SpecError(str(exc)) from None
    if m is None:
        return None
    path = output.dir / "matrix.json"
    try:
        rows = dict(zip(m["extended_sequence_names"], m["extended_matrix"], strict=True))
        pilot = {"conditions": names, "users": list(m["user_names"]), "matrix": [rows[n] for n in names],
                 "models": dict(m.get("models", {})), "from": f"teach output ({path})"}
        if "predicted" in m:  # the learners' choices in the tests (the teach output's own test set)
            predicted = m["predicted"]
            choice = {u: {n: by_name[n] for n in names} for u, by_name in predicted["choice"].items()}
            pilot["predicted"] = {"theta_star_option": list(predicted["theta_star_option"]), "choice": choice}
        return pilot
    except (KeyError, TypeError, ValueError) as exc:
        raise SpecError(f"{path} is not a teach output's matrix ({exc})") from None


def _load_table(spec: dict):
    try:
        table = TrajectoryTable.load(spec["table"])
    except (TableError, OSError, ValueError) as exc:
        raise SpecError(f"cannot use the table at {spec['table']}: {exc}") from None
    star = spec.get("theta_star")
    if star is not None:
        try:
            table.domain.parse_theta_star(star)
        except ValueError as exc:
            raise SpecError(f"'theta_star' for the {table.domain.name} table at {spec['table']} "
                            f"({', '.join(table.domain.feature_names)}): {exc}") from None
    if star is not None and not np.array_equal(np.asarray(table.theta_star, float), np.asarray(star, float)):
        raise SpecError(f"the table at {spec['table']} was built for theta* = {[float(v) for v in table.theta_star]}, "
                        f"not the study's theta* = {[float(v) for v in star]}")
    want = spec.get("table_hash")
    if want and table.meta.get("content_hash") != want:
        raise SpecError(f"the table at {spec['table']} (hash {str(table.meta.get('content_hash'))[:16]}) is not "
                        f"the one the sequences were selected on (hash {str(want)[:16]})")
    return table


def _payloads(spec: dict):
    """Training and test payloads of a spec that passed specschema.check_spec."""
    conditions = spec["conditions"]
    table = _load_table(spec)
    try:
        training = {c["name"]: trajectories.training_from_table(table, c.get("env_ids", [])) for c in conditions}
        if trajectories.test_kind_of(spec["test_set"]) == trajectories.SHOW:
            tests = trajectories.show_tests_from_table(table, spec["test_set"])
        else:
            tests = trajectories.test_set_from_table(table, spec["test_set"])
        loops = prepare_closed_loops(table, spec["slug"], {c["name"]: c["closed_loop"] for c in conditions
                                                           if "closed_loop" in c}, spec["test_set"])
    except (ValueError, IndexError) as exc:  # ClosedLoopError and TestSetError are ValueErrors
        raise SpecError(str(exc)) from None
    source = {"kind": "table", "table": str(spec["table"]), "content_hash": table.meta.get("content_hash"),
              "theta_star": [float(v) for v in table.theta_star], "domain": table.domain.name,
              **kept_suboptimal(table.meta)}
    selectors = {c["name"]: {"selector": c["selector"], "params": condition_params(c["selector"], c.get("params"))}
                 for c in conditions if "selector" in c}
    if selectors:  # what chose each condition's examples, as the study job records it
        source["selectors"] = selectors
    if loops:
        source[SCENE_VIEW_KEY] = closed_loop_view(table, training.values(), tests, loops.values())
        for name, data in loops.items():
            training[name] = data
    if isinstance(spec.get("pilot"), dict):  # a teach output's ideal-user matrix (spec_from_teach)
        source[PILOT_KEY] = {**spec["pilot"], "prior": 1.0 / table.n_thetas}
    return conditions, training, tests, source


def prepare_closed_loops(table, slug: str, loops: dict[str, dict], tests: list[dict]) -> dict[str, dict]:
    """{name: what Condition.closed_loop stores} of the closed-loop conditions `loops` ({name: settings}),
    their checks apart from the final `tests` (select_test_set's dicts); ClosedLoopError (one line)."""
    return {name: closedloop.prepare(table, slug, name, settings, tests) for name, settings in loops.items()}


def closed_loop_view(table, trainings, tests: list[dict], loops) -> dict:
    """The study's one scale for every canvas (study.source[SCENE_VIEW_KEY]), holding any example or check
    the closed loops (`loops`: their stored data) may show as well as the fixed trainings and the tests."""
    extra = [scene for data in loops for scene in closedloop.example_scenes(table, data)]
    return trajectories.study_view(table.domain, trainings, tests, extra)


# --- the one way a study is made: create it, freeze each condition, freeze the test set ---------
# create_study (a JSON spec or a teach output), the Celery study job (precompute/study.py) and the
# demo all go through these three, so one set of rules holds everywhere.
def new_study(checked: specschema.CheckedStudy, source: dict, replace: bool = False) -> Study:
    """Create the study `checked` designs, closed, with its conditions named and not yet frozen.

    Refuses what only the table's robot and the database can say: a language the domain's texts are not all
    in (studyapp.i18n.language_problem, said under "language"), an existing study unless `replace`, and
    replacing a study that has participants.  Everything else was said when `checked` was made.
    """
    if not isinstance(checked, specschema.CheckedStudy):
        raise TypeError("new_study takes a CheckedStudy: check the design first (studyapp.researcher.specschema)")
    slug, fields = checked["slug"], checked.study_fields
    domain = source_domain(source)
    # a study whose participants would read some of its robot's texts in English is not the study designed:
    # refused here, where every study is made, rather than shown half translated
    problem = language_problem(get_domain(domain), fields.get("language") or Study.language.field.default)
    if problem:
        raise SpecError(problem, "language")
    with transaction.atomic():
        existing = Study.objects.select_for_update().filter(slug=slug).first()
        if existing and not replace:
            raise SpecError(f"study {slug!r} exists; pass --replace to rebuild it", "slug")
        if existing and existing.participants.exists():
            raise SpecError(f"study {slug!r} already has participants; refusing to replace it", "slug")
        if existing:
            existing.delete()
        study = Study.objects.create(slug=slug, name=checked.get("name") or slug, source=source, is_open=False,
                                     test_set=[], domain=domain, **fields)
        for i, c in enumerate(checked.condition_names):
            Condition.objects.create(study=study, name=c, position=i, training=[])
    return study


def source_domain(source: dict) -> str:
    """The domain a study's stimuli come from: its table's (source["domain"]; a source recorded
    before domains is the default domain's table's)."""
    name = source.get("domain") or default_domain_name()
    if name not in domain_names():
        raise SpecError(f"unknown domain {name!r}: this installation knows {', '.join(domain_names())}")
    return name


def _refuse_if_started(study: Study) -> None:
    if study.participants.exists():
        raise SpecError(f"study {study.slug!r} already has participants: its design can no longer change")


def freeze_condition(condition: Condition, training: list[dict], target: int | None = None) -> None:
    """Store a condition's training examples (with the trajectories to draw them), and its own
    target of participants if one is given (else the study's target_per_condition applies)."""
    _refuse_if_started(condition.study)
    if not training:
        raise SpecError(f"condition {condition.name!r} needs at least one training example")
    condition.training = training
    fields = ["training"]
    if target is not None:
        condition.target = target
        fields.append("target")
    condition.save(update_fields=fields)


def store_pilot(study: Study, pilot: dict) -> None:
    """Keep the simulated pilot (studyapp/researcher/pilot.py reads it) with the study's source JSON,
    replacing an older one."""
    study.source = {**(study.source or {}), PILOT_KEY: pilot}
    study.save(update_fields=["source"])


def freeze_closed_loop(condition: Condition, data: dict, target: int | None = None) -> None:
    """Store a closed-loop condition (studyapp.participant.closedloop.prepare's data) instead of a training sequence."""
    _refuse_if_started(condition.study)
    condition.closed_loop = data
    condition.training = []
    fields = ["closed_loop", "training"]
    if target is not None:
        condition.target = target
        fields.append("target")
    condition.save(update_fields=fields)


def freeze_test_set(study: Study, tests: list[dict], open_study: bool = True) -> None:
    """Store the shared test set, disjoint from every condition's training, and open the study if
    asked (and it may open: Study.opening_problems)."""
    _refuse_if_started(study)
    try:
        trajectories.check_test_set(tests)
    except (KeyError, TypeError, ValueError) as exc:
        raise SpecError(f"bad test set: {exc}") from None
    conditions = list(study.conditions.all())
    empty = [c.name for c in conditions if not c.training and not c.closed_loop]
    if empty:
        raise SpecError(f"conditions without a training sequence: {', '.join(empty)}")
    # A test environment a participant already saw in training would measure recall, not
    # anticipation of a novel situation (DESIGN §6: the test set is disjoint from training).
    seen = {int(e) for c in conditions for e in c.env_ids}
    overlap = sorted(seen & {int(t["env_id"]) for t in tests})
    if overlap:
        raise SpecError(f"test environments {overlap} also appear in a training sequence; "
                        "the test set must be disjoint from every condition's training")
    study.test_set = tests
    study.test_kind = trajectories.test_kind_of(tests)
    study.is_open = open_study
    problems = study.opening_problems() if open_study else []
    if problems:
        raise SpecError(problems[0])
    study.save(update_fields=["test_set", "test_kind", "is_open"])


def build_study(spec: dict, replace: bool = False) -> Study:
    """Create the study described by `spec` (see module docstring), all in one transaction.

    An existing study with the same slug is kept as is unless `replace`,
    which is refused once it has participants.
    """
    spec = specschema.check_spec(spec)
    existing = Study.objects.filter(slug=spec["slug"]).first()
    if existing and not replace:
        return existing
    conditions, training, tests, source = _payloads(spec)
    with transaction.atomic():
        study = new_study(spec, source, replace=replace)
        targets = {c["name"]: c.get("target") for c in conditions}
        for c in study.conditions.all():
            if isinstance(training[c.name], dict):
                freeze_closed_loop(c, training[c.name], targets[c.name])
            else:
                freeze_condition(c, training[c.name], targets[c.name])
        freeze_test_set(study, tests, open_study=spec["is_open"])
    return study


# --- a whole study from a table, and the demo ------------------------------------------------------
def kept_suboptimal(meta: dict) -> dict:
    """{"kept_suboptimal": what the optimality check found} for a table imported although some trajectory is not
    the best under its own objective (its researcher set keep_suboptimal), else {}: the dashboard shows it."""
    imported = meta.get("imported") or {}
    return {"kept_suboptimal": imported.get("optimality", "")} if imported.get("keep_suboptimal") else {}


def table_spec(table_path, *, slug: str, sequences: dict | None = None, seed: int = 0, **test_set_kw) -> dict:
    """A spec whose conditions and test set come from the real pipeline on the table at `table_path`.

    sequences: {condition: env_ids}; by default ``teaching.core.conditions.build_sequences`` (the paper's
    nine conditions).  The test set is ``teaching.core.testset.select_test_set`` (its thresholds in
    `test_set_kw`: min_regret, min_distance), disjoint from every sequence.  A table that cannot
    give a test set is a SpecError naming why.
    """
    try:
        table = TrajectoryTable.load(table_path)
        if sequences is None:
            sequences = build_sequences(table, seed=seed)
        sequences = {name: [int(e) for e in ids] for name, ids in sequences.items()}
        tests = select_test_set(table, list(sequences.values()), seed, **test_set_kw)
    except (OSError, ValueError) as exc:  # TableError and TestSetError are ValueErrors
        raise SpecError(f"cannot use the table at {table_path}: {exc}") from None
    return {"slug": slug, "table": str(table_path),
            "conditions": [{"name": n, "env_ids": ids} for n, ids in sequences.items()], "test_set": tests}


def make_study(table, slug: str = "synth", sequences: dict | None = None, name: str = "Synthetic study",
               **test_set_kw) -> Study:
    """A study on the trajectory table at `table` (for simulations, tests and demos): the paper's conditions
    selected on it (or the given sequences) and its test set (:func:`table_spec`; `test_set_kw` its thresholds)."""
    spec = table_spec(table, slug=slug, sequences=sequences, **test_set_kw)
    spec.update(name=name, target_per_condition=100)
    return build_study(spec)


def demo_table_path(table_path=None) -> Path:
    """`table_path`, else $DEMO_TABLE, else the demo table under settings.TABLES_DIR (the one place
    that says where tables live: the designer and precompute_table use it too)."""
    return Path(table_path or os.environ.get(DEMO_TABLE_ENV) or Path(settings.TABLES_DIR) / DEMO_TABLE_NAME)


def demo_is_stale(study: Study, table_path=None) -> bool:
    """Was `study` built from something other than the demo table now on disk?

    True when the table was rebuilt (another content hash).  A missing table never makes a
    study stale.
    """
    meta = demo_table_path(table_path) / "meta.json"
    try:
        current = json.loads(meta.read_text()).get("content_hash")
    except (OSError, ValueError):
        return False
    return (study.source or {}).get("content_hash") != current


def demo_spec(table_path=None) -> dict:
    """The demo study: all of the paper's conditions, selected on the demo table (`table_path`,
    $DEMO_TABLE or TABLES_DIR/demo) by the real pipeline.  No table: a SpecError saying how to
    build one."""
    table_path = demo_table_path(table_path)
    if not (table_path / "meta.json").exists():
        raise SpecError(f"no trajectory table at {table_path}: build the demo's with "
                        f"`python -m teaching build --preset demo --out {table_path}` (or run `make demo`)")
    spec = table_spec(table_path, slug=DEMO_SLUG)
    title = get_domain(json.loads((table_path / "meta.json").read_text()).get("domain")).texts.title
    spec.update(name=f"Demo: {title[:1].lower()}{title[1:]}", target_per_condition=20,
                completion_code=DEMO_COMPLETION_CODE, estimated_minutes=12,
                contact="The research team (demo: no real contact)")
    return spec
