"""What participants' pages carry: on a study built from a real trajectory table,
nothing in a test page's HTML, embedded JSON or asset references tells theta*'s option apart
from the other three, and a training page carries only what it draws: for every domain,
each with its own whitelist (Domain.page_keys)."""
import json
import re

import numpy as np
import pytest
from django.test import Client
from django.urls import reverse

from studyapp.models import Participant, StepKind
from studyapp.participant import flow
from studyapp.researcher.studies import build_study
from teaching.core.build import build_table
from teaching.core.domain import domain_names, get_domain
from teaching.core.selection import showable
from teaching.core.table import TrajectoryTable
from tests.conftest import answer_payload, built_once

pytestmark = pytest.mark.django_db

N_TESTS = 4
SERVER_ONLY = ["theta", "cluster", "is_theta_star", "env_id", "class_name", "env_class", "theta_index"]
# words that would name what only the server may know: which option is theta*'s, its strategy (every
# registered domain's cluster names, "class: strategy")
FORBIDDEN = SERVER_ONLY + [n for name in domain_names() for n in get_domain(name).cluster_names if ":" in n]


def smallest_preset(domain):
    """The domain's cheapest preset to build: a study's pages need only a few environments."""
    return min(domain.presets, key=lambda p: p.n_envs * p.n_thetas)
JSON_SCRIPT = re.compile(r'<script id="([^"]+)" type="application/json">(.*?)</script>', re.S)
OPTION_BLOCKS = (re.compile(r'<section class="option".*?</section>', re.S),
                 re.compile(r'<div class="rating" data-option.*?</div>', re.S))
URL_ATTR = re.compile(r'(?<![-\w])(?:src|href|action)="([^"]*)"')


@pytest.fixture(scope="module", params=domain_names())
def tiny_table(request, tmp_path_factory):
    preset = smallest_preset(get_domain(request.param))
    out = built_once(tmp_path_factory, f"{preset.name}-table", lambda out: build_table(preset, out))
    return TrajectoryTable.load(out), out


def distinct_options(table, m) -> list[int]:
    """θ indices of θ*'s trajectory in table row `m` and of up to three others, each a trajectory of its
    own (the furthest from θ*'s first): where many θs share one path (a yard has few ways across), the
    furthest θs may all be one trajectory."""
    seen, picked = {table.controls[m, 0].tobytes()}, [0]
    for n in np.argsort(-table.d_euclid[m]):
        key = table.controls[m, n].tobytes()
        if key not in seen and len(picked) < 4:
            seen.add(key)
            picked.append(int(n))
    return picked


def shows_the_way(table) -> bool:
    """A world too small for four different trajectories in an environment (Lee et al.'s three) tests by
    asking to show the way, which a domain that scores a shown way (score_shown) can."""
    return callable(getattr(table.domain, "score_shown", None)) and not any(
        len(distinct_options(table, int(m))) == 4 for m in np.flatnonzero(showable(table)))


def real_spec(table, path, slug="real"):
    """A study on the tiny table: two conditions of two training examples, and N_TESTS tests, each
    theta*'s trajectory and three other trajectories (all real optima, all four different), or on a
    world that shows the way, N_TESTS show tests."""
    ok = [int(m) for m in np.flatnonzero(showable(table))]
    train = ok[:4]
    if shows_the_way(table):
        test_set = [{"env_id": int(table.env_ids[m]), "kind": "show"} for m in ok[4:4 + N_TESTS]]
    else:
        tests = [m for m in ok[4:] if len(distinct_options(table, m)) == 4][:N_TESTS]
        assert len(tests) == N_TESTS, f"{table.domain.name}: {len(tests)} environments with 4 different trajectories"
        test_set = [{"env_id": int(table.env_ids[m]), "options": [
            {"theta_index": n, "is_theta_star": n == 0} for n in distinct_options(table, m)]} for m in tests]
    return {"slug": slug, "name": "Real tiny study", "table": str(path), "test_set": test_set,
            "recruitment": "prolific", "completion_code": "REAL2026",
            "conditions": [{"name": "exact", "env_ids": [int(e) for e in table.env_ids[train[:2]]]},
                           {"name": "random", "env_ids": [int(e) for e in table.env_ids[train[2:]]]}]}


def embedded(html: str) -> dict:
    return {name: json.loads(body) for name, body in JSON_SCRIPT.findall(html)}


def walk(client, study, pid):
    """One participant through the study with the browser's requests; yields (participant,
    step, html) for every page shown."""
    r = client.get(reverse("entry", args=[study.slug]), {"PROLIFIC_PID": pid, "STUDY_ID": "S", "SESSION_ID": "X"})
    assert r.status_code == 302
    p = Participant.objects.get(platform_pid=pid)
    while True:
        p.refresh_from_db()
        step = flow.current_step(p)
        html = client.get(reverse("step", args=[study.slug, p.token])).content.decode()
        yield p, step, html
        if step.kind == StepKind.DONE:
            return
        r = client.post(reverse("answer", args=[study.slug, p.token, step.index]), answer_payload(p, step))
        assert r.status_code == 302, r.content[:300]


def test_no_test_page_tells_theta_stars_option_apart(tiny_table):
    table, path = tiny_table
    study = build_study(real_spec(table, path))
    assert study.source["kind"] == "table" and study.domain == table.domain.name
    keys = table.domain.page_keys
    assert keys and not set(keys) & set(SERVER_ONLY), keys  # the whitelist names nothing only the server knows
    star_letters, asset_sets = [], set()
    for pid in ("p1", "p2", "p3", "p4"):
        for p, step, html in walk(Client(), study, pid):
            low = html.lower()
            assert "{#" not in html and "{%" not in html, step.kind  # no template syntax reaches the page
            for word in FORBIDDEN:
                assert word.lower() not in low, (step.kind, word)
            data = embedded(html)
            if step.kind == StepKind.TRAINING:
                payload = p.condition.training[step.item]
                assert data == {"env-data": {k: payload[k] for k in (*keys, "robot")}, "scene-view": study.scene_view()}
            if step.kind != StepKind.TEST:
                continue
            test = study.test_set[step.item]
            assert '"robot"' not in html  # no trajectory outside the four options
            if study.test_kind == "show":  # the world and its rules, never θ*'s way nor its reward
                assert "optimum" not in html and data["scene-data"] == {k: test[k] for k in keys}
                asset_sets.add(frozenset(u for u in URL_ATTR.findall(html) if "/p/" not in u))
                continue
            shown = flow.option_letters(p, step.item)
            # the shared scene: the goal, the time step, the other car, the world's sizes; no reference trajectory
            assert set(data) == {"scene-data", "option-robots", "scene-view"}
            assert data["scene-data"] == {k: test[k] for k in keys}
            assert set(data["scene-view"]) <= {"study_span"}  # one number shared by every canvas of the study
            # four robots under opaque letters, all of one shape; theta*'s is just one of them
            robots = data["option-robots"]
            assert sorted(robots) == ["A", "B", "C", "D"]
            assert {letter: robots[letter] for letter, _ in shown} == {
                letter: test["options"][k]["robot"] for letter, k in shown}
            # rows of one width; their number may differ (a longer detour across a yard takes more moves)
            assert len({np.shape(r)[1:] for r in robots.values()}) == 1
            if study.domain == "driving":  # every drive lasts the horizon: 21 states of 5 numbers
                assert all(np.shape(r) == (21, 5) for r in robots.values())
            assert test["robot"] in robots.values()  # theta*'s own trajectory appears only as its option
            # the four animations and the four rating rows are the same markup but for their letter
            for pattern in OPTION_BLOCKS:
                blocks = pattern.findall(html)
                assert len(blocks) == 4
                masked = {re.sub(rf"(?<![A-Za-z]){letter}(?![A-Za-z])", "X", b)
                          for b, (letter, _) in zip(blocks, shown, strict=True)}
                assert len(masked) == 1, masked
            # the posted values are letters too: no option index anywhere in the form
            assert not re.search(r'name="(choice|played)" value="\d', html)
            asset_sets.add(frozenset(u for u in URL_ATTR.findall(html) if "/p/" not in u))  # not the form's
            star_letters.append(next(letter for letter, k in shown if test["options"][k]["is_theta_star"]))
    if study.test_kind != "show":
        assert len(star_letters) == 4 * N_TESTS
        assert len(set(star_letters)) > 1  # theta*'s letter is drawn per participant and test
    # every test page refers to the same static assets: nothing is fetched per option or per test
    assert len(asset_sets) == 1, asset_sets
    # static files, and the study's JavaScript catalog (one per study, the same on every page of it)
    catalog = reverse("jsi18n", args=[study.slug])
    assert all(u.startswith(("/static/", "#")) or u == catalog for u in next(iter(asset_sets))), asset_sets
