"""Researcher pages: staff only, counts, live progress fragment, open/close, preview, exports, admin."""
import csv
import io
from datetime import timedelta

import pytest
from django.test import Client
from django.urls import reverse
from django.utils import timezone

from studyapp.models import Answer, ComprehensionAttempt, Participant, StepKind, Study
from studyapp.participant import assignment

pytestmark = pytest.mark.django_db


@pytest.mark.parametrize("name, args", [
    ("dashboard", []), ("dashboard_study", ["s1"]), ("dashboard_progress", ["s1"]),
    ("dashboard_export", ["s1", "long"]), ("dashboard_export", ["s1", "wide"]),
    ("dashboard_export", ["s1", "dictionary"]),
])
def test_pages_need_staff(study, django_user_model, name, args):
    url = reverse(name, args=args)
    r = Client().get(url)
    assert r.status_code == 302 and r["Location"].startswith("/login/")
    user = django_user_model.objects.create_user("plain", password="pw-plain-123")
    c = Client()
    c.force_login(user)
    assert c.get(url).status_code == 302


def test_post_only_views_need_staff(study):
    cond = study.conditions.first()
    for url in (reverse("dashboard_toggle", args=[study.slug]),
                reverse("dashboard_preview", args=[study.slug, cond.pk])):
        assert Client().post(url).status_code == 302
    assert Study.objects.get().is_open and not Participant.objects.exists()


def test_index_lists_studies(staff_client, study):
    r = staff_client.get(reverse("dashboard"))
    assert r.status_code == 200 and study.name.encode() in r.content


def test_detail_counts(staff_client, study, complete):
    a, b, c = study.conditions.all()
    complete(Participant.objects.create(study=study, condition=a, platform="prolific", platform_pid="1",
                                        option_orders=assignment.option_orders(study)))
    complete(Participant.objects.create(study=study, condition=a, platform="prolific", platform_pid="2",
                                        option_orders=assignment.option_orders(study)), attentive=False)
    # failed the attention check, then left before the demographics: excluded but not completed
    complete(Participant.objects.create(study=study, condition=a, platform="prolific", platform_pid="3",
                                        option_orders=assignment.option_orders(study)),
             attentive=False, stop_before=StepKind.DEMOGRAPHICS)
    Participant.objects.create(study=study, condition=b, last_seen_at=timezone.now() - timedelta(hours=3))
    Participant.objects.create(study=study, condition=c)
    assignment.preview_participant(c)
    r = staff_client.get(reverse("dashboard_study", args=[study.slug]))
    assert r.status_code == 200
    rows = {row["condition"].name: row for row in r.context["stats"]}
    assert {k: rows["alpha"][k] for k in ("started", "completed", "excluded", "active", "abandoned", "valid")} == \
        {"started": 3, "completed": 2, "excluded": 2, "active": 1, "abandoned": 0, "valid": 1}
    assert rows["alpha"]["percent"] == 10  # 1 valid of a target of 10
    assert (rows["beta"]["started"], rows["beta"]["abandoned"], rows["beta"]["active"]) == (1, 1, 0)
    assert (rows["gamma"]["started"], rows["gamma"]["active"]) == (1, 1)  # the preview is not counted
    assert r.context["totals"]["started"] == 5
    assert b"PROLIFIC_PID={{%PROLIFIC_PID%}}" in r.content
    assert b"dashboard.js" in r.content and b'data-refresh="5"' in r.content
    assert len(r.context["recent"]) > 0


def test_progress_fragment(staff_client, study):
    assignment.assign(study, "prolific", "live")
    r = staff_client.get(reverse("dashboard_progress", args=[study.slug]))
    assert r.status_code == 200 and b"<html" not in r.content and b"Recent activity" in r.content
    assert sum(row["started"] for row in r.context["stats"]) == 1


def test_open_close(staff_client, study):
    url = reverse("dashboard_toggle", args=[study.slug])
    assert staff_client.post(url, {"open": "0"}).status_code == 302
    assert not Study.objects.get().is_open
    assert Client().get(reverse("entry", args=[study.slug])).status_code == 403
    staff_client.post(url, {"open": "1"})
    assert Study.objects.get().is_open
    assert staff_client.get(url).status_code == 405


def test_preview_is_not_counted(staff_client, study, complete):
    cond = study.conditions.get(name="beta")
    r = staff_client.post(reverse("dashboard_preview", args=[study.slug, cond.pk]))
    p = Participant.objects.get()
    assert r["Location"] == p.get_absolute_url() and p.platform == "preview" and p.condition == cond
    complete(p)
    assert assignment.condition_counts(study)[cond.pk] == 0
    page = staff_client.get(p.get_absolute_url())
    assert b"Staff preview" in page.content and b"prolific.com" not in page.content
    long = staff_client.get(reverse("dashboard_export", args=[study.slug, "long"])).getvalue().decode()
    assert len(list(csv.DictReader(io.StringIO(long)))) == 0
    assert staff_client.post(reverse("dashboard_preview", args=["other", cond.pk])).status_code == 404


def test_exports_download(staff_client, study, complete):
    p = complete(assignment.assign(study, "prolific", "exp"))
    for kind in ("long", "wide", "dictionary"):
        r = staff_client.get(reverse("dashboard_export", args=[study.slug, kind]))
        assert r.status_code == 200 and r["Content-Type"].startswith("text/csv")
        assert f'{study.slug}-' in r["Content-Disposition"]
    wide = staff_client.get(reverse("dashboard_export", args=[study.slug, "wide"])).getvalue().decode()
    (row,) = csv.DictReader(io.StringIO(wide))
    assert row["platform_pid"] == "exp" and row["condition"] == p.condition.name
    assert row["mean_confidence_score"] == "6.0"


@pytest.mark.parametrize("model", ["study", "condition", "participant", "answer"])
def test_admin_pages(admin_client, study, complete, model):
    p = complete(assignment.assign(study, "prolific", "adm"))
    obj = {"study": study, "condition": p.condition, "participant": p, "answer": Answer.objects.first()}[model]
    assert admin_client.get(reverse(f"admin:studyapp_{model}_changelist")).status_code == 200
    assert admin_client.get(reverse(f"admin:studyapp_{model}_change", args=[obj.pk])).status_code == 200


def test_recent_activity_names_comprehension_attempts_and_shown_ways(study, staff_client):
    """A failed comprehension attempt writes no answer, and a shown way has no score: both are said."""
    p = assignment.assign(study, "prolific", "activity-1")
    start = timezone.now()
    ComprehensionAttempt.objects.create(participant=p, number=1, missed=[0, 2], passed=False, created_at=start)
    ComprehensionAttempt.objects.create(participant=p, number=2, passed=True, created_at=start + timedelta(seconds=1))
    Answer.objects.create(participant=p, step=5, kind="test", item=0, data={"moves": ["up", "up", "right"]},
                          correct=False, regret=0.25, created_at=start + timedelta(seconds=2))
    page = staff_client.get(reverse("dashboard_progress", args=[study.slug])).content.decode()
    lines = page[page.index('<ul class="activity">'):].split("</li>")[:3]
    assert "test 1, a way of 3 moves, θ*-regret 0.25" in lines[0]
    assert "comprehension attempt 2: passed" in lines[1]
    assert "comprehension attempt 1: failed, missed 2" in lines[2]
