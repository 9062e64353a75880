"""How a participant's study ends before its last step, and the code each way of ending gives.

- **returned**: the recruiting platform says they left (:func:`mark_returned`, from the dashboard or
  ``manage.py mark_returned``);
- **timed out**: the study's time limit passed before they finished (:func:`time_up`, :func:`expire`);
- **screened out**: they failed the comprehension check too often (:func:`end`).

An outcome is written once, by a conditional UPDATE on the participant's row, so a participant who
finishes in the same instant as their time runs out is either finished or timed out, never both.  An
ended participant holds no place in their condition (assignment.counted_filter), answers nothing more
(flow.record) and sees the page of their outcome, with its code (:func:`code_for`).
"""
from __future__ import annotations

import logging
import re
from dataclasses import dataclass, field

from django.db.models import Q
from django.utils import timezone

from .. import status
from ..models import Participant, Study, new_code

logger = logging.getLogger(__name__)


def time_up(participant: Participant, now=None) -> bool:
    """Whether an unfinished participant's time (Study.time_limit) has run out.  Staff previews have none."""
    limit = participant.study.time_limit
    if limit is None or participant.completed_at is not None or participant.outcome or participant.is_preview:
        return False
    return (now or timezone.now()) > participant.started_at + limit


def end(participant: Participant, outcome: str, now=None) -> bool:
    """Set an unfinished participant's outcome (timed out or screened out) with its code; False, and nothing
    written, if they have finished or ended already (another request was first).  ``participant`` is
    updated in place either way."""
    if outcome not in (status.TIMED_OUT, status.SCREENED_OUT):
        raise ValueError(f"end() sets a timed-out or screened-out outcome, not {outcome!r}")
    now = now or timezone.now()
    code = code_for(participant, outcome)
    changed = Participant.objects.filter(pk=participant.pk, completed_at__isnull=True, outcome="").update(
        outcome=outcome, ended_at=now, completion_code=code)
    participant.refresh_from_db(fields=["outcome", "ended_at", "completion_code", "completed_at", "position"])
    if changed:
        logger.info("participant %s of study %r: %s", participant.pk, participant.study.slug, outcome)
    return bool(changed)


def check_time(participant: Participant, now=None) -> bool:
    """Time the participant out if their time is up; whether they have ended (now or before)."""
    if time_up(participant, now):
        end(participant, status.TIMED_OUT, now)
    return bool(participant.outcome)


def expire(study: Study, now=None) -> int:
    """Mark every participant of ``study`` whose time ran out as timed out (the dashboard, exports and
    analysis call this before they count, so a participant who never came back reads as timed out too).
    Returns how many were marked.  Their codes are set when they come back (:func:`code_for` needs the row)."""
    if study.time_limit is None:
        return 0
    now = now or timezone.now()
    late = (Participant.objects.filter(study=study, completed_at__isnull=True, outcome="",
                                       started_at__lt=now - study.time_limit)
            .exclude(platform=Participant.PREVIEW))
    # one by one: each gets its own code (a few per visit of the dashboard: the rest were marked before)
    return sum(end(participant, status.TIMED_OUT, now) for participant in late.select_related("study"))


def code_for(participant: Participant, outcome: str) -> str:
    """The code a participant ending with ``outcome`` (a status) is given.

    complete: the study's completion code, else the participant's own random code (a link or MTurk study);
    excluded (finished, failed the attention check): the study's excluded code, else as complete;
    screened out, timed out: the study's code for it, else an own code, except on Prolific, which only
    accepts its study's codes: there the participant is asked to return the study instead ("")."""
    study = participant.study
    own = participant.completion_code or new_code()
    if outcome == status.COMPLETE:
        return study.completion_code or own
    if outcome == status.EXCLUDED:
        return study.excluded_code or study.completion_code or own
    set_code = {status.SCREENED_OUT: study.screened_out_code, status.TIMED_OUT: study.timed_out_code}.get(outcome)
    if set_code is None:
        raise ValueError(f"no code is given for {outcome!r}")
    if set_code:
        return set_code
    return "" if participant.platform == Participant.PROLIFIC else own


@dataclass
class Returned:
    """What :func:`mark_returned` did: platform ids marked, already ended, or unknown to the study."""

    marked: list[str] = field(default_factory=list)
    already: list[str] = field(default_factory=list)
    unknown: list[str] = field(default_factory=list)

    def summary(self) -> str:
        parts = [f"{len(self.marked)} marked returned"]
        if self.already:
            parts.append(f"{len(self.already)} had ended already")
        if self.unknown:
            parts.append(f"{len(self.unknown)} not in this study ({', '.join(self.unknown[:5])}"
                         f"{', ...' if len(self.unknown) > 5 else ''})")
        return "; ".join(parts)


MAX_IDS = 10_000


def parse_ids(text: str) -> list[str]:
    """Platform ids from what a researcher pastes: one per line, or separated by commas, semicolons or
    spaces (Prolific's list of returned submissions copies that way); each once, in order."""
    ids = [t for t in re.split(r"[\s,;]+", text or "") if t]
    if len(ids) > MAX_IDS:
        raise ValueError(f"at most {MAX_IDS} ids at once (got {len(ids)})")
    return list(dict.fromkeys(ids))


def mark_returned(study: Study, ids: list[str], now=None) -> Returned:
    """Mark the participants the platform says returned the study: each id is a platform participant id
    (PROLIFIC_PID, workerId) or their latest session id (SESSION_ID, assignmentId).  Their place is freed
    at once.  A participant who has an outcome already keeps it; a finished one is marked too (they
    withdrew: the platform's word is the last)."""
    now = now or timezone.now()
    report = Returned()
    people = Participant.objects.filter(study=study).exclude(platform=Participant.PREVIEW)
    for pid in ids:
        match = people.filter(Q(platform_pid=pid) | Q(platform_session_id=pid)).first()
        if match is None:
            report.unknown.append(pid)
        elif Participant.objects.filter(pk=match.pk, outcome="").update(outcome=status.RETURNED, ended_at=now):
            report.marked.append(pid)
        else:
            report.already.append(pid)
    if report.marked:  # row ids only: platform ids are personal data and stay out of the logs
        logger.info("study %r: %d participants marked returned", study.slug, len(report.marked))
    return report
