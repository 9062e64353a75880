"""A study opens only when it can run: a study whose build gave it no test question, whose closed loop lost
the data built from its table, or whose robot is not registered on this server, says why on its dashboard
and cannot be opened; a participant link to it, new or returning, answers one clear page in the study's
language (503) and writes nothing; and a participant who answered no test question is never given a
completion code or a bonus."""
import shutil

import pytest
from django.urls import reverse

from studyapp.models import Answer, Participant, StepKind, Study
from studyapp.participant import flow
from studyapp.participant.assignment import assign
from tests.conftest import complete_flow

pytestmark = pytest.mark.django_db

UNAVAILABLE = "This study is not available right now."
PROLIFIC = {"PROLIFIC_PID": "5f0c0ffee000000000000001", "STUDY_ID": "S", "SESSION_ID": "X"}


def _counts():
    return Participant.objects.count(), Answer.objects.count()


def test_a_study_whose_build_gave_it_no_test_cannot_be_opened(study, staff_client, client):
    Study.objects.filter(pk=study.pk).update(test_set=[], is_open=False)  # a build that failed at its last step
    study.refresh_from_db()
    assert study.opening_problems() == study.running_problems() != []
    page = staff_client.get(reverse("dashboard_study", args=[study.slug])).content.decode()
    assert "Cannot open: It has no test questions: its build did not finish" in page
    listed = staff_client.get(reverse("dashboard")).content.decode()  # the list says so too
    assert 'class="error" title="It has no test questions' in listed and ">cannot run<" in listed
    refused = staff_client.post(reverse("dashboard_toggle", args=[study.slug]), {"open": "1"}, follow=True)
    assert "It has no test questions" in refused.content.decode()
    study.refresh_from_db()
    assert not study.is_open
    # opened behind the dashboard's back (the admin, an old row): its link still takes no one
    Study.objects.filter(pk=study.pk).update(is_open=True)
    before = _counts()
    response = client.get(reverse("entry", args=[study.slug]), PROLIFIC)
    assert response.status_code == 503 and UNAVAILABLE in response.content.decode()
    assert _counts() == before


def test_a_study_whose_robot_is_not_registered_answers_a_clear_page_never_500(study, staff_client, client):
    Study.objects.filter(pk=study.pk).update(language="de")
    response = client.get(reverse("entry", args=[study.slug]), PROLIFIC)
    p = Participant.objects.get(platform_pid=PROLIFIC["PROLIFIC_PID"])
    p = complete_flow(p, stop_before=StepKind.TEST)  # a participant part of the way when the server changed
    Study.objects.filter(pk=study.pk).update(domain="vacuum")  # served without the setting that registers it
    before = _counts()
    for response in (client.get(reverse("entry", args=[study.slug]), {**PROLIFIC, "PROLIFIC_PID": "new-one"}),
                     client.get(reverse("step", args=[study.slug, p.token])),
                     client.post(reverse("answer", args=[study.slug, p.token, p.position]), {"choice": "A"})):
        text = response.content.decode()
        assert response.status_code == 503, text[:300]
        assert "Diese Studie ist gerade nicht verfügbar" in text and "vacuum" not in text  # its language, no internals
    assert _counts() == before
    assert client.get(reverse("step", args=[study.slug, p.token]), HTTP_ACCEPT="application/json").status_code == 503
    page = staff_client.get(reverse("dashboard_study", args=[study.slug]))
    assert page.status_code == 200 and staff_client.get(reverse("dashboard")).status_code == 200
    assert "Cannot open: Its robot &#x27;vacuum&#x27; is not registered on this server" in page.content.decode()


def test_a_participant_who_answered_no_test_gets_no_code_and_no_bonus(make_study):
    study = make_study(slug="no-tests", bonus_per_point=0.10, bonus_currency="GBP")
    p = flow_participant(study)
    Study.objects.filter(pk=study.pk).update(test_set=[])  # the tests gone from under a participant
    p.refresh_from_db()
    p = complete_flow(p)
    assert p.completed_at is not None
    assert p.completion_code == "" and p.bonus is None
    assert not Answer.objects.filter(participant=p, kind=StepKind.TEST).exists()


def test_a_participant_who_answered_the_tests_gets_the_code(make_study):
    p = complete_flow(flow_participant(make_study(slug="with-tests")))
    assert p.completion_code == "TEST2026" and Answer.objects.filter(participant=p, kind=StepKind.TEST).exists()


def flow_participant(study) -> Participant:
    p = assign(study, Participant.ANONYMOUS, "")
    assert flow.steps_for(p)
    return p


def test_a_closed_loop_study_whose_decision_data_is_gone_cannot_run(closed_loop_study, staff_client, client):
    """The files a closed-loop condition decides with are built from the table beside it; with them gone
    (the table's directory cleaned up, another machine's disk) no participant may start."""
    study = closed_loop_study
    assert study.running_problems() == []
    pack = study.conditions.get(name="closed-loop").closed_loop["pack"]
    shutil.rmtree(pack)
    [problem] = study.running_problems()
    assert "closed-loop condition 'closed-loop'" in problem and pack in problem
    page = staff_client.get(reverse("dashboard_study", args=[study.slug])).content.decode()
    assert "Cannot open: The data of its closed-loop condition" in page
    Study.objects.filter(pk=study.pk).update(is_open=True)
    before = _counts()
    response = client.get(reverse("entry", args=[study.slug]), PROLIFIC)
    assert response.status_code == 503 and UNAVAILABLE in response.content.decode()
    assert _counts() == before
