"""Who reaches what: researcher pages only for staff, a participant token only its own
participant, participant text escaped on every page, exports safe from CSV formula injection
(docs/decisions.md, "Security")."""
import csv
import io
import re

import pytest
from django.test import Client
from django.urls import reverse

from precompute.models import Job
from studyapp.data import exports
from studyapp.models import Answer, Participant, StepKind, Study
from studyapp.participant import assignment
from tests.studyapp.helpers import answer_url, record, snapshot, step_url

pytestmark = pytest.mark.django_db
XSS = "<script>alert(\"x\")</script>'\"&"


# --- access control ---------------------------------------------------------------------------
def staff_urls(study, job):
    cond = study.conditions.first()
    gets = [reverse("dashboard"), reverse("dashboard_study", args=[study.slug]),
            reverse("dashboard_progress", args=[study.slug]), reverse("dashboard_analysis", args=[study.slug]),
            *(reverse("dashboard_export", args=[study.slug, k]) for k in ("long", "wide", "dictionary")),
            reverse("precompute:jobs"), reverse("precompute:job", args=[job.pk]),
            reverse("precompute:job_status", args=[job.pk])]
    posts = [reverse("dashboard_toggle", args=[study.slug]),
             reverse("dashboard_preview", args=[study.slug, cond.pk]),
             reverse("precompute:job_retry", args=[job.pk])]
    return gets, posts


@pytest.mark.parametrize("who", ["anonymous", "non-staff"])
def test_researcher_pages_refuse_everyone_but_staff(study, django_user_model, who):
    job = Job.objects.create(kind=Job.STUDY, params={"slug": study.slug}, status=Job.FAILED, error="boom")
    c = Client()
    if who == "non-staff":
        c.force_login(django_user_model.objects.create_user("plain", password="pw-plain-123"))
    gets, posts = staff_urls(study, job)
    for url in gets:
        r = c.get(url)
        assert r.status_code == 302 and r["Location"].startswith("/login/"), url
    for url in posts:
        r = c.post(url, {"open": "0"})
        assert r.status_code == 302 and r["Location"].startswith("/login/"), url
    job.refresh_from_db()
    assert Study.objects.get().is_open and not Participant.objects.exists() and job.attempts == 0


def test_staff_reach_every_researcher_page(staff_client, study):
    job = Job.objects.create(kind=Job.STUDY, params={"slug": study.slug}, status=Job.FAILED, error="boom")
    for url in staff_urls(study, job)[0]:
        assert staff_client.get(url).status_code == 200, url


def test_a_token_reaches_only_its_own_participant(client, make_study, complete):
    a_study, b_study = make_study("a"), make_study("b")
    mine = assignment.assign(a_study, "prolific", "MINE-pid")
    theirs = complete(assignment.assign(a_study, "prolific", "THEIRS-pid"))
    other = assignment.assign(b_study, "prolific", "OTHER-pid")
    before = snapshot()
    # a token under another study's slug is unknown there
    assert client.get(reverse("step", args=["b", mine.token])).status_code == 404
    assert client.post(reverse("answer", args=["b", mine.token, 0]), {"consent": "yes"}).status_code == 404
    assert client.post(reverse("answer", args=["a", other.token, 0]), {"consent": "yes"}).status_code == 404
    assert snapshot() == before
    # my page shows nothing of the finished participant, my answer moves only me
    page = client.get(step_url(mine)).content
    assert theirs.completion_code.encode() not in page and theirs.token.encode() not in page
    assert b"THEIRS-pid" not in page and b"MINE-pid" not in page
    assert client.post(answer_url(mine), {"consent": "yes"}).status_code == 302
    assert [(a.participant_id, a.step) for a in Answer.objects.exclude(participant=theirs)] == [(mine.pk, 0)]
    theirs_after = Participant.objects.get(pk=theirs.pk)
    assert (theirs_after.position, theirs_after.completed_at) == (theirs.position, theirs.completed_at)


# --- escaping and CSV injection ---------------------------------------------------------------
def test_participant_text_is_escaped_on_every_page(client, admin_client, study, complete):
    q = {"workerId": XSS, "assignmentId": XSS, "hitId": XSS, "turkSubmitTo": "https://www.mturk.com"}
    assert client.get(reverse("entry", args=[study.slug]), q).status_code == 302
    turk = complete(Participant.objects.get(), stop_before=StepKind.DEMOGRAPHICS)
    turk = record(turk, turk.position, age="30", gender="other", gender_text=XSS)
    prolific = complete(assignment.assign(study, "prolific", XSS, platform_study_id=XSS, platform_session_id=XSS))
    escaped = b"&lt;script&gt;alert(&quot;x&quot;)&lt;/script&gt;&#x27;&quot;&amp;"
    shown = {  # page -> must it show the text (escaped)?
        step_url(turk): True,  # the MTurk completion form carries assignmentId
        step_url(prolific): False,
        reverse("dashboard"): False, reverse("dashboard_study", args=[study.slug]): False,
        reverse("dashboard_progress", args=[study.slug]): False,
        reverse("dashboard_analysis", args=[study.slug]): False,
        reverse("admin:studyapp_participant_changelist"): True,
        reverse("admin:studyapp_participant_changelist") + "?q=script": True,
        reverse("admin:studyapp_participant_change", args=[prolific.pk]): True,
        reverse("admin:studyapp_participant_change", args=[turk.pk]): True,
        reverse("admin:studyapp_answer_changelist"): True,
        reverse("admin:studyapp_answer_change", args=[Answer.objects.get(participant=turk,
                                                                          kind=StepKind.DEMOGRAPHICS).pk]): False,
    }
    for url, must_show in shown.items():
        r = (client if "/p/" in url else admin_client).get(url)
        assert r.status_code == 200, url
        assert b"<script>alert" not in r.content, url
        if must_show:
            assert escaped in r.content, url
    demo = admin_client.get(reverse("admin:studyapp_answer_change", args=[
        Answer.objects.get(participant=turk, kind=StepKind.DEMOGRAPHICS).pk])).content
    assert b"&lt;script&gt;alert(" in demo  # gender_text inside the stored JSON, escaped


def test_exports_neutralise_formulas_but_not_numbers(staff_client, study, complete):
    wrong = [next(k for k, o in enumerate(t["options"]) if not o["is_theta_star"]) for t in study.test_set]
    p = complete(assignment.assign(study, "prolific", "=HYPERLINK(\"http://x\")", platform_study_id="+1",
                                   platform_session_id="-2"), choices=wrong, stop_before=StepKind.DEMOGRAPHICS)
    record(p, p.position, age="30", gender="other", gender_text="@SUM(A1)")
    complete(assignment.assign(study, "prolific", "\tTAB", platform_session_id="\rCR"))
    wide = list(csv.DictReader(io.StringIO(
        staff_client.get(reverse("dashboard_export", args=[study.slug, "wide"])).getvalue().decode())))
    row = next(r for r in wide if r["participant_id"] == str(p.pk))
    assert (row["platform_pid"], row["platform_study_id"], row["platform_session_id"], row["gender_text"]) == (
        "'=HYPERLINK(\"http://x\")", "'+1", "'-2", "'@SUM(A1)")
    tab = next(r for r in wide if r["participant_id"] != str(p.pk))
    assert (tab["platform_pid"], tab["platform_session_id"]) == ("'\tTAB", "'\rCR")
    scores = [row[f"test{j}_confidence_score"] for j in range(6)]
    assert scores == ["-2"] * 6  # chosen option rated 2, not theta*'s: untouched negative numbers
    assert float(row["mean_confidence_score"]) == pytest.approx(sum(map(int, scores)) / 6)
    long = list(csv.DictReader(io.StringIO(exports.long_csv(study))))
    negative = [r["confidence_score"] for r in long if r["confidence_score"].startswith("-")]
    assert negative and all(re.fullmatch(r"-[1-7]", s) for s in negative)
    assert exports.neutralise(-5) == -5 and exports.neutralise(-0.5) == -0.5 and exports.neutralise("ok") == "ok"
