"""CSRF on every form, the answer endpoint inside Mechanical Turk's cross-site iframe included
(docs/decisions.md, "Security")."""
import re
from pathlib import Path

import pytest
from django.test import Client, override_settings
from django.urls import URLPattern, URLResolver, get_resolver, reverse

from precompute.models import Job
from studyapp.models import Answer, Participant, Study
from studyapp.participant import views
from tests.studyapp.helpers import answer_url, page_token, snapshot, step_url

pytestmark = pytest.mark.django_db
ROOT = Path(__file__).resolve().parents[2]


# --- CSRF -------------------------------------------------------------------------------------
@pytest.fixture
def strict():
    return Client(enforce_csrf_checks=True)


@pytest.mark.parametrize("headers", [
    {"HTTP_ORIGIN": "https://evil.example"},
    {"HTTP_ORIGIN": "null"},
    {"HTTP_ORIGIN": "http://testserver.evil.example"},
    {"HTTP_REFERER": "https://evil.example/forge.html"},
    {},  # no cookie, no token, no Origin, no Referer
])
def test_cookieless_answer_from_elsewhere_is_refused(strict, participant, headers):
    before = snapshot()
    for body in ({"consent": "yes"}, {"consent": "no"}):  # declining is a form too
        r = strict.post(answer_url(participant), body, **headers)
        assert r.status_code == 403 and b"nothing was saved" in r.content
    r = strict.post(answer_url(participant), {"consent": "yes"}, HTTP_ACCEPT="application/json", **headers)
    assert r.status_code == 403 and r.json()["ok"] is False and "study's own page" in r.json()["error"]
    assert snapshot() == before


@pytest.mark.parametrize("headers", [
    {"HTTP_ORIGIN": "http://testserver"},
    {"HTTP_REFERER": "http://testserver/s/s1/p/x/"},
])
def test_cookieless_answer_from_our_own_page_is_accepted(strict, participant, headers):
    """The MTurk iframe: our page, our Origin, but the SameSite=Lax CSRF cookie is not sent."""
    assert strict.post(answer_url(participant), {"consent": "yes"}, **headers).status_code == 302
    assert Answer.objects.filter(participant=participant, step=0).exists()


@override_settings(CSRF_TRUSTED_ORIGINS=["https://study.example.org"])
def test_cookieless_answer_from_a_trusted_origin_is_accepted(strict, participant):
    r = strict.post(answer_url(participant), {"consent": "yes"}, HTTP_ORIGIN="https://study.example.org")
    assert r.status_code == 302


def test_answer_with_cookie_needs_the_form_token(strict, participant):
    token = page_token(strict.get(step_url(participant)))  # sets the CSRF cookie, as a browser visit does
    before = snapshot()
    assert strict.post(answer_url(participant), {"consent": "yes"}, HTTP_ORIGIN="http://testserver").status_code == 403
    r = strict.post(answer_url(participant), {"consent": "yes", "csrfmiddlewaretoken": token},
                    HTTP_ORIGIN="https://evil.example")
    assert r.status_code == 403 and snapshot() == before
    r = strict.post(answer_url(participant), {"consent": "yes", "csrfmiddlewaretoken": "x" * 64},
                    HTTP_ACCEPT="application/json")
    assert r.status_code == 403 and "expired" in r.json()["error"] and snapshot() == before
    assert strict.post(answer_url(participant), {"consent": "yes", "csrfmiddlewaretoken": token}).status_code == 302
    assert Answer.objects.filter(participant=participant, step=0).exists()


def test_staff_forms_need_the_csrf_token(study, django_user_model):
    user = django_user_model.objects.create_user("staff", password="pw-staff-123", is_staff=True)
    c = Client(enforce_csrf_checks=True)
    c.force_login(user)
    job = Job.objects.create(kind=Job.STUDY, params={"slug": study.slug}, status=Job.FAILED, error="boom")
    toggle = reverse("dashboard_toggle", args=[study.slug])
    assert c.post(toggle, {"open": "0"}).status_code == 403
    assert c.post(reverse("dashboard_preview", args=[study.slug, study.conditions.first().pk])).status_code == 403
    assert c.post(reverse("precompute:job_retry", args=[job.pk])).status_code == 403
    job.refresh_from_db()
    assert Study.objects.get().is_open and not Participant.objects.exists() and job.attempts == 0
    assert b"csrfmiddlewaretoken" in c.get(reverse("precompute:job", args=[job.pk])).content
    token = page_token(c.get(reverse("dashboard_study", args=[study.slug])))
    assert c.post(toggle, {"open": "0", "csrfmiddlewaretoken": token}).status_code == 302
    assert not Study.objects.get().is_open
    assert c.post(reverse("admin:logout")).status_code == 403


def test_admin_login_needs_the_csrf_token(django_user_model):
    django_user_model.objects.create_user("staff", password="pw-staff-123", is_staff=True)
    c = Client(enforce_csrf_checks=True)
    creds = {"username": "staff", "password": "pw-staff-123", "next": "/admin/"}
    assert c.post(reverse("admin:login"), creds).status_code == 403
    creds["csrfmiddlewaretoken"] = page_token(c.get(reverse("admin:login")))
    assert c.post(reverse("admin:login"), creds).status_code == 302


def _views(patterns):
    for p in patterns:
        if isinstance(p, URLResolver):
            yield from _views(p.url_patterns)
        elif isinstance(p, URLPattern):
            yield p.callback


def test_only_the_answer_view_takes_over_the_csrf_check():
    exempt = {v for v in _views(get_resolver().url_patterns) if getattr(v, "csrf_exempt", False)}
    assert exempt == {views.answer}


def test_every_post_form_carries_a_csrf_token():
    """Except the MTurk completion form: it posts to mturk.com, which must never see our token."""
    forms = []
    for path in [*ROOT.glob("templates/**/*.html"), *ROOT.glob("*/templates/**/*.html")]:
        for form in re.findall(r"<form\b[^>]*method=\"post\".*?</form>", path.read_text(), re.S | re.I):
            forms.append((path.name, form))
    assert len(forms) >= 8
    for name, form in forms:
        if 'id="mturk-form"' in form:
            assert "csrf_token" not in form
        else:
            assert "{% csrf_token %}" in form, name
