"""How a participant's study ends early (studyapp/participant/outcomes.py): timed out by the study's time limit,
returned (the platform says so), screened out; each outcome's code and redirect, the places they free,
and the outcome in the dashboard, the exports and the analysis."""
from __future__ import annotations

import csv
import io
from datetime import timedelta

import pytest
from django.core.management import CommandError, call_command
from django.urls import reverse
from django.utils import timezone

from studyapp import status
from studyapp.analysis.data import frames
from studyapp.analysis.formatting import participant_groups
from studyapp.data import exports
from studyapp.models import Answer, Participant, StepKind
from studyapp.participant import outcomes
from studyapp.participant.assignment import assign, condition_counts
from studyapp.participant.flow import AnswerError
from studyapp.researcher.dashboard import condition_stats
from studyapp.researcher.specschema import SpecError
from tests.conftest import complete_flow
from tests.studyapp.helpers import answer_url, design_form, record, snapshot, step_url

PROLIFIC_DONE = "https://app.prolific.com/submissions/complete?cc="


@pytest.fixture
def limited(make_study):
    """A Prolific study with a 20-minute limit and a code for every way of ending."""
    return make_study(slug="limited", time_limit_minutes=20, estimated_minutes=12, recruitment="prolific",
                      completion_code="DONE2026", excluded_code="ATTN2026", screened_out_code="SCRN2026",
                      timed_out_code="TIME2026")


def late(participant, minutes=21):
    """Move the participant's arrival `minutes` into the past."""
    Participant.objects.filter(pk=participant.pk).update(started_at=timezone.now() - timedelta(minutes=minutes))
    participant.refresh_from_db()
    return participant


def wide_rows(study) -> dict[str, dict]:
    return {r["platform_pid"]: r for r in csv.DictReader(io.StringIO(exports.wide_csv(study)))}


def test_a_participant_out_of_time_is_timed_out_freed_sent_back_with_its_code_and_answers_nothing(limited, client):
    p = assign(limited, Participant.PROLIFIC, "slow")
    p = complete_flow(p, stop_before=StepKind.TEST)
    condition = p.condition
    assert condition_counts(limited)[condition.pk] == 1
    late(p)
    assert condition_counts(limited)[condition.pk] == 0  # freed as soon as the limit passes

    before = snapshot()
    position = p.position
    r = client.post(answer_url(p, position), {"choice": "A"})  # an answer sent after the limit
    assert r.status_code == 302 and r["Location"].startswith(step_url(p))
    assert snapshot()[0] == before[0]  # no answer stored
    page = client.get(step_url(p)).content.decode()
    assert 'data-outcome="timed_out"' in page and "Your time for this study is up" in page and "20 minutes" in page
    assert f'href="{PROLIFIC_DONE}TIME2026"' in page and 'content="3;url=' in page
    p.refresh_from_db()
    assert (p.outcome, p.completion_code, p.position) == (status.TIMED_OUT, "TIME2026", position)
    assert wide_rows(limited)["slow"]["status"] == "timed_out"
    assert wide_rows(limited)["slow"]["completion_code"] == "TIME2026"


def test_one_who_never_comes_back_reads_as_timed_out_in_the_dashboard_and_exports(limited):
    gone = late(assign(limited, Participant.PROLIFIC, "gone"))
    complete_flow(assign(limited, Participant.PROLIFIC, "stays"), stop_before=StepKind.TRAINING)
    stats = condition_stats(limited)
    assert sum(r["timed_out"] for r in stats) == 1 and sum(r["active"] for r in stats) == 1
    rows = wide_rows(limited)
    assert (rows["gone"]["status"], rows["stays"]["status"]) == ("timed_out", "incomplete")
    assert rows["gone"]["ended_at"] and not rows["stays"]["ended_at"]
    gone.refresh_from_db()
    assert gone.completion_code == "TIME2026"  # set when marked, so the page shows the same code later


def test_finishing_in_time_and_timing_out_never_both_happen(limited):
    p = complete_flow(assign(limited, Participant.PROLIFIC, "quick"))
    assert p.completed_at is not None and p.completion_code == "DONE2026"
    late(p, minutes=60)
    assert not outcomes.time_up(p)
    assert outcomes.end(p, status.TIMED_OUT) is False  # finished: the conditional update writes nothing
    assert outcomes.expire(limited) == 0
    p.refresh_from_db()
    assert (p.outcome, p.completion_code) == ("", "DONE2026")


def test_each_outcome_gets_its_own_code(limited):
    done = complete_flow(assign(limited, Participant.PROLIFIC, "done"))
    inattentive = complete_flow(assign(limited, Participant.PROLIFIC, "inattentive"), attentive=False)
    screened = assign(limited, Participant.PROLIFIC, "screened")
    assert outcomes.end(screened, status.SCREENED_OUT) is True
    assert outcomes.end(screened, status.TIMED_OUT) is False  # an outcome is written once
    timed = late(assign(limited, Participant.PROLIFIC, "timed"))
    outcomes.check_time(timed)
    codes = {pid: (r["status"], r["completion_code"]) for pid, r in wide_rows(limited).items()}
    assert codes == {"done": ("complete", "DONE2026"), "inattentive": ("excluded", "ATTN2026"),
                     "screened": ("screened_out", "SCRN2026"), "timed": ("timed_out", "TIME2026")}
    assert done.completion_code == "DONE2026" and inattentive.completion_code == "ATTN2026"
    pseudonymised = list(csv.DictReader(io.StringIO(exports.wide_csv(limited, pseudonymise=True))))
    assert {r["completion_code"] for r in pseudonymised} == {""}


def test_without_codes_of_their_own_prolific_asks_to_return_and_others_keep_a_code(make_study, client):
    study = make_study(slug="plain", time_limit_minutes=30)
    on_prolific = assign(study, Participant.PROLIFIC, "pp")
    outcomes.end(on_prolific, status.SCREENED_OUT)
    page = client.get(step_url(on_prolific)).content.decode()
    assert "Please return the study on Prolific" in page and PROLIFIC_DONE not in page
    assert 'id="completion-code"' not in page
    anonymous = assign(study)
    outcomes.end(anonymous, status.SCREENED_OUT)
    assert len(anonymous.completion_code) == 8  # an own code, as a finished participant's without a study code
    worker = assign(study, Participant.MTURK, "w1", platform_session_id="A1",
                    turk_submit_to="https://workersandbox.mturk.com")
    late(worker, minutes=31)
    page = client.get(step_url(worker)).content.decode()
    assert 'action="https://workersandbox.mturk.com/mturk/externalSubmit"' in page
    assert f'name="completion_code" value="{Participant.objects.get(pk=worker.pk).completion_code}"' in page


def test_the_dashboard_marks_returned_participants_and_frees_their_places(limited, staff_client, client):
    going = assign(limited, Participant.PROLIFIC, "left-1", platform_session_id="SESS-9")
    finished = complete_flow(assign(limited, Participant.PROLIFIC, "left-2"))
    assert sum(condition_counts(limited).values()) == 2
    r = staff_client.post(reverse("dashboard_returned", args=[limited.slug]),
                          {"platform_ids": "SESS-9\nleft-2, Nobody"}, follow=True)
    page = r.content.decode()
    assert "2 marked returned; 1 not in this study (Nobody)." in page
    assert sum(condition_counts(limited).values()) == 0
    rows = wide_rows(limited)
    assert rows["left-1"]["status"] == rows["left-2"]["status"] == "returned"
    assert rows["left-2"]["completion_code"] == "DONE2026"  # what they were given stays on record
    # the analysis keeps them out, and says why
    people = frames(limited)[0].set_index("participant_id")
    assert bool(people.loc[str(finished.pk), "excluded"]) is True
    assert people.loc[str(finished.pk), "exclusion_reason"] == "returned the study"
    assert ("returned (the platform says)", 1) in participant_groups(people.reset_index())
    # their pages say so, with no code; their answers are refused
    page = client.get(step_url(going)).content.decode()
    assert 'data-outcome="returned"' in page and 'id="completion-code"' not in page
    again = staff_client.post(reverse("dashboard_returned", args=[limited.slug]), {"platform_ids": "left-1"},
                              follow=True).content.decode()
    assert "0 marked returned; 1 had ended already" in again
    empty = staff_client.post(reverse("dashboard_returned", args=[limited.slug]), {"platform_ids": " \n"},
                              follow=True).content.decode()
    assert "Paste the platform ids" in empty
    dash = staff_client.get(reverse("dashboard_study", args=[limited.slug])).content.decode()
    assert 'id="outcome-codes"' in dash and "SCRN2026" in dash and "TIME2026" in dash


def test_mark_returned_command(limited, tmp_path, capsys):
    assign(limited, Participant.PROLIFIC, "c1")
    assign(limited, Participant.PROLIFIC, "c2")
    listed = tmp_path / "returned.txt"
    listed.write_text("c2\nc9\n")
    call_command("mark_returned", limited.slug, "c1", "--file", str(listed))
    assert "2 marked returned; 1 not in this study (c9)" in capsys.readouterr().out
    assert set(Participant.objects.filter(study=limited).values_list("outcome", flat=True)) == {"returned"}
    with pytest.raises(CommandError, match="no study 'nope'"):
        call_command("mark_returned", "nope", "x")
    with pytest.raises(CommandError, match="no ids given"):
        call_command("mark_returned", limited.slug)


def test_the_consent_page_states_the_limit_and_its_version_changes_with_it(limited, client):
    p = assign(limited, Participant.PROLIFIC, "reader")
    assert "at most 20 minutes from now to finish" in client.get(step_url(p)).content.decode()
    version = limited.consent_version()
    limited.time_limit_minutes = 25
    assert limited.consent_version() != version


def test_staff_previews_never_time_out(limited, staff_client):
    condition = limited.conditions.first()
    staff_client.post(reverse("dashboard_preview", args=[limited.slug, condition.pk]))
    preview = late(Participant.objects.get(platform=Participant.PREVIEW), minutes=600)
    assert not outcomes.time_up(preview) and outcomes.expire(limited) == 0


@pytest.mark.parametrize("fields, says", [
    ({"time_limit_minutes": 10, "estimated_minutes": 15}, "shorter than the 15 minutes the study takes"),
    ({"time_limit_minutes": -5}, "time_limit_minutes"),
    ({"time_limit_minutes": 100_000}, "time_limit_minutes"),
    ({"screened_out_code": "x" * 65}, "screened_out_code"),
])
def test_bad_limits_and_codes_are_one_line_refusals(make_study, fields, says):
    with pytest.raises(SpecError, match=says) as refused:
        make_study(slug="bad", **fields)
    assert "\n" not in str(refused.value)


def test_the_designer_takes_a_limit_and_codes_and_refuses_a_limit_below_the_estimate(db, tiny_table):
    prolific = {"recruitment": "prolific", "completion_code": "C1"}
    form = design_form(tiny_table, **prolific, time_limit_minutes="45", timed_out_code="T1", screened_out_code="S1")
    assert form.is_valid(), form.errors
    job = form.cleaned_data["job"]
    assert (job["time_limit_minutes"], job["timed_out_code"], job["screened_out_code"]) == (45, "T1", "S1")
    form = design_form(tiny_table, **prolific, time_limit_minutes="10")
    assert not form.is_valid()
    (message,) = form.errors["time_limit_minutes"]
    assert message.startswith("a time limit of 10 minutes is shorter than the 15 minutes") and "\n" not in message


def test_an_answer_row_is_never_written_for_an_ended_participant(limited):
    p = assign(limited, Participant.PROLIFIC, "ended")
    outcomes.end(p, status.SCREENED_OUT)
    with pytest.raises(AnswerError, match="ended for you"):
        record(p, 0, consent="yes")
    assert not Answer.objects.filter(participant=p).exists()
