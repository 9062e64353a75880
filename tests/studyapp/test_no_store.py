"""Every researcher page and CSV export is sent with ``Cache-Control: no-store``:
a browser's disk cache or a shared proxy must never keep participant data.

The URL names come from the live URLconf, so a researcher view added later is checked too.
"""
import pytest
from django.test import Client
from django.urls import URLResolver, get_resolver, reverse

from config.middleware import PARTICIPANT_URL_NAMES
from precompute.models import Job

pytestmark = pytest.mark.django_db


def url_names(patterns=None, namespace="", params=()):
    """(view name, its URL parameters) for every named pattern, namespaces included."""
    for p in get_resolver().url_patterns if patterns is None else patterns:
        names = (*params, *p.pattern.regex.groupindex)
        if isinstance(p, URLResolver):
            yield from url_names(p.url_patterns, f"{namespace}{p.namespace}:" if p.namespace else namespace, names)
        elif p.name:
            yield namespace + p.name, names


def test_every_researcher_url_is_no_store(staff_client, study):
    job = Job.objects.create(kind=Job.STUDY, params={"slug": study.slug}, status=Job.FAILED, error="boom")
    values = {"slug": study.slug, "condition_id": study.conditions.first().pk, "pk": job.pk, "kind": "long",
              "app_label": "studyapp", "object_id": "1", "content_type_id": 1, "id": 1, "url": "nowhere",
              "name": "0" * 64 + ".webm"}
    checked = set()
    for name, params in url_names():
        if name in PARTICIPANT_URL_NAMES:
            continue
        kinds = ("long", "wide", "dictionary") if name == "dashboard_export" else ("long",)
        for kind in kinds:
            url = reverse(name, kwargs={k: kind if k == "kind" else values[k] for k in params})
            for client in (staff_client, Client()):  # signed in, and the login redirect of a stranger
                r = client.get(url)
                assert "no-store" in r.get("Cache-Control", ""), (name, url, r.status_code, r.get("Cache-Control"))
            checked.add(name)
    assert {"dashboard", "dashboard_study", "dashboard_export", "dashboard_analysis", "dashboard_stimuli",
            "dashboard_preview", "dashboard_progress", "precompute:jobs", "precompute:design", "precompute:job",
            "precompute:job_status", "login", "logout", "admin:index", "admin:login",
            "admin:studyapp_study_changelist"} <= checked
    assert len(checked) > 40  # the admin's model pages too


def test_an_export_is_no_store_with_its_body(staff_client, study):
    r = staff_client.get(reverse("dashboard_export", args=[study.slug, "wide"]))
    assert r.status_code == 200 and r["Content-Type"].startswith("text/csv")
    assert "no-store" in r["Cache-Control"]


def test_participant_pages_keep_their_own_headers(client, study):
    r = client.get(reverse("home"))
    assert "no-store" not in r.get("Cache-Control", "")  # the middleware keys on the URL name, not on everything
