"""Participants' data rights: erasing everything a participant left, and exports without platform ids.

* :func:`erase` deletes the participant rows of one platform id (a PROLIFIC_PID or MTurk workerId) in one
  study or in all, with everything stored under them (answers, closed-loop steps, comprehension attempts: the
  database cascades),
  as an EU participant may ask.  Nothing else changes: other participants, the study, its conditions and
  their places (an erased participant's place is free again).  The audit line it logs names the study,
  the participant's database id and how many rows went, never a platform id.
* :func:`pseudonym` is the stable stand-in for a platform id in an export made for sharing: an HMAC of
  the study and the id under the site's SECRET_KEY (``django.utils.crypto.salted_hmac``), so the same
  participant has the same pseudonym in every export of the study while the key stays the same, different
  participants differ, and nobody without the key can go back to the id.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass

from django.db import transaction
from django.db.models import Count
from django.utils.crypto import salted_hmac

from ..models import Answer, ComprehensionAttempt, LoopStep, Participant, Study

logger = logging.getLogger(__name__)
PSEUDONYM_SALT = "studyapp.data.privacy.pseudonym"


class ErasureError(ValueError):
    """Nothing to erase, or a request that names nothing: one line, nothing deleted."""


@dataclass(frozen=True)
class Found:
    """What an erasure would delete: per participant row, its study's slug, database id and counts."""

    rows: tuple[tuple[str, int, int, int], ...]  # (study slug, participant id, answers, loop steps)
    # each row's comprehension attempts (a study with the check: studyapp.participant.comprehension)
    attempts: tuple[int, ...] = ()

    @property
    def n_answers(self) -> int:
        return sum(r[2] for r in self.rows)

    @property
    def n_attempts(self) -> int:
        return sum(self.attempts)

    def summary(self) -> str:
        studies = sorted({r[0] for r in self.rows})
        return (f"{len(self.rows)} participant row(s) in {', '.join(studies)}: {self.n_answers} answer(s), "
                f"{sum(r[3] for r in self.rows)} closed-loop step(s)"
                + (f", {self.n_attempts} comprehension attempt(s)" if self.n_attempts else ""))


def _participants(platform_pid: str, study: Study | None):
    pid = (platform_pid or "").strip()
    if not pid:
        raise ErasureError("give the participant's platform id (their PROLIFIC_PID or MTurk workerId)")
    rows = Participant.objects.filter(platform_pid=pid).exclude(platform=Participant.PREVIEW)
    return rows.filter(study=study) if study is not None else rows


def find(platform_pid: str, study: Study | None = None) -> Found:
    """What :func:`erase` would delete for `platform_pid` (in `study`, or in every study); ErasureError
    when no participant has that id there."""
    people = list(_participants(platform_pid, study).select_related("study").order_by("pk"))
    if not people:
        where = f"study {study.slug!r}" if study is not None else "any study"
        raise ErasureError(f"no participant of {where} has that platform id; nothing was erased")
    answers = _counts(Answer, people)
    steps = _counts(LoopStep, people)
    attempts = _counts(ComprehensionAttempt, people)
    return Found(tuple((p.study.slug, p.pk, answers.get(p.pk, 0), steps.get(p.pk, 0)) for p in people),
                 tuple(attempts.get(p.pk, 0) for p in people))


def _counts(model, people) -> dict[int, int]:
    rows = model.objects.filter(participant__in=people).values("participant").annotate(n=Count("pk"))
    return {r["participant"]: r["n"] for r in rows}


def erase(platform_pid: str, study: Study | None = None) -> Found:
    """Delete every participant row of `platform_pid` (in `study`, or in every study) with all that is
    stored under it, in one transaction; returns what went.  ErasureError (nothing deleted) when there
    is none."""
    with transaction.atomic():
        found = find(platform_pid, study)
        Participant.objects.filter(pk__in=[r[1] for r in found.rows]).delete()
    for (slug, pk, n_answers, n_steps), n_attempts in zip(found.rows, found.attempts, strict=True):
        logger.info("erased participant %s of study %r at their request: %d answers, %d closed-loop steps%s",
                    pk, slug, n_answers, n_steps, f", {n_attempts} comprehension attempts" if n_attempts else "")
    return found


def pseudonym(study_slug: str, value: str) -> str:
    """A platform id's stable stand-in in `study_slug`'s exports ("" stays "")."""
    if not value:
        return ""
    return "p-" + salted_hmac(PSEUDONYM_SALT, f"{study_slug}\x1f{value}", algorithm="sha256").hexdigest()[:16]
