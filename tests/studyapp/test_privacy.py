"""Participants' data rights (studyapp/data/privacy.py): erasing a participant by platform id removes every row
that names them and nothing else, counted row by row before and after, from the command and from the
dashboard; the audit line keeps no platform id; a pseudonymised export has none either, and its
pseudonyms are stable and distinct."""
from __future__ import annotations

import csv
import io
import json
import logging

import pytest
from django.core.management import CommandError, call_command
from django.test import Client
from django.urls import reverse

from studyapp.data import exports, privacy
from studyapp.models import Answer, ComprehensionAttempt, Condition, LoopStep, Participant, Study
from studyapp.participant.assignment import assign
from studyapp.researcher.dashboard import condition_stats

PIDS = ["5f0c0ffee000000000000001", "5f0c0ffee000000000000002", "5f0c0ffee000000000000003"]


@pytest.fixture
def two_studies(make_study, complete):
    """Two studies; the first has three finished Prolific participants, the second one of the same ids."""
    first, second = make_study(slug="s1"), make_study(slug="s2")
    for i, pid in enumerate(PIDS):
        complete(assign(first, Participant.PROLIFIC, pid, platform_session_id=f"SESSION{i}"))
    complete(assign(second, Participant.PROLIFIC, PIDS[0], platform_session_id="SESSION9"))
    return first, second


def everything() -> dict[str, set]:
    """Every row of every table a participant's data lives in, as comparable values."""
    return {
        "participants": set(Participant.objects.values_list("pk", "study_id", "platform_pid", "position")),
        "answers": {(a, p, s, json.dumps(d, sort_keys=True))
                    for a, p, s, d in Answer.objects.values_list("pk", "participant_id", "step", "data")},
        "loop_steps": set(LoopStep.objects.values_list("pk", "participant_id", "index")),
        "comprehension_attempts": set(ComprehensionAttempt.objects.values_list("pk", "participant_id", "number")),
        "studies": set(Study.objects.values_list("pk", "slug", "is_open")),
        "conditions": set(Condition.objects.values_list("pk", "study_id", "name")),
    }


def test_erasing_a_participant_removes_their_rows_and_nothing_else(two_studies, caplog):
    first, second = two_studies
    gone_p = Participant.objects.get(study=first, platform_pid=PIDS[0])
    gone_answers = set(Answer.objects.filter(participant=gone_p).values_list("pk", flat=True))
    started = {r["condition"].pk: r["started"] for r in condition_stats(first)}
    before = everything()
    with caplog.at_level(logging.INFO, logger="studyapp.data.privacy"):
        found = privacy.erase(PIDS[0], first)
    after = everything()
    assert found.rows == ((first.slug, gone_p.pk, len(gone_answers), 0),)
    assert {p[0] for p in before["participants"] - after["participants"]} == {gone_p.pk}
    assert {a[0] for a in before["answers"] - after["answers"]} == gone_answers and len(gone_answers) > 5
    assert after["participants"] <= before["participants"] and after["answers"] <= before["answers"]
    for table in ("loop_steps", "comprehension_attempts", "studies", "conditions"):
        assert after[table] == before[table]
    # the other study's participant of the same id stays; the place in the condition is free again
    assert Participant.objects.filter(study=second, platform_pid=PIDS[0]).exists()
    now = {r["condition"].pk: r["started"] for r in condition_stats(first)}
    assert now[gone_p.condition_id] == started[gone_p.condition_id] - 1
    # the audit line names the row and its counts, never the platform id
    lines = [r.getMessage() for r in caplog.records if r.name == "studyapp.data.privacy"]
    assert lines == [f"erased participant {gone_p.pk} of study 's1' at their request: {len(gone_answers)} "
                     "answers, 0 closed-loop steps"]
    assert PIDS[0] not in caplog.text


def test_the_command_shows_asks_and_erases_in_every_study(two_studies, monkeypatch):
    out = io.StringIO()
    monkeypatch.setattr("builtins.input", lambda prompt: "no")
    with pytest.raises(CommandError, match="nothing was erased"):
        call_command("erase_participant", PIDS[0], stdout=out)
    assert "to erase: 2 participant row(s) in s1, s2" in out.getvalue()
    assert Participant.objects.filter(platform_pid=PIDS[0]).count() == 2
    call_command("erase_participant", PIDS[0], "--yes", stdout=out)
    assert not Participant.objects.filter(platform_pid=PIDS[0]).exists()
    assert Participant.objects.filter(platform_pid__in=PIDS[1:]).count() == 2
    for argv, message in ((["nobody"], "no participant of any study has that platform id"),
                          (["  "], "give the participant's platform id"),
                          ([PIDS[1], "--study", "nope"], "no study 'nope'")):
        with pytest.raises(CommandError, match=message):
            call_command("erase_participant", *argv, "--yes", stdout=io.StringIO())


def test_the_dashboard_finds_confirms_and_erases_with_the_id_never_in_a_url(two_studies, staff_client):
    first, _ = two_studies
    url = reverse("dashboard_erase", args=[first.slug])
    page = staff_client.get(reverse("dashboard_study", args=[first.slug])).content.decode()
    assert 'id="erase-form"' in page and "pseudonymise=1" in page
    assert staff_client.get(url, {"platform_id": PIDS[1]}).status_code == 405  # never by GET: no id in a URL
    confirm = staff_client.post(url, {"action": "find", "platform_id": PIDS[1]})
    assert confirm.status_code == 200 and "1 participant row(s) in s1" in confirm.content.decode()
    assert Participant.objects.filter(platform_pid=PIDS[1]).exists()  # finding erases nothing
    assert Client().post(url, {"action": "erase", "platform_id": PIDS[1]}).status_code == 302  # not staff: login
    assert Participant.objects.filter(platform_pid=PIDS[1]).exists()
    done = staff_client.post(url, {"action": "erase", "platform_id": PIDS[1]}, follow=True)
    assert "Erased 1 participant row(s) in s1" in done.content.decode()
    assert not Participant.objects.filter(platform_pid=PIDS[1]).exists()
    missing = staff_client.post(url, {"action": "find", "platform_id": "nobody"})
    assert missing.status_code == 404 and "nothing was erased" in missing.content.decode()


def test_a_pseudonymised_export_has_no_platform_id_and_stable_distinct_pseudonyms(two_studies, staff_client):
    first, _ = two_studies
    secrets = [*PIDS, "SESSION0", "SESSION1", "SESSION2"]
    for kind in ("long", "wide"):
        text = "".join(exports.STREAMS[kind](first, True))
        assert not [s for s in secrets if s in text], kind
        again = staff_client.get(reverse("dashboard_export", args=[first.slug, kind]), {"pseudonymise": "1"})
        assert b"".join(again.streaming_content).decode() == text  # stable: the same file again
        rows = list(csv.DictReader(io.StringIO(text)))
        by_participant = {r["participant_id"]: r["platform_pid"] for r in rows}
        assert len(set(by_participant.values())) == len(PIDS) == len(by_participant)
        assert all(v.startswith("p-") and len(v) == 18 for v in by_participant.values())
        plain = {r["participant_id"]: r["platform_pid"] for r in csv.DictReader(io.StringIO(
            "".join(exports.STREAMS[kind](first))))}
        assert {k: privacy.pseudonym(first.slug, v) for k, v in plain.items()} == by_participant
    out = io.StringIO()
    call_command("export_study", first.slug, "wide", "--pseudonymise", stdout=out)
    assert not [s for s in secrets if s in out.getvalue()]
    # another study's pseudonym of the same id differs: data sets shared apart cannot be joined on it
    assert privacy.pseudonym("s1", PIDS[0]) != privacy.pseudonym("s2", PIDS[0])
