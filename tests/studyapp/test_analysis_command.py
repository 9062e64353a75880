"""A full synthetic study through the real models and flow, analysed by ``manage.py analyze``.

Simulated participants arrive through ``assignment.assign`` and answer every step through
``flow.record`` (so scores, exclusions and completion are the app's own).  Participants in
``coverage-approx*`` and approx* (``det-euclidean``) pick theta*'s option far more often than the
rest: the analysis must find that effect, and it must drop the participants who fail the
attention check (they answer the opposite way, so keeping them would hide the effect).
"""
from __future__ import annotations

import io
import random
import re

import numpy as np
import pandas as pd
import pytest
from django.contrib.auth.models import User
from django.core.management import call_command
from django.core.management.base import CommandError
from django.test import RequestFactory

from studyapp.analysis import data as D
from studyapp.analysis import stats as S
from studyapp.analysis import views as V
from studyapp.analysis.simulate import run_participant, simulate
from studyapp.models import Participant, StepKind
from studyapp.participant import assignment
from studyapp.researcher.studies import make_study
from tests.conftest import PAPER_SEQUENCES, TINY_TEST_SET

pytestmark = pytest.mark.django_db


@pytest.fixture(autouse=True)
def seeded_assignment(monkeypatch):
    """The app breaks assignment ties with SystemRandom; seed it so the simulated data are
    reproducible (the effect sizes are chosen so the assertions hold for almost any draw)."""
    monkeypatch.setattr(assignment, "_rng", random.Random(20261122), raising=False)


@pytest.fixture
def paper_study(tiny_table):
    """paper_study(slug, keep): a study on the tiny table with some of the paper's conditions."""
    def make(slug="synth", keep=None):
        seqs = {k: v for k, v in PAPER_SEQUENCES.items() if keep is None or S.canonical(k) in keep}
        return make_study(tiny_table, slug, seqs, **TINY_TEST_SET)
    return make


def test_synthetic_study_analyze_finds_the_effect(tmp_path, paper_study):
    study = paper_study()
    simulate(study)
    assignment.preview_participant(study.conditions.get(name="exact"))  # staff preview: never analysed
    out = tmp_path / "report"
    buf = io.StringIO()
    call_command("analyze", "synth", "--out", str(out), "--compare", "coverage-approx*:exact", stdout=buf)
    text = buf.getvalue()

    # files
    for name in ("index.html", "participants.csv", "answers.csv", "conditions.csv", "anova.csv", "welch.csv",
                 "correlations.csv", "examples_per_cluster.csv", "figures/scores.png", "figures/correlations.svg",
                 "figures/examples_per_cluster.png"):
        assert (out / name).exists(), name
    html = (out / "index.html").read_text()
    assert "Type III sums of squares" in html and "Welch" in html and "data:image/png;base64," in html

    # participants: everyone (excluded ones too), never the preview
    real = Participant.objects.filter(study=study).exclude(platform=Participant.PREVIEW)
    parts = pd.read_csv(out / "participants.csv")
    assert len(parts) == real.count() == 81
    n_failed = real.filter(excluded=True).count()
    assert n_failed > 0 and int(parts["excluded"].sum()) == n_failed
    assert (parts.loc[parts["excluded"], "attention_ok"] == False).all()  # noqa: E712
    assert set(parts["condition"]) >= {"det-euclidean", "det-strategy", "coverage-approx*"}  # canonical names
    ans = pd.read_csv(out / "answers.csv")
    assert len(ans) == 6 * (81 - n_failed)  # only included participants' answers
    # the mean score of a participant equals the mean of the app's stored confidence scores
    p0 = real.filter(excluded=False).first()
    stored = [a.confidence_score for a in p0.answers.filter(kind=StepKind.TEST)]
    assert parts.set_index("participant_id").loc[p0.pk, "mean_score"] == pytest.approx(np.mean(stored))

    # the effect
    welch = pd.read_csv(out / "welch.csv").set_index("comparison")
    cov = welch.loc["coverage-approx* vs random"]
    assert cov["diff"] > 2 and cov["p_holm"] < 0.05 and cov["cohen_d"] > 1
    star = welch.loc["approx* (det-euclidean) vs exact"]
    assert star["diff"] > 1.5 and star["p_holm"] < 0.05
    assert "coverage-approx* vs exact" in welch.index  # the researcher-named pair
    # no effect built in for coverage-random: far smaller than the built-in one
    assert abs(welch.loc["coverage-random vs random", "diff"]) < cov["diff"] / 2
    anova = pd.read_csv(out / "anova.csv")
    cm = anova[anova["anova"].str.startswith("coverage x model") & (anova["type"] == "III")].set_index("effect")
    assert cm.loc["model", "p"] < 0.001 and cm.loc["model", "partial_eta2"] > 0.3
    dd = anova[anova["anova"].str.startswith("distance + determinism") & (anova["type"] == "II")].set_index("effect")
    assert dd.loc["distance", "df"] == 2 and dd.loc["distance", "p"] < 0.05

    # printed summary
    assert "81 participants" in text and f"{n_failed} excluded" in text
    assert "Welch coverage-approx* vs random" in text and "Report:" in text


def test_exclusions_matter_and_unknown_study_errors(tmp_path, paper_study):
    study = paper_study("synth2")
    simulate(study, n_per_condition=3, seed=2)
    analysis = D.analyze_study(study)
    # same data with the exclusion flags ignored: the excluded participants' reversed answers move the means
    participants, answers, training = D.frames(study)
    no_excl = S.analyze(participants.assign(excluded=False), answers, training)
    assert analysis.n_included < no_excl.n_included
    assert not np.isclose(analysis.summary["mean"].sum(), no_excl.summary["mean"].sum())
    with pytest.raises(CommandError, match="no study 'nope'"):
        call_command("analyze", "nope", "--out", str(tmp_path))


def test_too_few_participants_reported_not_nan(tmp_path, paper_study):
    study = paper_study("tiny", ("exact", "det-euclidean", "random", "coverage-random"))
    buf = io.StringIO()
    call_command("analyze", "tiny", "--out", str(tmp_path / "empty"), stdout=buf)  # nobody yet: no crash
    assert "0 participants" in buf.getvalue() and (tmp_path / "empty" / "index.html").exists()
    rng = np.random.default_rng(0)
    for _ in range(5):  # balanced assignment: 2 in two conditions, 1 in the others
        run_participant(study, rng)
    buf = io.StringIO()
    call_command("analyze", "tiny", "--out", str(tmp_path), stdout=buf)
    text = buf.getvalue()
    assert "nan" not in text.lower()
    assert "Welch's t needs at least 2 per group" in text  # the planned pairs whose two conditions it has
    html = re.sub(r'data:image/png;base64,[^"]*', "", (tmp_path / "index.html").read_text())
    assert "Not every test could be run" in html and not re.search(r"\bnan\b", html.lower())


def test_report_is_computed_when_the_cache_is_down(monkeypatch, paper_study):
    study = paper_study("nocache", ("exact", "random"))
    simulate(study, n_per_condition=3, seed=4)

    def down(*args, **kwargs):
        raise ConnectionError("Redis is restarting")

    monkeypatch.setattr(V.cache, "get", down)
    monkeypatch.setattr(V.cache, "set", down)
    html = V.render_report(study)
    assert "Analysis of Synthetic study" in html


def test_live_report_is_cached_until_a_response_arrives(monkeypatch, paper_study):
    study = paper_study("live", ("exact", "det-euclidean", "random", "coverage-random", "coverage-approx*"))
    rng = simulate(study, n_per_condition=3, seed=3)
    calls = []
    real = D.analyze_study

    def counting(*a, **k):
        calls.append(1)
        return real(*a, **k)

    monkeypatch.setattr(D, "analyze_study", counting)
    first = V.render_report(study)
    assert V.render_report(study) == first and len(calls) == 1  # served from the cache
    run_participant(study, rng)  # new responses
    second = V.render_report(study)
    assert len(calls) == 2 and second != first
    assert "Analysis of Synthetic study" in second and "Type II sums of squares" in second

    # the view: full page, then the fragment with an ETag, then 304 while nothing changes
    staff = User.objects.create_user("r", password="x", is_staff=True)
    rf = RequestFactory()
    req = rf.get("/dashboard/live/analysis/")
    req.user = staff
    page = V.report(req, "live")
    assert page.status_code == 200 and b"analysis-live" in page.content and b"Welch" in page.content
    req = rf.get("/dashboard/live/analysis/", {"fragment": "1"})
    req.user = staff
    frag = V.report(req, "live")
    assert frag.status_code == 200 and frag["ETag"] and b"<html" not in frag.content
    # If-None-Match as browsers and proxies send it: the tag itself, a list, a weak tag (Django's rules)
    for header in (frag["ETag"], f'"other", {frag["ETag"]}', "W/" + frag["ETag"]):
        req = rf.get("/dashboard/live/analysis/", {"fragment": "1"}, HTTP_IF_NONE_MATCH=header)
        req.user = staff
        assert V.report(req, "live").status_code == 304, header
    run_participant(study, rng)
    req = rf.get("/dashboard/live/analysis/", {"fragment": "1"}, HTTP_IF_NONE_MATCH=frag["ETag"])
    req.user = staff
    assert V.report(req, "live").status_code == 200
    # researcher-named comparisons via the query string
    req = rf.get("/dashboard/live/analysis/", {"fragment": "1", "compare": "coverage-random:exact"})
    req.user = staff
    assert b"coverage-random vs exact" in V.report(req, "live").content
