"""Performance bonuses: what a participant earns on top of the payment, by their test answers.

A study may pay ``bonus_per_correct`` for each test answered correctly (θ*'s option; in a show study a
way that is optimal for θ*) and ``bonus_per_point`` for each point of the participant's total confidence
score (the paper's score: the rating, 1–7, of the option chosen, negated when it is not θ*'s; a total
below 0 earns nothing), the sum capped at ``bonus_cap`` (0: no cap) and rounded to the cent, half up.

A bonus is computed once, on the server, in the same transaction that stores the participant's last
answer (flow.record), and stored on their row: a reload, a replayed POST or a later change of the
study's rates never changes it.  Only a participant who finished and passed the attention check earns
one (the others' stored bonus is 0).  The bulk-bonus files (:func:`prolific_lines`, :func:`mturk_csv`)
list the participants whose status is complete and whose bonus is above 0.
"""
from __future__ import annotations

import csv
import io
from decimal import ROUND_HALF_UP, Decimal

from django.utils.formats import number_format
from django.utils.translation import gettext

from ..guards.csvsafe import neutralise
from ..models import Answer, Participant, StepKind, Study

CENT = Decimal("0.01")
SYMBOLS = {"GBP": "£", "USD": "$", "EUR": "€"}


def _money(value) -> Decimal:
    """A rate or cap as stored (a Decimal; a float straight from a spec) as an exact Decimal."""
    return value if isinstance(value, Decimal) else Decimal(str(value or 0))


def offers_bonus(study: Study) -> bool:
    return _money(study.bonus_per_correct) > 0 or _money(study.bonus_per_point) > 0


def amount(study: Study, n_correct: int, total_score: int) -> Decimal:
    """The bonus of `n_correct` correct tests and a total confidence score `total_score` (pure: the rule)."""
    earned = _money(study.bonus_per_correct) * n_correct + _money(study.bonus_per_point) * max(total_score, 0)
    cap = _money(study.bonus_cap)
    if cap > 0:
        earned = min(earned, cap)
    return earned.quantize(CENT, rounding=ROUND_HALF_UP)


def compute(participant: Participant) -> Decimal:
    """The bonus `participant` earned, from their stored test answers (0 if excluded or none is offered)."""
    study = participant.study
    if participant.excluded or not offers_bonus(study):
        return Decimal("0.00")
    tests = Answer.objects.filter(participant=participant, kind=StepKind.TEST).values_list(
        "correct", "confidence_score")
    n_correct = sum(1 for correct, _ in tests if correct)
    total = sum(score or 0 for _, score in tests)
    return amount(study, n_correct, total)


def label(study: Study, value) -> str:
    """e.g. "£1.20" (the researchers' pages and the files)."""
    return f"{SYMBOLS.get(study.bonus_currency, study.bonus_currency + ' ')}{_money(value).quantize(CENT)}"


def participant_label(study: Study, value) -> str:
    """The amount as a participant reads it in the active language: its decimal mark and where the currency
    goes come from the catalog ("£1.20" in English, "1,20 £" in German)."""
    number = number_format(_money(value).quantize(CENT), decimal_pos=2)
    symbol = SYMBOLS.get(study.bonus_currency, study.bonus_currency + " ")
    # Translators: a money amount; {symbol} is the currency's sign (£, $, €) or its code and a space,
    # {amount} the number.
    return gettext("{symbol}{amount}").format(symbol=symbol, amount=number).strip()


def rule_text(study: Study) -> str:
    """The bonus rule as the consent page says it, in the participant's language, every amount through
    :func:`participant_label`; "" when the study offers none.  E.g. "£0.10 for each test question you answer
    correctly, at most £1.00 in all, on top of the payment."."""
    if not offers_bonus(study):
        return ""
    parts = []
    if _money(study.bonus_per_correct) > 0:
        parts.append(gettext("{amount} for each test question you answer correctly").format(
            amount=participant_label(study, study.bonus_per_correct)))
    if _money(study.bonus_per_point) > 0:
        parts.append(gettext("{amount} for each point of the confidence you give your test answers (a wrong "
                             "answer's confidence counts against you)").format(
            amount=participant_label(study, study.bonus_per_point)))
    rule = gettext("{first} and {second}").format(first=parts[0], second=parts[1]) if len(parts) == 2 else parts[0]
    if _money(study.bonus_cap) > 0:
        rule = gettext("{rule}, at most {cap} in all").format(rule=rule, cap=participant_label(study, study.bonus_cap))
    return gettext("{rule}, on top of the payment.").format(rule=rule)


def researcher_rule(study: Study) -> str:
    """The bonus rule for the researchers' pages, e.g. "£0.10 per correct test, at most £1.00"; "" if none."""
    if not offers_bonus(study):
        return ""
    parts = [f"{label(study, rate)} per {what}" for rate, what in ((study.bonus_per_correct, "correct test"),
                                                                  (study.bonus_per_point, "confidence point"))
             if _money(rate) > 0]
    cap = f", at most {label(study, study.bonus_cap)}" if _money(study.bonus_cap) > 0 else ""
    return " + ".join(parts) + cap


def _paid(study: Study):
    """The participants the bulk-bonus files pay, in id order: bonus above 0 and complete (studyapp.status:
    finished, not excluded, no outcome; a participant who returned the study after finishing is not paid)."""
    return Participant.objects.filter(Participant.complete_filter(), study=study, bonus__gt=0).order_by("pk")


def totals(study: Study) -> dict:
    """{"n": participants paid a bonus, "total": their bonuses' sum, "label": the sum with its currency}."""
    bonuses = [p.bonus for p in _paid(study).only("bonus")]
    total = sum(bonuses, Decimal("0.00"))
    return {"n": len(bonuses), "total": total, "label": label(study, total)}


def csv_text(rows) -> str:
    """CSV of `rows`, every text cell through csvsafe.neutralise (an id is whatever the entry link carried)."""
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerows([neutralise(v) if isinstance(v, str) else v for v in row] for row in rows)
    return out.getvalue()


def prolific_lines(study: Study) -> str:
    """Prolific's bulk bonus box: one "participant id,amount" line each (no header), amounts in the study's
    currency with two decimals.  Only Prolific participants: the others have no Prolific id."""
    rows = _paid(study).filter(platform=Participant.PROLIFIC).values_list("platform_pid", "bonus")
    return csv_text((pid, f"{bonus:.2f}") for pid, bonus in rows)


MTURK_HEADER = ("worker_id", "assignment_id", "bonus_usd", "reason")


def mturk_csv(study: Study) -> str:
    """MTurk's SendBonus needs a worker, an assignment, an amount and a reason: one row each, under a header."""
    rows = _paid(study).filter(platform=Participant.MTURK).values_list("platform_pid", "platform_session_id", "bonus")
    return csv_text([MTURK_HEADER, *((worker, assignment, f"{bonus:.2f}", f"Performance bonus for study {study.slug}")
                                     for worker, assignment, bonus in rows)])

