"""The entry link: platform ids captured, MTurk preview, anonymous entry, returning participants, closed studies."""
import pytest
from django.test import Client
from django.urls import reverse

from studyapp.models import Participant

pytestmark = pytest.mark.django_db


def entry(client, study, **params):
    return client.get(reverse("entry", args=[study.slug]), params)


def test_prolific_ids_are_captured(client, study):
    r = entry(client, study, PROLIFIC_PID="pp1", STUDY_ID="st1", SESSION_ID="se1")
    p = Participant.objects.get()
    assert r.status_code == 302 and r["Location"] == p.get_absolute_url()
    assert (p.platform, p.platform_pid, p.platform_study_id, p.platform_session_id) == ("prolific", "pp1", "st1", "se1")
    assert p.condition.study == study and p.position == 0
    assert len(p.option_orders) == len(study.test_set) == 6
    assert all(sorted(order) == [0, 1, 2, 3] for order in p.option_orders)


def test_mturk_ids_are_captured(client, study):
    entry(client, study, workerId="W1", assignmentId="A1", hitId="H1",
          turkSubmitTo="https://workersandbox.mturk.com")
    p = Participant.objects.get()
    assert (p.platform, p.platform_pid, p.platform_study_id, p.platform_session_id) == ("mturk", "W1", "H1", "A1")
    assert p.turk_submit_to == "https://workersandbox.mturk.com"


def test_mturk_preview_creates_nobody(client, study):
    r = entry(client, study, assignmentId="ASSIGNMENT_ID_NOT_AVAILABLE", hitId="H1")
    assert r.status_code == 200 and b"Accept the HIT" in r.content
    assert not Participant.objects.exists()


def test_anonymous_entry_and_same_browser_resumes(client, study):
    first = entry(client, study)
    second = entry(client, study)  # a new tab in the same browser: same session cookie
    assert first["Location"] == second["Location"]
    p = Participant.objects.get()
    assert p.platform == "anonymous" and p.platform_pid == ""


def test_anonymous_entries_from_different_browsers_are_different_people(client, study):
    entry(client, study)
    entry(Client(), study)
    assert Participant.objects.count() == 2


def test_returning_platform_id_gets_its_own_participant_back(client, study):
    entry(client, study, PROLIFIC_PID="back")
    p = Participant.objects.get()
    for _ in range(5):  # other browsers, same Prolific id
        r = entry(Client(), study, PROLIFIC_PID="back", SESSION_ID="another")
        assert r["Location"] == p.get_absolute_url()
    assert Participant.objects.count() == 1
    assert Participant.objects.get().platform_session_id == ""  # the original record is not rewritten


def test_platform_id_wins_over_an_anonymous_session(client, study):
    entry(client, study)
    entry(client, study, PROLIFIC_PID="pp2")
    assert set(Participant.objects.values_list("platform", flat=True)) == {"anonymous", "prolific"}


def test_closed_study_refuses_new_but_not_returning(client, study):
    entry(client, study, PROLIFIC_PID="early")
    study.is_open = False
    study.save()

    r = entry(Client(), study, PROLIFIC_PID="late")
    assert r.status_code == 403 and b"closed" in r.content
    assert entry(Client(), study, PROLIFIC_PID="early").status_code == 302
    assert Participant.objects.count() == 1


@pytest.mark.parametrize("params", [
    {"PROLIFIC_PID": "x" * 101},
    {"workerId": "W", "assignmentId": "A", "turkSubmitTo": "https://evil.example.com"},
])
def test_bad_platform_parameters_are_400(client, study, params):
    r = entry(client, study, **params)
    assert r.status_code == 400
    assert not Participant.objects.exists()


@pytest.mark.parametrize("submit_to", [  # each got past a hostname check, or would
    "javascript://www.mturk.com/%0Aalert(document.domain)",  # script on this site (the form's action)
    "https://evil.example\\@www.mturk.com/",  # a browser reads the backslash as a slash: evil.example
    "https://evil.example@www.mturk.com/",  # userinfo
    "https://user:pw@www.mturk.com",
    "data:text/html,<script>alert(1)</script>",
    "http://www.mturk.com",  # not https
    "https://www.mturk.com:8443",
    "https://www.mt\turk.com",  # browsers drop tabs and newlines inside a URL
    "https://www.mturk.com/\nx",
    "https://www.mturk.com.evil.example",
    "https://www.mturk.com/mturk/externalSubmit?x=1",
    "//www.mturk.com",
])
def test_turk_submit_to_only_ever_an_mturk_site(client, study, submit_to):
    r = entry(client, study, workerId="W", assignmentId="A", hitId="H", turkSubmitTo=submit_to)
    assert r.status_code == 400 and b"turkSubmitTo must be" in r.content
    assert not Participant.objects.exists()


@pytest.mark.parametrize("submit_to, stored", [
    ("https://www.mturk.com", "https://www.mturk.com"),
    ("https://www.mturk.com/", "https://www.mturk.com"),
    ("HTTPS://WorkerSandbox.MTurk.com", "https://workersandbox.mturk.com"),
    (" https://www.mturk.com\t", "https://www.mturk.com"),  # ids are trimmed of surrounding space first
])
def test_turk_submit_to_is_stored_as_the_allowlisted_site(client, study, submit_to, stored):
    assert entry(client, study, workerId="W", assignmentId="A", hitId="H", turkSubmitTo=submit_to).status_code == 302
    assert Participant.objects.get().turk_submit_to == stored


def test_unknown_study_is_404(client, db):
    assert client.get("/s/nope/").status_code == 404


def test_home_page(client, study, staff_client):
    assert Client().get("/").status_code == 200
    assert staff_client.get("/")["Location"] == reverse("dashboard")
