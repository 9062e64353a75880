"""Logins are throttled (django-axes; issue 12, item 6): staff accounts guard every export."""
from datetime import timedelta

import pytest
from axes.models import AccessAttempt
from django.core.management import call_command
from django.db.models import F
from django.test import Client
from django.urls import reverse

pytestmark = pytest.mark.django_db

RIGHT = "right-pw-4821"


def login(address, username="res", password=RIGHT, page="login"):
    """POST to the researchers' login page (or the admin's, page="admin:login")."""
    c = Client(REMOTE_ADDR=address)
    r = c.post(reverse(page), {"username": username, "password": password, "next": "/dashboard/"})
    return r, "_auth_user_id" in c.session


@pytest.fixture
def researcher(django_user_model):
    return django_user_model.objects.create_user("res", password=RIGHT, is_staff=True)


def test_wrong_passwords_lock_the_account_and_the_address(researcher, settings):
    assert settings.AXES_FAILURE_LIMIT == 5
    for i in range(4):
        r, ok = login("198.51.100.7", password=f"wrong-{i}")
        assert r.status_code == 200 and not ok  # the form again, with its error
    r, ok = login("198.51.100.7", password="wrong-4")  # the fifth wrong password locks
    assert r.status_code == 429 and not ok
    assert b"Traceback" not in r.content
    # locked: the right password is refused too, from this address and (the account) from any other
    r, ok = login("198.51.100.7")
    assert r.status_code == 429 and not ok
    r, ok = login("203.0.113.9")
    assert r.status_code == 429 and not ok
    r, ok = login("203.0.113.9", page="admin:login")  # the admin's login is the same account, locked too
    assert r.status_code == 429 and not ok
    # an unknown user name from the locked address is refused without a password check
    r, ok = login("198.51.100.7", username="someone-else")
    assert r.status_code == 429 and not ok


def test_the_lock_ends_after_the_cool_off_or_when_reset(researcher, settings):
    for i in range(6):
        login("198.51.100.7", password=f"wrong-{i}")
    assert login("198.51.100.7")[0].status_code == 429
    AccessAttempt.objects.update(attempt_time=F("attempt_time") - settings.AXES_COOLOFF_TIME - timedelta(seconds=1))
    r, ok = login("198.51.100.7")
    assert r.status_code == 302 and ok
    # and `manage.py axes_reset` lifts a lockout at once
    for i in range(6):
        login("198.51.100.8", password=f"wrong-{i}")
    assert login("198.51.100.8")[0].status_code == 429
    call_command("axes_reset")
    assert login("198.51.100.8")[1]


def test_a_correct_login_resets_the_count(researcher):
    for i in range(4):
        login("198.51.100.7", password=f"wrong-{i}")
    assert login("198.51.100.7")[1]
    for i in range(4):  # four more: still under the limit, since the success started afresh
        r, ok = login("198.51.100.7", password=f"again-{i}")
        assert r.status_code == 200
    assert login("198.51.100.7")[1]


def test_throttling_counts_the_address_behind_our_proxies(researcher, settings):
    """Behind nginx (TRUSTED_PROXY_COUNT = 1) every login arrives from 127.0.0.1: locking that
    address would lock everyone out, so the participant's address from X-Forwarded-For counts."""
    settings.TRUSTED_PROXY_COUNT = 1
    for i in range(6):
        c = Client(REMOTE_ADDR="127.0.0.1", HTTP_X_FORWARDED_FOR="198.51.100.7")
        c.post(reverse("login"), {"username": f"guess-{i}", "password": "x"})
    assert set(AccessAttempt.objects.values_list("ip_address", flat=True)) == {"198.51.100.7"}
    c = Client(REMOTE_ADDR="127.0.0.1", HTTP_X_FORWARDED_FOR="203.0.113.9")
    r = c.post(reverse("login"), {"username": "res", "password": RIGHT})
    assert r.status_code == 302 and "_auth_user_id" in c.session
