"""Balanced assignment: least-filled condition, counting completed + recently active, random tie-break."""
from collections import Counter
from datetime import timedelta

import pytest
from django.db import IntegrityError, connection, transaction
from django.test.utils import CaptureQueriesContext
from django.utils import timezone

from studyapp.models import Participant
from studyapp.participant import assignment, flow
from studyapp.researcher.dashboard import condition_stats

pytestmark = pytest.mark.django_db


def counts(study):
    return Counter(Participant.objects.filter(study=study).exclude(platform="preview")
                   .values_list("condition__name", flat=True))


def test_sequential_arrivals_fill_conditions_evenly(study):
    for i in range(31):
        assignment.assign(study, "prolific", f"p{i}")
    c = counts(study)
    assert sum(c.values()) == 31 and max(c.values()) - min(c.values()) <= 1


def test_tie_break_is_random(study):
    firsts = set()
    for _ in range(30):  # the first arrival of an empty study, 30 times (each leaves before the next comes)
        first = assignment.assign(study)
        firsts.add(first.condition.name)
        first.delete()
    assert firsts == {"alpha", "beta", "gamma"}  # P(miss one) = 3 * (2/3)^30 < 1e-5


def test_abandoned_participants_free_their_place(study):
    stale = assignment.assign(study, "prolific", "stale")
    Participant.objects.filter(pk=stale.pk).update(last_seen_at=timezone.now() - timedelta(hours=2))
    # stale no longer counts: the three conditions are all empty, so stale's condition can be picked again;
    # with two fresh arrivals in the other two conditions, the next goes to stale's condition for sure.
    others = [c for c in study.conditions.all() if c != stale.condition]
    for i, c in enumerate(others):
        Participant.objects.create(study=study, condition=c, platform="prolific", platform_pid=f"o{i}")
    assert assignment.assign(study, "prolific", "new").condition == stale.condition
    assert assignment.condition_counts(study)[stale.condition.pk] == 1


def test_completed_count_but_excluded_and_previews_do_not(study):
    a, b, c = study.conditions.all()
    old = timezone.now() - timedelta(days=1)
    Participant.objects.create(study=study, condition=a, completed_at=old, last_seen_at=old)  # counts
    Participant.objects.create(study=study, condition=b, completed_at=old, last_seen_at=old, excluded=True)
    assignment.preview_participant(c)
    assert assignment.condition_counts(study) == {a.pk: 1, b.pk: 0, c.pk: 0}
    picked = {assignment.assign(study, "prolific", f"x{i}").condition.name for i in range(2)}
    assert picked == {b.name, c.name}


def test_targets_weight_the_fill(make_study):
    s = make_study("weighted", sequences={"big": [500], "small": [5780]})
    big = s.conditions.get(name="big")
    big.target = 30
    big.save()
    s.target_per_condition = 10
    s.save()
    for i in range(40):
        assignment.assign(s, "prolific", f"w{i}")
    assert counts(s) == {"big": 30, "small": 10}


def test_returning_id_never_gets_a_second_condition(study):
    first = assignment.assign(study, "mturk", "W1")
    for _ in range(10):
        assert assignment.assign(study, "mturk", "W1").pk == first.pk
    # the same id on another platform is another person
    assert assignment.assign(study, "prolific", "W1").pk != first.pk


def test_closed_study_raises(study):
    study.is_open = False
    study.save()
    with pytest.raises(assignment.StudyClosed):
        assignment.assign(study, "prolific", "late")


def test_unique_constraint_backs_up_the_lock(study):
    p = assignment.assign(study, "prolific", "dup")
    with pytest.raises(IntegrityError), transaction.atomic():
        Participant.objects.create(study=study, condition=p.condition, platform="prolific", platform_pid="dup")


def test_an_arrival_and_an_answer_read_the_study_once(study):
    """The study row carries its test set and pilot as JSON: an arrival read it again for every condition
    (Condition.target_count) and each answer once more in its lock query; each decode grows with the study."""
    def study_reads(queries):
        return [q["sql"] for q in queries if 'FROM "studyapp_study"' in q["sql"]]

    assert study.conditions.count() > 1
    with CaptureQueriesContext(connection) as arrival:
        p = assignment.assign(study)
    assert len(study_reads(arrival.captured_queries)) == 1  # the lock, once
    with CaptureQueriesContext(connection) as answer:
        flow.record(p, 0, {"consent": "yes"})
    assert study_reads(answer.captured_queries) == []
    with CaptureQueriesContext(connection) as stats:
        assert [row["target"] for row in condition_stats(study)] == [c.target_count for c in study.conditions.all()]
    assert study_reads(stats.captured_queries) == []
