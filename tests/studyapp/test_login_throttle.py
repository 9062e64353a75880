"""Logins are throttled (django-axes): staff accounts guard every export."""
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


def test_wrong_passwords_lock_the_account_and_the_page_says_so(researcher, settings):
    assert settings.AXES_FAILURE_LIMIT == 5 and settings.LOGIN_ADDRESS_FAILURE_LIMIT == 50
    for i in range(4):
        r, ok = login("198.51.100.7", password=f"wrong-{i}")
        assert r.status_code == 200 and not ok  # the form again, with its error
    r, ok = login("198.51.100.7", password="wrong-4")  # the fifth wrong password locks the account
    assert r.status_code == 429 and not ok
    assert b"Traceback" not in r.content
    page = r.content.decode()
    assert "The account <strong>res</strong> is locked for" in page and "<strong>15 more minutes</strong>" in page
    assert "/admin/" in page and "Your address" not in page  # what is locked, and what is not
    assert r["Retry-After"] == str(15 * 60) and "no-store" in r["Cache-Control"]
    # locked: the right password is refused too, from this address and from any other, and on /admin/
    for address, page_name in (("198.51.100.7", "login"), ("203.0.113.9", "login"), ("203.0.113.9", "admin:login")):
        r, ok = login(address, page=page_name)
        assert r.status_code == 429 and not ok and "The account <strong>res</strong> is locked" in r.content.decode()


def test_a_locked_name_leaves_other_researchers_at_that_address_alone(researcher, django_user_model):
    """One researcher's typos must not lock out a colleague behind the same address (a lab's NAT)."""
    django_user_model.objects.create_user("colleague", password=RIGHT, is_staff=True)
    for i in range(6):
        login("198.51.100.7", password=f"wrong-{i}")
    assert login("198.51.100.7")[0].status_code == 429  # "res" is locked
    r, ok = login("198.51.100.7", username="colleague")
    assert r.status_code == 302 and ok
    assert login("198.51.100.7", username="colleague", page="admin:login")[1]


def test_guessing_many_names_locks_the_address_and_the_page_says_so(researcher, settings):
    """An address is locked only after LOGIN_ADDRESS_FAILURE_LIMIT wrong passwords across names."""
    settings.LOGIN_ADDRESS_FAILURE_LIMIT = 12
    for i in range(11):  # 11 names, one wrong password each: no name and not the address is locked
        r, _ = login("198.51.100.7", username=f"guess-{i}", password="x")
        assert r.status_code == 200
    assert login("198.51.100.7")[1]  # the right password still works from there
    r, ok = login("198.51.100.7", username="guess-11", password="x")  # the 12th locks the address
    assert r.status_code == 429
    page = r.content.decode()
    assert "Your address <strong>198.51.100.7</strong> is locked for" in page and "15 more minutes" in page
    assert "The account" not in page  # guess-11 itself has one failure only
    r, ok = login("198.51.100.7")  # now every name from that address, the right password too, and /admin/
    assert r.status_code == 429 and not ok and "Your address" in r.content.decode()
    assert login("198.51.100.7", page="admin:login")[0].status_code == 429
    assert login("203.0.113.9")[1]  # other addresses are not affected


def test_the_minutes_left_count_down_and_retries_do_not_extend_the_lock(researcher, settings):
    for i in range(5):
        login("198.51.100.7", password=f"wrong-{i}")
    AccessAttempt.objects.update(attempt_time=F("attempt_time") - timedelta(minutes=11))
    r, _ = login("198.51.100.7", password="wrong-again")  # refused while locked: not counted
    assert r.status_code == 429 and "<strong>4 more minutes</strong>" in r.content.decode()
    assert r["Retry-After"] == str(4 * 60)


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
