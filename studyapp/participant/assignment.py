"""Balanced assignment of arriving participants to conditions (DESIGN §7).

Inside one transaction, with the study's row locked (``SELECT ... FOR
UPDATE`` on PostgreSQL; on SQLite the settings open every transaction with
``BEGIN IMMEDIATE``, which takes the database's single write lock), count per
condition the completed, non-excluded participants plus the unfinished ones
seen within the study's timeout (none that returned, timed out or was screened
out), and put the newcomer in the least-filled condition (relative to its
target), ties broken at random.  A returning
platform id gets its own participant back and never a second condition.
"""
from __future__ import annotations

import logging
import random
import secrets

from django.db import IntegrityError, transaction
from django.db.models import Count, Q
from django.utils import timezone

from ..conditions import aliased_pairs
from ..models import Condition, Participant, Study

logger = logging.getLogger(__name__)

_rng = random.SystemRandom()


class StudyClosed(Exception):
    pass


def counted_filter(study: Study, now=None) -> Q:
    """Participants that hold a place in their condition: finished and kept, or unfinished, seen within the
    study's timeout and (with a time limit) still within it.  One who returned the study, timed out or was
    screened out (Participant.outcome) holds none."""
    now = now or timezone.now()
    prefix = "participants__"
    active = Q(**{prefix + "completed_at__isnull": True, prefix + "last_seen_at__gte": now - study.active_timeout})
    if study.time_limit is not None:
        active &= Q(**{prefix + "started_at__gte": now - study.time_limit})
    active &= Q(**{prefix + "outcome": ""}) & ~Q(**{prefix + "platform": Participant.PREVIEW})
    return Participant.complete_filter(prefix) | active


def counted_conditions(study: Study):
    """The study's conditions, each annotated with n = the participants holding a place in it."""
    # through the study's own manager: each condition's .study is `study` itself, so target_count costs no
    # query and no second decode of the study's JSON (at every arrival, under the study's lock)
    return study.conditions.annotate(n=Count("participants", filter=counted_filter(study)))


def condition_counts(study: Study) -> dict[int, int]:
    return {c.pk: c.n for c in counted_conditions(study)}


def pick_condition(study: Study) -> Condition:
    # Without the training examples (the largest JSON a condition stores): choosing reads names, targets and
    # counts, and decoding every condition's examples at every arrival cost more than the choice, under the
    # study's lock.  The arrival's condition reads them when its flow first needs them.
    conditions = list(counted_conditions(study).defer("training"))
    if not conditions:
        raise ValueError(f"study {study.slug} has no conditions")
    if aliased_pairs([c.name for c in conditions]):
        # two names of one condition (a study stored before creating one refused that): its
        # participants would be one group to the analysis, so it takes no one (Study.opening_problems)
        raise StudyClosed(study.slug)
    fill = {c.pk: c.n / max(c.target_count, 1) for c in conditions}
    least = min(fill.values())
    return _rng.choice([c for c in conditions if fill[c.pk] == least])


def option_orders(study: Study) -> list[list[int]]:
    """A fresh random display order of the options of every test."""
    rng = random.Random(secrets.randbits(64))
    orders = []
    for test in study.test_set:
        order = list(range(len(test.get("options", ()))))  # a show test has none
        rng.shuffle(order)
        orders.append(order)
    return orders


def find_returning(study: Study, platform: str, pid: str) -> Participant | None:
    if not pid:
        return None
    return Participant.objects.filter(study=study, platform=platform, platform_pid=pid).first()


def assign(study: Study, platform: str = Participant.ANONYMOUS, pid: str = "", **ids) -> Participant:
    """The participant for this arrival: the returning one, or a new one in the least-filled condition.

    Raises StudyClosed for a new arrival at a closed study.
    """
    try:
        with transaction.atomic():
            locked = Study.objects.select_for_update().get(pk=study.pk)
            existing = find_returning(locked, platform, pid)
            if existing:
                return note_session(existing, ids.get("platform_session_id", ""))
            if not locked.is_open:
                raise StudyClosed(locked.slug)
            condition = pick_condition(locked)
            session = ids.get("platform_session_id", "")
            participant = Participant.objects.create(
                study=locked, condition=condition, platform=platform, platform_pid=pid,
                option_orders=option_orders(locked), platform_session_ids=[session] if session else [], **ids)
        # row ids only: platform ids are personal data and stay out of the logs
        logger.info("assigned participant %s (%s) to condition %r of study %r", participant.pk, platform,
                    condition.name, study.slug)
        return participant
    except IntegrityError:
        # Another arrival with the same platform id won the race: return theirs.
        existing = find_returning(study, platform, pid)
        if existing is None:
            raise
        return note_session(existing, ids.get("platform_session_id", ""))


def note_session(participant: Participant, session: str) -> Participant:
    """Keep every SESSION_ID (assignmentId) a returning participant arrives with: Prolific gives a
    new one when they restart, and paying or querying them needs each."""
    if not session or session in participant.platform_session_ids:
        return participant
    with transaction.atomic():
        locked = Participant.objects.select_for_update().get(pk=participant.pk)
        if session not in locked.platform_session_ids:
            locked.platform_session_ids = [*locked.platform_session_ids, session]
            locked.save(update_fields=["platform_session_ids"])
    participant.platform_session_ids = locked.platform_session_ids
    return participant


def preview_participant(condition: Condition) -> Participant:
    """A staff preview of one condition: a participant that is never counted or exported."""
    return Participant.objects.create(
        study=condition.study, condition=condition, platform=Participant.PREVIEW,
        option_orders=option_orders(condition.study))
