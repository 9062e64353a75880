"""Closed-loop conditions on the web side: built with the study, decided per participant.

A closed-loop condition has no fixed training sequence.  A spec names one as
``{"name": "closed-loop", "closed_loop": {"model": "det-euclidean", "check_every": 2, ...}}``
(teaching's ClosedLoopSpec; every setting has a default).  When the study is built:

* its check questions are drawn as the final tests are, on environments the final tests leave over
  (teaching's select_checks), and stored with their options' paths, as the test set is; in a study whose
  tests show the way, its checks ask to show the way too (select_show_checks), stored with every
  distinct way the table's θ take there, which the participant's way is matched against;
* what its decisions need is written once, as a pack under ``VAR_DIR/closedloop/`` (teaching's
  write_pack): the learner model's likelihood matrix, the checks' answer likelihoods and θ*'s
  trajectory in every environment.  Every web worker maps the same files read-only.

While the study runs, the step a participant stands on is decided from their stored steps and check
answers (teaching's ClosedLoop.decide), stored once as a LoopStep (unique per participant and index),
and served from there on: a reload, Back, a double click or a second tab reads the stored decision.
"""
from __future__ import annotations

import logging
import random
import re
import secrets
import time
from functools import lru_cache
from pathlib import Path

import numpy as np
from django.conf import settings
from django.db import IntegrityError, transaction

from teaching.api import (
    ClosedLoop,
    ClosedLoopError,
    ClosedLoopSpec,
    Decision,
    Event,
    TrajectoryTable,
    check_questions,
    load_pack,
    select_checks,
    select_show_checks,
    write_pack,
)

from .. import trajectories
from ..models import Answer, LoopStep, Participant, StepKind

logger = logging.getLogger(__name__)

SPEC_KEY = "closed_loop"
STEP_KINDS = {LoopStep.EXAMPLE: StepKind.TRAINING, LoopStep.CHECK: StepKind.CHECK,
              LoopStep.FEEDBACK: StepKind.FEEDBACK}


def is_closed_loop(condition) -> bool:
    return bool(condition.closed_loop)


def max_checks(data: dict) -> int:
    """The most check questions a closed-loop condition (its Condition.closed_loop) asks a participant: one
    after every ``check_every`` examples, as long as unasked questions are left (teaching's ClosedLoop.decide)."""
    s = data["settings"]
    return min(len(data["checks"]), s["max_examples"] // s["check_every"]) if s["check_every"] else 0


def pack_dir(slug: str, name: str, table_hash: str) -> Path:
    safe = re.sub(r"[^A-Za-z0-9_-]+", "_", name)
    return Path(settings.VAR_DIR) / "closedloop" / f"{slug}--{safe}--{table_hash[:12]}"


def prepare(table, slug: str, name: str, loop_settings: dict, tests: list[dict]) -> dict:
    """Build closed-loop condition `name` of study `slug` on `table` (its final `tests` as
    select_test_set gives them): write its pack and return what Condition.closed_loop stores.
    ClosedLoopError (one line) for bad settings or a table that leaves no check question."""
    if not isinstance(loop_settings, dict):
        raise ClosedLoopError(f"condition {name!r}: 'closed_loop' must be an object of settings")
    spec = ClosedLoopSpec.from_dict(loop_settings)
    shown = trajectories.test_kind_of(tests) == trajectories.SHOW  # its checks ask what its tests ask
    checks = select_show_checks(table, tests) if shown else select_checks(table, tests)
    loop = ClosedLoop.build(table, spec, check_questions(table, checks),
                            exclude=[table.row_of[int(t["env_id"])] for t in tests])
    table_hash = table.meta["content_hash"]
    path = pack_dir(slug, name, table_hash)
    write_pack(path, table, loop)
    return {"settings": spec.as_dict(), "pack": str(path), "table_hash": table_hash,
            "checks": show_checks(table, checks) if shown else trajectories.test_set_from_table(table, checks),
            "eligible": int(np.count_nonzero(loop.eligible))}


def show_checks(table, checks: list[dict]) -> list[dict]:
    """Payloads of checks that ask to show the way: a show test's, and the ``ways`` the answer is matched
    against (each distinct trajectory of the table there, in the check Question's order; never sent to
    the page)."""
    out = trajectories.show_tests_from_table(table, checks)
    for payload, check in zip(out, checks, strict=True):
        i = table.row_of[int(check["env_id"])]
        payload["ways"] = [{"theta_index": int(t), "robot": table.domain.path_rows(table.states(i, int(t)))}
                           for t in check["ways"]]
    return out


def way_index(check: dict, rows: list) -> int:
    """Which of a show check's ways the participant's way is (its rows, as the domain's score_shown gives
    them); len(ways) when it is none of them: the closed loop's answer."""
    return next((k for k, w in enumerate(check["ways"]) if w["robot"] == rows), len(check["ways"]))


def example_scenes(table, data: dict) -> list[tuple[dict, list]]:
    """(page scene, robot path) of every example the condition may show: the study's view (one scale
    for every canvas) must hold them all, whichever a participant gets."""
    pack = pack_of_data(data)
    domain = table.domain
    rows = np.flatnonzero(pack.loop.eligible)
    payloads = [example_payload(domain, pack, int(r)) for r in rows]
    payloads += data["checks"]
    return [(domain.page_scene(p), p["robot"]) for p in payloads]


@lru_cache(maxsize=32)
def _load(path: str, table_hash: str):
    return load_pack(path, expected_hash=table_hash)


def pack_of_data(data: dict):
    return _load(data["pack"], data["table_hash"])


def warm_packs() -> int:
    """Map the pack of every open study's closed-loop condition, so that no participant's first decision in a
    new web worker waits for it (config/gunicorn.conf.py, post_worker_init); returns how many.  A pack that
    cannot be read is logged and left to the request, which says so."""
    from django.db import DatabaseError  # noqa: PLC0415

    from ..models import Condition  # noqa: PLC0415

    n = 0
    try:
        loops = list(Condition.objects.filter(study__is_open=True, closed_loop__isnull=False)
                     .values_list("closed_loop", flat=True))
        for data in filter(None, loops):
            try:
                pack_of_data(data)
                n += 1
            except (OSError, ValueError, KeyError) as exc:
                logger.warning("closed-loop pack %s not mapped at start: %s", data.get("pack"), exc)
    except DatabaseError as exc:  # the database is down at boot: the requests will map them
        logger.warning("closed-loop packs not mapped at start: %s", exc)
    return n


def example_payload(domain, pack, row: int) -> dict:
    """What the page draws of θ*'s trajectory in table row `row` (a training example's payload)."""
    return trajectories.env_payload(domain, int(pack.env_ids[row]), int(pack.env_class[row]),
                                    np.asarray(pack.star_states[row]), int(pack.star_cluster[row]),
                                    TrajectoryTable.theta_star_index)


# --- per participant ------------------------------------------------------------------------------
def events_of(participant: Participant, steps: list[LoopStep]) -> list[Event]:
    """The participant's closed-loop events: what `steps` showed them and what they answered, up to the
    first check they have not answered yet."""
    pack = pack_of_data(participant.condition.closed_loop)
    answers = dict(Answer.objects.filter(participant=participant, kind=StepKind.CHECK)
                   .values_list("item", "data"))
    checks = participant.condition.closed_loop["checks"]
    events = []
    for s in steps:
        if s.kind == LoopStep.DONE or (s.kind == LoopStep.CHECK and s.index not in answers):
            break
        row = pack.row_of(s.env_id)
        if s.kind == LoopStep.CHECK:
            answer = check_answer(participant, checks[s.question], answers[s.index])
            events.append(Event(s.kind, row, s.question, answer))
        else:
            events.append(Event(s.kind, row))
    return events


def check_answer(participant: Participant, check: dict, data: dict) -> int:
    """The closed loop's answer to a check from what the participant sent (Answer.data): the option chosen,
    or for a shown way which of the check's ways it is, replayed again (nothing derived is trusted)."""
    if "moves" in data:
        rows = trajectories.study_domain(participant.study).score_shown(check["env_id"], data["moves"])["rows"]
        return way_index(check, rows)
    return int(data["choice"])


def loop_steps(participant: Participant, first_step: int) -> list[LoopStep]:
    """The participant's stored loop steps, the one they stand on decided and stored first if it was not
    (their flow's loop steps start at index `first_step`)."""
    steps = list(participant.loop_steps.all())
    finished = steps and steps[-1].kind == LoopStep.DONE
    if finished or participant.position != first_step + len(steps):
        return steps
    return steps + [_decide(participant, steps)]


def _decide(participant: Participant, steps: list[LoopStep]) -> LoopStep:
    data = participant.condition.closed_loop
    pack = pack_of_data(data)
    t0 = time.perf_counter()
    events = events_of(participant, steps)
    if len(events) != len(steps):
        raise ClosedLoopError(f"participant {participant.pk}: a check before loop step {len(steps)} has no answer")
    decision = pack.loop.decide(events)
    seconds = time.perf_counter() - t0
    step = LoopStep(participant=participant, index=len(steps), kind=decision.kind, decision=decision.as_dict(),
                    seconds=seconds)
    if decision.env_index is not None:
        step.env_id = int(pack.env_ids[decision.env_index])
    if decision.kind in (LoopStep.EXAMPLE, LoopStep.FEEDBACK):
        domain = trajectories.study_domain(participant.study)
        step.payload = example_payload(domain, pack, decision.env_index)
    if decision.kind == LoopStep.CHECK:
        step.question = decision.question
        order = list(range(len(data["checks"][decision.question].get("options", ()))))  # a shown check: none
        random.Random(secrets.randbits(64)).shuffle(order)
        step.option_order = order
    try:
        with transaction.atomic():
            step.save()
    except IntegrityError:  # another request (a second tab, a double click) stored this step first
        return LoopStep.objects.get(participant=participant, index=len(steps))
    return step


def replay(participant: Participant) -> list[str]:
    """Recompute every stored decision of `participant` from their stored answers alone (a line per
    disagreement; none when it replays)."""
    steps = list(participant.loop_steps.all())
    events = events_of(participant, steps)
    pack = pack_of_data(participant.condition.closed_loop)
    return pack.loop.replay(events, [Decision.from_dict(s.decision) for s in steps[:len(events) + 1]])
