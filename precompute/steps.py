"""The work of each precompute task, apart from Celery's bookkeeping (precompute/tasks.py).

This module brings in NumPy, Numba, SciPy, the teaching core and the study's writers: more than
half of what a worker would otherwise import at boot.  tasks.py imports it when a pool process
runs its first task, never in the worker's main process, so a worker that supervisord restarts
after a crash is ready about twice as fast, and fastest when the machine is busiest
(bench/worker_boot.py; tests/precompute/test_precompute_real_worker.py checks that the main
process never loads them).
"""
from __future__ import annotations

import functools
import logging
import os

import numba

from studyapp.analysis.modelfit import ModelFitError, best_fit_settings
from studyapp.models import Condition, Study
from studyapp.participant.closedloop import pack_of_data
from studyapp.researcher.studies import (
    SCENE_VIEW_KEY,
    closed_loop_view,
    freeze_closed_loop,
    freeze_condition,
    freeze_test_set,
    prepare_closed_loops,
    store_pilot,
)
from studyapp.trajectories import show_tests_from_table, test_set_from_table, training_from_table
from teaching.api import (
    MIN_REGRET,
    ClosedLoopError,
    TestSetError,
    TrajectoryTable,
    select_show_tests,
    select_test_set,
)

from . import work
from .models import Part
from .sequences import condition_sequence, pilot_matrix
from .specs import BuildRefused, StudyJobSpec

log = logging.getLogger(__name__)


# --- trajectory tables ---------------------------------------------------------
def compute_chunk(spec: dict, env_ids, threads: int) -> dict:
    """One chunk planned with `threads` Numba threads (the pool process's own thread pool,
    started here, after the fork: Numba's threading layer is not fork-safe once used)."""
    numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
    _say_threads()
    return work.compute_chunk(spec, env_ids)


@functools.cache
def _say_threads() -> None:
    """Once per pool process, in the worker log: what it plans with."""
    log.info("precompute: worker process %d plans with %d Numba thread(s), threading layer %s",
             os.getpid(), numba.get_num_threads(), numba.threading_layer())


publish = work.publish


# --- study sequences -----------------------------------------------------------------
def _table(spec: StudyJobSpec):
    """The job's table.  create_study_job verified its content hash once and put it in the
    spec; a task only checks that meta.json still records that hash (a table rebuilt or
    replaced since is refused) instead of re-reading every byte: 2.65 GB per task at paper
    size.  A job created before specs carried the hash verifies the table as it always did."""
    if spec.content_hash is None:
        return TrajectoryTable.load(spec.table)
    return TrajectoryTable.load(spec.table, verify=False, expected_hash=spec.content_hash)


def select_condition(spec: StudyJobSpec, condition: Condition) -> dict:
    """One condition's teaching sequence (or the researcher's own list), frozen on `condition`;
    returns what was chosen: env_ids, model, value (and the selection's rule and P(θ*))."""
    table = _table(spec)
    name = condition.name
    if name in spec.hand_picked:  # the researcher's own list: shown as given, no selection
        result = {"condition": name, "env_ids": spec.hand_picked[name], "model": "hand-picked", "value": None}
    else:
        chosen = spec.selectors.get(name, {"selector": name, "params": {}})
        result = {**condition_sequence(table, chosen["selector"], seed=spec.seed, approx_star=spec.approx_star,
                                       hyperparameters=spec.hyperparameters, params=chosen["params"]),
                  "condition": name}
    freeze_condition(condition, training_from_table(table, result["env_ids"]))
    return result


def study_pilot(table, conditions, spec: StudyJobSpec, job_id, tests: list[dict] | None, loops: dict) -> dict:
    """The study's simulated pilot: the ideal-user matrix for exactly its conditions and what learners of
    each model would choose in its `tests`; each closed loop (`loops`: {name: stored data}) by simulated
    participants of every model run through it.  Each user's τ / λ is the one its condition's task chose
    (or the researcher fixed), so only a model no condition used is swept again."""
    chosen = {r["model"]: r["value"] for r in Part.objects.filter(job_id=job_id).values_list("result", flat=True)
              if r.get("model") and r.get("value") is not None}
    return pilot_matrix(table, {c.name: c.env_ids for c in conditions},
                        {**chosen, **spec.hyperparameters}, test_set=tests,
                        closed_loops={name: pack_of_data(data).loop for name, data in loops.items()})


def closed_loop_settings(spec: StudyJobSpec) -> tuple[dict, dict]:
    """({name: settings}, {name: what a fit gave, or why it gave nothing}) of the job's closed loops: those
    the researcher tied to a study take the model, τ / λ and ε of that study's best fit, where it has one."""
    settings, notes = {k: dict(v) for k, v in spec.closed_loop.items()}, {}
    for name, slug in spec.closed_loop_fit.items():
        try:
            fitted = best_fit_settings(Study.objects.get(slug=slug))
        except (Study.DoesNotExist, ModelFitError) as exc:
            notes[name] = f"no fit of study {slug!r} ({exc}); the settings given were used"
            continue
        settings[name].update(fitted)
        value = "" if fitted["value"] is None else f" at {fitted['value']:g}"
        notes[name] = f"the best fit to study {slug!r}: {fitted['model']}{value}, lapse rate {fitted['lapse']:.3g}"
    return settings, notes


def closed_loop_refusal(exc: ClosedLoopError) -> str:
    """One line for the job page: why a closed-loop condition could not be prepared, and what to change."""
    why = str(exc).rstrip(".")
    if why.startswith("cannot write"):
        change = ("The server's data folder (VAR_DIR) must be writable by the worker, with room to spare; "
                  "ask whoever runs the server, then build again.")
    else:
        change = ("Lower the test set's thresholds, choose another difficulty or test kind, or build the study "
                  "without a closed-loop condition.")
    return f"A closed-loop condition could not be prepared: {why}. {change}"


def finish_study(job_id, spec: StudyJobSpec, study: Study, conditions: list[Condition]) -> tuple[list, dict, dict]:
    """The test set (disjoint from every condition's training), the closed loops' checks and the
    simulated pilot, stored with the study, which opens if the job asks.  Returns (tests, loops
    {name: stored data}, {name: what their settings came from})."""
    table = _table(spec)
    training = [c.env_ids for c in conditions]
    try:
        if spec.test_kind == Study.SHOW:  # the way, not options: nothing for the pilot to predict in the tests
            tests = select_show_tests(table, training, seed=spec.seed, difficulty=spec.test_difficulty,
                                      min_regret=spec.test_set_thresholds.get("min_regret", MIN_REGRET))
            test_set = show_tests_from_table(table, tests)
        else:
            tests = select_test_set(table, training, seed=spec.seed, difficulty=spec.test_difficulty,
                                    **spec.test_set_thresholds)
            test_set = test_set_from_table(table, tests)
    except TestSetError as exc:
        # the designer counted the environments before training; the conditions' examples took the last ones
        raise BuildRefused(f"No test set could be drawn from the environments the conditions do not train on "
                           f"({exc}). Choose another difficulty (the designer counts each level), lower the minimum "
                           "θ*-regret or distance, or fewer conditions, and build again.") from None
    settings, from_fit = closed_loop_settings(spec)
    try:
        loops = prepare_closed_loops(table, study.slug, settings, tests)  # their checks apart from the tests
    except ClosedLoopError as exc:  # the designer checked the settings; the checks and the pack need the tests
        raise BuildRefused(closed_loop_refusal(exc)) from None
    predicted = None if spec.test_kind == Study.SHOW else tests
    store_pilot(study, study_pilot(table, conditions, spec, job_id, predicted, loops))
    if loops:
        for c in study.conditions.filter(name__in=list(loops)):
            freeze_closed_loop(c, loops[c.name])
        study.source = {**study.source, SCENE_VIEW_KEY: closed_loop_view(table, [c.training for c in conditions],
                                                                         test_set, loops.values())}
        study.save(update_fields=["source"])
    freeze_test_set(study, test_set, open_study=spec.open_when_done)
    return tests, loops, from_fit
