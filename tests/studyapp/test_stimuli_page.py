"""The stimulus sheet (the designer's preview before opening): researchers only; its JSON
holds every condition's training examples in order and every test's options, each exactly as
the study stores it (what the participant's page draws: studyapp.trajectories.drawn_scene), and
the page marks theta*'s option once per test; closed and open studies alike; 404 for no study."""
import json
import re

import pytest
from django.test import Client
from django.urls import reverse

from studyapp.models import Participant, Study
from studyapp.trajectories import drawn_scene
from teaching.domains.driving.domain import DOMAIN as DRIVING

pytestmark = pytest.mark.django_db
JSON_SCRIPT = re.compile(r'<script id="([^"]+)" type="application/json">(.*?)</script>', re.S)


def embedded(html: str) -> dict:
    return {name: json.loads(body) for name, body in JSON_SCRIPT.findall(html)}


def url(study):
    return reverse("dashboard_stimuli", args=[study.slug])


def test_anonymous_is_sent_to_the_login_page(study):
    r = Client().get(url(study))
    assert r.status_code == 302 and r["Location"].startswith("/login/")


def test_a_participant_or_a_plain_account_cannot_see_it(study, django_user_model):
    c = Client()  # a participant who arrived through the study's link (a session, no account)
    c.get(reverse("entry", args=[study.slug]), {"PROLIFIC_PID": "p1", "STUDY_ID": "S", "SESSION_ID": "X"})
    assert Participant.objects.filter(platform_pid="p1").exists()
    r = c.get(url(study))
    assert r.status_code == 302 and r["Location"].startswith("/login/")
    plain = Client()
    plain.force_login(django_user_model.objects.create_user("plain", password="pw-plain-123"))
    r = plain.get(url(study))
    assert r.status_code == 302 and r["Location"].startswith("/login/")
    assert b"test-set" not in r.content


def test_unknown_study_is_404(staff_client, study):
    assert staff_client.get(reverse("dashboard_stimuli", args=["no-such-study"])).status_code == 404


@pytest.mark.parametrize("is_open", [False, True])
def test_every_example_and_every_option_is_in_the_page(staff_client, make_study, is_open):
    study = make_study("sheet", is_open=is_open)
    assert Study.objects.get(slug="sheet").is_open is is_open
    r = staff_client.get(url(study))
    assert r.status_code == 200
    html = r.content.decode()
    data = embedded(html)
    conditions = list(study.conditions.order_by("position", "pk"))
    assert len(conditions) == 3 and study.test_set
    # one block per condition, its examples in the stored order, each drawn as the participant's page draws it
    for c in conditions:
        examples = data[f"training-{c.pk}"]
        assert len(examples) == len(c.training) > 0
        assert [e["env_id"] for e in examples] == c.env_ids
        assert [e["scene"] for e in examples] == [drawn_scene(p, robot=True, domain=DRIVING) for p in c.training]
        assert all("world" in e["scene"] for e in examples)
        assert f'data-condition="{c.name}"' in html
        assert html.count(f'data-scene="training-{c.pk}"') == len(c.training)
    tests = data["test-set"]
    assert len(tests) == len(study.test_set)
    for shown, stored in zip(tests, study.test_set, strict=True):
        assert shown["env_id"] == stored["env_id"]
        assert shown["scene"] == drawn_scene(stored, robot=False, domain=DRIVING)
        assert len(shown["options"]) == len(stored["options"]) == 4
        assert [o["letter"] for o in shown["options"]] == list("ABCD")
        for o, s in zip(shown["options"], stored["options"], strict=True):
            assert (o["robot"], o["is_theta_star"], o["cluster_name"], o["theta_index"]) == (
                s["robot"], s["is_theta_star"], s["cluster_name"], s["theta_index"])
        assert f"env {stored['env_id']}" in html
    n_options = sum(len(t["options"]) for t in study.test_set)
    assert html.count('data-scene="test-set"') == n_options
    # theta* marked for the researcher: one option per test, and the cluster names written out
    assert html.count('data-theta-star="1"') == len(study.test_set)
    for t in study.test_set:
        for o in t["options"]:
            assert o["cluster_name"] in html
    # the canvases are drawn by the page's own module; the data are JSON blocks, never inline script
    assert "studyapp/stimuli.js" in html
    assert not re.search(r"<script(?![^>]*(type=\"application/json\"|type=\"module\" src=))", html)


def test_the_study_dashboard_links_to_it(staff_client, study):
    r = staff_client.get(reverse("dashboard_study", args=[study.slug]))
    assert r.status_code == 200 and url(study).encode() in r.content
