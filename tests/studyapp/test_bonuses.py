"""Performance bonuses (studyapp/participant/bonuses.py): computed once when a participant finishes, shown on the
completion page, totalled on the dashboard and written as Prolific's bulk-bonus lines and an MTurk list,
equal to a count made by hand from what each simulated participant chose."""
from __future__ import annotations

import csv
import hashlib
import html
import io
from decimal import Decimal
from fractions import Fraction

import pytest
from django.urls import reverse
from django.utils import translation

from studyapp.models import Participant, StepKind
from studyapp.participant import bonuses, flow
from studyapp.participant.assignment import assign
from studyapp.researcher import specschema
from studyapp.researcher.specschema import SpecError
from tests.conftest import complete_flow
from tests.studyapp.helpers import answer_url, design_form, step_url

# complete_flow rates the option it picks 6 when it is θ*'s and the others 2: a wrong pick scores -2.
RIGHT, WRONG = 6, -2


@pytest.fixture
def paying(make_study):
    return make_study(slug="paying", recruitment="prolific", bonus_per_correct=0.10, bonus_per_point=0.02,
                      bonus_cap=0.75)


def choices_with(study, n_right: int) -> list[int]:
    """Option indices for every test: θ*'s in the first `n_right`, another option in the rest."""
    out = []
    for j, test in enumerate(study.test_set):
        star = next(k for k, o in enumerate(test["options"]) if o["is_theta_star"])
        out.append(star if j < n_right else (star + 1) % len(test["options"]))
    return out


def by_hand(n_right: int, n_tests: int) -> str:
    """0.10 a correct test + 0.02 a point of the total score (never below 0), at most 0.75, to the cent."""
    score = RIGHT * n_right + WRONG * (n_tests - n_right)
    pounds = min(Fraction(10, 100) * n_right + Fraction(2, 100) * max(score, 0), Fraction(75, 100))
    cents = int(pounds * 100 + Fraction(1, 2))  # half up
    return f"{cents // 100}.{cents % 100:02d}"


def test_the_bulk_bonus_files_equal_a_count_by_hand(paying):
    n_tests = len(paying.test_set)
    expected = {}
    for n_right in range(n_tests + 1):
        pid = f"prolific{n_right}"
        complete_flow(assign(paying, Participant.PROLIFIC, pid), choices=choices_with(paying, n_right))
        if by_hand(n_right, n_tests) != "0.00":
            expected[pid] = by_hand(n_right, n_tests)
    worker = complete_flow(assign(paying, Participant.MTURK, "worker1", platform_session_id="ASSIGN1"),
                           choices=choices_with(paying, n_tests))
    complete_flow(assign(paying, Participant.PROLIFIC, "inattentive"), attentive=False)  # excluded: no bonus
    complete_flow(assign(paying, Participant.PROLIFIC, "halfway"), stop_before=StepKind.ATTENTION)  # unfinished

    lines = bonuses.prolific_lines(paying).splitlines()
    assert dict(line.split(",") for line in lines) == expected
    assert len(expected) >= 3 and "0.75" in expected.values()  # some capped, some not, some nothing
    mturk = list(csv.reader(io.StringIO(bonuses.mturk_csv(paying))))
    assert mturk == [list(bonuses.MTURK_HEADER),
                     ["worker1", "ASSIGN1", by_hand(n_tests, n_tests), "Performance bonus for study paying"]]
    assert worker.bonus == Decimal(by_hand(n_tests, n_tests))
    assert Participant.objects.get(platform_pid="inattentive").bonus == 0
    assert Participant.objects.get(platform_pid="halfway").bonus is None
    total = sum(Decimal(v) for v in expected.values()) + worker.bonus
    assert bonuses.totals(paying) == {"n": len(expected) + 1, "total": total, "label": f"£{total}"}


def test_a_bonus_is_set_once_and_never_changes(paying, client):
    client.get(reverse("entry", args=[paying.slug]), {"PROLIFIC_PID": "once", "STUDY_ID": "S", "SESSION_ID": "X"})
    p = Participant.objects.get(platform_pid="once")
    last = flow.steps_for(p)[-2]
    p = complete_flow(p, choices=choices_with(paying, 2), stop_before=last.kind)
    body = {"age": "34", "gender": "female"}
    assert client.post(answer_url(p, last.index), body).status_code == 302
    first = Participant.objects.get(pk=p.pk).bonus
    assert first == Decimal(by_hand(2, len(paying.test_set)))
    page = client.get(step_url(p)).content.decode()
    assert f"you earned a bonus of <strong>£{first}</strong>" in page
    assert client.post(answer_url(p, last.index), body).status_code == 302  # the same POST again
    client.get(step_url(p))  # a reload
    paying.bonus_per_correct, paying.bonus_cap = Decimal("5"), Decimal("50")  # the study's rates changed later
    paying.save()
    assert Participant.objects.get(pk=p.pk).bonus == first
    assert bonuses.prolific_lines(paying) == f"once,{first}\n"


def test_the_dashboard_totals_the_bonuses_and_serves_the_files(paying, staff_client):
    complete_flow(assign(paying, Participant.PROLIFIC, "dash1"), choices=choices_with(paying, 3))
    page = staff_client.get(reverse("dashboard_study", args=[paying.slug])).content.decode()
    one = Participant.objects.get(platform_pid="dash1").bonus
    assert f"<strong>£{one}</strong> to\n  1 participant." in page
    r = staff_client.get(reverse("dashboard_export", args=[paying.slug, "bonuses-prolific"]))
    assert r.content.decode() == f"dash1,{one}\n" and "bonuses-prolific" in r["Content-Disposition"]
    r = staff_client.get(reverse("dashboard_export", args=[paying.slug, "bonuses-mturk"]))
    assert r.content.decode().splitlines() == [",".join(bonuses.MTURK_HEADER)]


def test_a_study_without_a_bonus_says_nothing_of_one(study, client):
    p = complete_flow(assign(study, Participant.PROLIFIC, "plain"))
    assert p.bonus == 0 and 'id="bonus"' not in client.get(step_url(p)).content.decode()


def test_an_id_that_looks_like_a_formula_is_neutralised(paying):
    complete_flow(assign(paying, Participant.PROLIFIC, "=HYPERLINK(1)"), choices=choices_with(paying, 1))
    assert bonuses.prolific_lines(paying).startswith("'=HYPERLINK(1),")


@pytest.mark.parametrize("fields, says", [
    ({"bonus_cap": 2}, "a bonus cap needs a bonus to cap"),
    ({"bonus_per_correct": 0.1, "bonus_cap": -1}, "'bonus_cap' must be a number from 0 to 100"),
    ({"bonus_per_correct": 0.1, "bonus_cap": 5000}, "'bonus_cap' must be a number from 0 to 100"),
    ({"bonus_per_correct": -0.5}, "'bonus_per_correct' must be a number from 0 to 100"),
    ({"bonus_per_point": "lots"}, "'bonus_per_point' must be a number"),
    ({"bonus_per_correct": 0.1, "bonus_currency": "BTC"}, "bonus_currency"),
])
def test_bad_bonuses_are_one_line_refusals(make_study, fields, says):
    with pytest.raises(SpecError, match=says) as refused:
        make_study(slug="bad", **fields)
    assert "\n" not in str(refused.value)


def test_the_designer_takes_a_bonus_and_refuses_a_cap_without_one(db, tiny_table):
    form = design_form(tiny_table, bonus_per_correct="0.05", bonus_cap="0.5", bonus_currency="USD")
    assert form.is_valid(), form.errors
    job = form.cleaned_data["job"]
    assert (job["bonus_per_correct"], job["bonus_cap"], job["bonus_currency"]) == (0.05, 0.5, "USD")
    for bad, field, says in ((dict(bonus_cap="3"), "bonus_cap", "a bonus cap needs a bonus to cap"),
                             (dict(bonus_per_correct="0.1", bonus_cap="-2"), "bonus_cap", "0"),
                             (dict(bonus_per_correct="0.1", bonus_cap="9999"), "bonus_cap", "100")):
        form = design_form(tiny_table, **bad)
        assert not form.is_valid()
        (message,) = form.errors[field]
        assert says in message and "\n" not in message


def test_show_tests_have_no_confidence_to_pay_for():
    _, found = specschema.job_problems({"slug": "shown", "test_kind": "show", "bonus_per_point": 0.1})
    assert [(str(p), p.field) for p in found] == [
        ("tests that show the way have no confidence score: pay a bonus per correct test instead", "bonus_per_point")]


def test_a_participant_reads_the_amount_in_the_studys_language(paying):
    with translation.override("de"):
        assert bonuses.participant_label(paying, Decimal("1.2")) == "1,20\u00a0£"
    with translation.override("en"):
        assert bonuses.participant_label(paying, Decimal("1.2")) == "£1.20"
    assert bonuses.label(paying, Decimal("1.2")) == "£1.20"  # the researchers' pages and the files


def test_the_consent_page_states_the_bonus_rule_before_anyone_agrees(paying, study, client):
    """What a participant is paid for, in the study's language, every amount formatted the one way the
    completion page formats it (bonuses.participant_label); a study without a bonus says nothing of one."""
    rule = ("£0.10 for each test question you answer correctly and £0.02 for each point of the confidence you give "
            "your test answers (a wrong answer's confidence counts against you), at most £0.75 in all, on top of "
            "the payment.")
    page = html.unescape(client.get(step_url(assign(paying, Participant.PROLIFIC, "reader"))).content.decode())
    assert f"<dd data-bonus-rule>{rule}</dd>" in page
    paying.language = "de"
    paying.save(update_fields=["language"])
    page = html.unescape(client.get(step_url(assign(paying, Participant.PROLIFIC, "leser"))).content.decode())
    assert ("0,10\u00a0£ für jede Testfrage, die Sie richtig beantworten und 0,02\u00a0£ für jeden Punkt der "
            "Sicherheit") in page and "insgesamt höchstens 0,75\u00a0£, zusätzlich zur Bezahlung." in page
    plain = client.get(step_url(assign(study, Participant.PROLIFIC, "plain"))).content.decode()
    assert "data-bonus-rule" not in plain and bonuses.rule_text(study) == ""


def test_the_consent_version_names_the_bonus_rule_and_keeps_a_study_without_one(paying, study):
    """A changed rate or payment is a changed consent page; a study without either keeps the version it had."""
    shown = [*study.consent_paragraphs(), str(study.estimated_minutes), study.payment, study.contact,
             study.ethics_reference]
    assert study.consent_version() == hashlib.sha256("\x1f".join(shown).encode()).hexdigest()[:12]
    before = paying.consent_version()
    paying.bonus_per_correct = Decimal("0.20")
    paying.save(update_fields=["bonus_per_correct"])
    paying.refresh_from_db()
    assert paying.consent_version() != before
    before = paying.consent_version()
    paying.payment_amount = Decimal("2.50")  # an amount the page now writes
    paying.save(update_fields=["payment_amount"])
    paying.refresh_from_db()
    assert paying.consent_version() != before
