"""Researcher accounts: created by a command with Django's password validation, logged in and out
on the researchers' own pages, not the admin's."""
import io

import pytest
from django.contrib.auth import get_user_model
from django.core.management import call_command
from django.core.management.base import CommandError
from django.test import Client

pytestmark = pytest.mark.django_db
GOOD = "quiet-harbour-417"


def create(username, password, monkeypatch):
    monkeypatch.setattr("sys.stdin", io.StringIO(password + "\n"))
    out = io.StringIO()
    call_command("create_researcher", username, "--password-stdin", stdout=out)
    return out.getvalue()


def test_create_researcher_makes_a_staff_account(monkeypatch):
    assert "researcher alice created" in create("alice", GOOD, monkeypatch)
    user = get_user_model().objects.get(username="alice")
    assert user.is_staff and not user.is_superuser and user.check_password(GOOD)
    assert "researcher alice updated" in create("alice", GOOD + "-2", monkeypatch)  # a password reset
    assert get_user_model().objects.get(username="alice").check_password(GOOD + "-2")


@pytest.mark.parametrize("username, password, message", [
    ("alice", "short-1", "too short"),
    ("alice", "password1234", "too common"),
    ("alice", "4817263950", "entirely numeric"),
    ("harbourmaster", "harbourmaster1", "too similar"),
    ("alice", "", "the password is empty"),
])
def test_weak_passwords_are_refused(monkeypatch, username, password, message):
    with pytest.raises(CommandError, match=message) as exc:
        create(username, password, monkeypatch)
    assert "\n" not in str(exc.value)
    assert not get_user_model().objects.exists()


@pytest.mark.slow
def test_setup_demo_creates_the_fixed_demo_password_only_when_asked(demo_table, monkeypatch):
    """Only `make demo` asks (scripts/demo.sh passes --demo-login)."""
    monkeypatch.setenv("DEMO_TABLE", str(demo_table))
    out = io.StringIO()
    call_command("setup_demo", stdout=out)
    assert not get_user_model().objects.exists()
    assert "demo-password" not in out.getvalue() and "create_researcher" in out.getvalue()


def test_log_in_and_out_on_the_researcher_pages(django_user_model):
    django_user_model.objects.create_user("res", password=GOOD, is_staff=True)
    c = Client()
    r = c.get("/dashboard/")
    assert r.status_code == 302 and r["Location"] == "/login/?next=/dashboard/"
    page = c.get(r["Location"])
    assert page.status_code == 200 and b"Researcher login" in page.content and b"/admin/" not in page.content
    r = c.post("/login/", {"username": "res", "password": GOOD, "next": "/dashboard/"})
    assert r.status_code == 302 and r["Location"] == "/dashboard/"
    dashboard = c.get("/dashboard/")
    assert dashboard.status_code == 200 and b'action="/logout/"' in dashboard.content and b"res" in dashboard.content
    assert c.get("/logout/").status_code == 405  # logging out is a POST (a link could not log anyone out)
    r = c.post("/logout/")
    assert r.status_code == 302 and r["Location"] == "/login/"
    assert c.get("/dashboard/").status_code == 302  # logged out


def test_a_non_staff_account_cannot_reach_researcher_pages(django_user_model):
    django_user_model.objects.create_user("plain", password=GOOD)
    c = Client()
    r = c.post("/login/", {"username": "plain", "password": GOOD, "next": "/dashboard/"})
    assert r.status_code == 302  # the login itself succeeds ...
    r = c.get("/dashboard/")
    assert r.status_code == 302 and r["Location"].startswith("/login/")  # ... but the dashboard stays shut
    assert b"cannot see that page" in c.get(r["Location"]).content
