"""Recruitment and per-study texts: Prolific needs the study's own completion code,
every SESSION_ID a participant arrives with is kept, and the consent page shows the study's texts."""
import pytest
from django.core.exceptions import ValidationError
from django.urls import reverse

from studyapp.models import Participant, Study
from studyapp.researcher import studies
from teaching.api import get_domain
from tests.studyapp.helpers import snapshot

DEFAULT_CONSENT = get_domain("driving").texts.consent

pytestmark = pytest.mark.django_db


def entry(client, study, **params):
    return client.get(reverse("entry", args=[study.slug]), params)


def test_prolific_arrivals_at_a_study_without_a_code_are_turned_away(client, make_study):
    study = make_study("nocode", completion_code="")
    before = snapshot()
    r = entry(client, study, PROLIFIC_PID="pp1", STUDY_ID="st", SESSION_ID="se")
    assert r.status_code == 503 and b"not ready for Prolific participants yet" in r.content
    assert snapshot() == before  # nobody assigned: they would have been sent back with an unpayable code
    assert entry(client, study).status_code == 302  # a plain link still works


def test_a_prolific_study_cannot_open_without_its_completion_code(staff_client, make_study):
    spec_error = "Prolific only accepts its study's own completion code"
    with pytest.raises(studies.SpecError, match=spec_error):
        make_study("p1", recruitment="prolific", completion_code="")
    with pytest.raises(studies.SpecError, match="'recruitment' must be one of link, prolific, mturk"):
        make_study("p2", recruitment="facebook")
    study = make_study("p3", recruitment="prolific", completion_code="C0DE", is_open=False)
    # the admin's form validation (Model.clean) refuses it too
    study.completion_code, study.is_open = "", True
    with pytest.raises(ValidationError, match=spec_error):
        study.full_clean()
    study.save(update_fields=["completion_code"])
    # the dashboard's "Open study" refuses, says why, and leaves it closed
    r = staff_client.post(reverse("dashboard_toggle", args=["p3"]), {"open": "1"}, follow=True)
    assert spec_error.encode() in r.content.replace(b"&#x27;", b"'")
    assert not Study.objects.get(slug="p3").is_open
    Study.objects.filter(slug="p3").update(completion_code="C0DE")
    staff_client.post(reverse("dashboard_toggle", args=["p3"]), {"open": "1"})
    assert Study.objects.get(slug="p3").is_open


def test_dashboard_shows_the_code_and_the_exact_completion_url(staff_client, make_study):
    make_study("coded", recruitment="prolific", completion_code="C0DE123")
    page = staff_client.get(reverse("dashboard_study", args=["coded"])).content.decode()
    assert '<code id="completion-code">C0DE123</code>' in page
    assert '<code id="completion-url">https://app.prolific.com/submissions/complete?cc=C0DE123</code>' in page
    make_study("uncoded", completion_code="")
    page = staff_client.get(reverse("dashboard_study", args=["uncoded"])).content.decode()
    assert 'id="no-completion-code"' in page and "Prolific participants are" in page


def test_every_session_id_a_participant_arrives_with_is_kept(client, study):
    entry(client, study, PROLIFIC_PID="pp1", STUDY_ID="st", SESSION_ID="first")
    entry(client, study, PROLIFIC_PID="pp1", STUDY_ID="st", SESSION_ID="second")  # restarted on Prolific
    entry(client, study, PROLIFIC_PID="pp1", STUDY_ID="st", SESSION_ID="first")   # back in the first tab
    p = Participant.objects.get()
    assert p.platform_session_ids == ["first", "second"]
    assert p.platform_session_id == "first"  # the first arrival's, as before
    entry(client, study, workerId="W1", assignmentId="A1", hitId="H")
    entry(client, study, workerId="W1", assignmentId="A2", hitId="H")
    assert Participant.objects.get(platform_pid="W1").platform_session_ids == ["A1", "A2"]


def test_consent_page_shows_the_studys_own_texts(client, make_study):
    study = make_study("texts", consent_text="First approved paragraph.\n\nSecond, with a\nline break.",
                       estimated_minutes=9, payment="£1.80 through Prolific",
                       contact="Dr A. Researcher, a.researcher@example.org", ethics_reference="ERC-2026-117")
    page = client.get(entry(client, study)["Location"]).content.decode()
    assert "<p>First approved paragraph.</p>" in page and "<p>Second, with a<br>line break.</p>" in page
    for text in ("About 9 minutes.", "£1.80 through Prolific", "a.researcher@example.org", "ERC-2026-117"):
        assert text in page
    assert DEFAULT_CONSENT[:40] not in page


def test_consent_page_defaults(client, make_study):
    study = make_study("plain")
    page = client.get(entry(client, study)["Location"]).content.decode()
    assert DEFAULT_CONSENT.split("\n\n")[0][:60] in page and "About 15 minutes." in page
    assert "Payment" not in page and "Ethics approval" not in page  # nothing shown that was not set


@pytest.mark.slow
def test_the_demo_study_sets_a_completion_code(demo_table):
    spec = studies.demo_spec(demo_table)
    assert spec["completion_code"] == studies.DEMO_COMPLETION_CODE
