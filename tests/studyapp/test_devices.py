"""Device rules (studyapp/participant/devices.py): a study that needs a desktop screen turns away a phone or a small
screen on its consent page, with the reason, keeping no place for them and counting the refusal; what the
browser reports is checked again on the server, with the User-Agent's own word on phones."""
from __future__ import annotations

import pytest
from django.test import Client

from precompute.design import StudyDesignForm
from precompute.tables import built_tables
from studyapp.models import Participant, Study
from studyapp.participant import devices
from studyapp.participant.assignment import assign
from studyapp.researcher.dashboard import condition_stats
from studyapp.researcher.specschema import SpecError
from tests.studyapp.helpers import answer_url, step_url

IPHONE = "Mozilla/5.0 (iPhone; CPU iPhone OS 17_0 like Mac OS X) AppleWebKit/605.1.15 Mobile/15E148 Safari/604.1"
DESKTOP = "Mozilla/5.0 (X11; Linux x86_64) AppleWebKit/537.36 (KHTML, like Gecko) Chrome/156.0 Safari/537.36"


@pytest.fixture
def desktop_only(make_study):
    study = make_study(slug="desk", min_screen_width=1024, allow_phones=False, allow_tablets=False)
    assert (study.min_screen_width, study.allow_phones, study.allow_tablets) == (1024, False, False)
    return study


@pytest.mark.parametrize("reported, agent, says", [
    ({"screen_width": "1920", "device": "computer"}, DESKTOP, None),
    ({"screen_width": "390", "device": "phone"}, DESKTOP, "cannot be done on a phone"),
    ({"screen_width": "1920", "device": "computer"}, IPHONE, "cannot be done on a phone"),  # the agent's word wins
    ({"screen_width": "1180", "device": "tablet"}, DESKTOP, "cannot be done on a tablet"),
    ({"screen_width": "800", "device": "computer"}, DESKTOP, "at least 1024 pixels wide, and yours is 800"),
    ({}, DESKTOP, "needs JavaScript"),
    ({"screen_width": "", "device": ""}, DESKTOP, "needs JavaScript"),  # the page's fields, its script off
])
def test_what_the_browser_reports_is_checked_against_the_rules(desktop_only, reported, agent, says):
    problem = devices.problem(desktop_only, reported, agent)
    assert (problem is None) if says is None else says in problem


# what no page sends: its script writes String(a whole number) and one of DEVICES
TAMPERED = [{"screen_width": "²", "device": "computer"},  # str.isdigit() says True, int() refuses
            {"screen_width": "١٩٢٠", "device": "computer"},  # Arabic-Indic digits: int() reads 1920
            {"screen_width": "１９２０", "device": "computer"},  # full-width digits: int() reads 1920
            {"screen_width": "9" * 5000, "device": "computer"},
            {"screen_width": "1920.0", "device": "computer"},
            {"screen_width": "wide", "device": "computer"},
            {"screen_width": "1920", "device": "toaster"}]


@pytest.mark.parametrize("reported", TAMPERED, ids=range(len(TAMPERED)))
def test_what_no_page_sends_is_refused_as_such(desktop_only, reported):
    with pytest.raises(devices.ReportError):
        devices.problem(desktop_only, reported, DESKTOP)


@pytest.mark.parametrize("reported", TAMPERED, ids=range(len(TAMPERED)))
def test_a_tampered_consent_post_is_a_400_and_stores_nothing(desktop_only, reported):
    client = Client(HTTP_USER_AGENT=DESKTOP)
    p = assign(desktop_only, Participant.PROLIFIC, "tamperer")
    r = client.post(answer_url(p), {"consent": "yes", **reported})
    assert r.status_code == 400 and "could not be read; please reload the page" in r.content.decode()
    p.refresh_from_db()  # still there, as they were: no consent stored, no refusal counted
    assert p.position == 0 and not p.answers.exists()
    assert Study.objects.get(pk=desktop_only.pk).device_refusals == 0
    r = client.post(answer_url(p), {"consent": "yes", **reported}, HTTP_ACCEPT="application/json")
    assert r.status_code == 400 and r.json()["ok"] is False


def test_a_study_without_rules_takes_every_device(study):
    assert not study.has_device_rules
    assert devices.problem(study, {}, IPHONE) is None


def test_a_refused_phone_sees_why_keeps_no_place_and_is_counted(desktop_only):
    client = Client(HTTP_USER_AGENT=IPHONE)
    p = assign(desktop_only, Participant.PROLIFIC, "phone-user")
    page = client.get(step_url(p)).content.decode()
    assert 'id="device-rules"' in page and 'name="screen_width"' in page and "device.js" in page
    started = sum(r["started"] for r in condition_stats(desktop_only))
    r = client.post(answer_url(p), {"consent": "device", "screen_width": "390", "device": "phone"})
    assert r.status_code == 403 and "cannot be done on a phone" in r.content.decode()
    assert not Participant.objects.filter(pk=p.pk).exists()
    assert sum(r["started"] for r in condition_stats(desktop_only)) == started - 1
    assert Study.objects.get(pk=desktop_only.pk).device_refusals == 1


def test_agreeing_on_a_small_screen_is_refused_by_the_server_too(desktop_only):
    client = Client(HTTP_USER_AGENT=DESKTOP)
    p = assign(desktop_only, Participant.PROLIFIC, "small-screen")
    r = client.post(answer_url(p), {"consent": "yes", "screen_width": "800", "device": "computer"},
                    HTTP_ACCEPT="application/json")
    assert r.status_code == 403 and "yours is 800" in r.json()["error"]
    assert not Participant.objects.filter(pk=p.pk).exists()
    ok = assign(desktop_only, Participant.PROLIFIC, "big-screen")
    r = client.post(answer_url(ok), {"consent": "yes", "screen_width": "1920", "device": "computer"})
    assert r.status_code == 302
    ok.refresh_from_db()
    assert ok.position == 1 and Study.objects.get(pk=desktop_only.pk).device_refusals == 1


def test_the_designer_and_a_spec_refuse_bad_device_rules(make_study):
    for bad, message in (({"min_screen_width": -5}, "min_screen_width"), ({"allow_phones": "maybe"}, "true or false")):
        with pytest.raises(SpecError, match=message):
            make_study(slug="bad", **bad)


@pytest.mark.parametrize("devices, min_width, want", [
    ("", "", {"allow_phones": True, "allow_tablets": True}),  # the defaults, also for a post without the fields
    ("no-phones", "", {"allow_phones": False, "allow_tablets": True}),
    ("computers", "1024", {"allow_phones": False, "allow_tablets": False, "min_screen_width": 1024}),
])
def test_the_designer_sets_the_device_rules(db, tiny_table, devices, min_width, want):
    tables = [t for t in built_tables(tiny_table.parent) if t["path"] == str(tiny_table)]
    data = {"table": str(tiny_table), "slug": "designed", "target_per_condition": "20", "recruitment": "link",
            "approx_star": "det-euclidean", "seed": "0", "min_regret": "0.001", "estimated_minutes": "15",
            "conditions": ["exact"], "min_distance": "0.1"}  # the tiny table's tests (TINY_TEST_SET)
    if devices or min_width:
        data.update(devices=devices, min_screen_width=min_width)
    form = StudyDesignForm(data, tables=tables)
    assert form.is_valid(), form.errors
    job = form.cleaned_data["job"]
    assert {k: job[k] for k in want} == want and job["min_screen_width"] == int(min_width or 0)  # 0: any width
    bad = StudyDesignForm({**data, "min_screen_width": "-3"}, tables=tables)
    assert not bad.is_valid() and "min_screen_width" in bad.errors


def test_the_page_shows_the_servers_own_words(desktop_only):
    messages = devices.rules(desktop_only)["messages"]
    assert messages["phone"] == devices.problem(desktop_only, {"screen_width": "390", "device": "phone"})
    assert messages["tablet"] == devices.problem(desktop_only, {"screen_width": "1180", "device": "tablet"})
    assert messages["width"].replace("{width}", "800") == devices.problem(
        desktop_only, {"screen_width": "800", "device": "computer"})
