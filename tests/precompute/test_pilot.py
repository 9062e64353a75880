"""The study designer's simulated pilot: the study job stores the ideal-user matrix of
exactly the study's conditions (teach.py's matrix, computed on the worker), and the study's
dashboard page shows it with a power table whose α, power and effect size the researcher picks."""
from __future__ import annotations

import io
import math
import re

import numpy as np
import pytest
from django.core.management import CommandError, call_command
from django.template.defaultfilters import floatformat
from statsmodels.stats.power import TTestIndPower

from precompute import jobs
from precompute.models import Job
from precompute.study import create_study_job
from studyapp.analysis.power import PAPER_EFFECTS, participants_needed
from studyapp.models import Study
from studyapp.researcher.specschema import check_job
from studyapp.researcher.studies import store_pilot
from teaching.core.answers import Question
from teaching.core.conditions import teach
from teaching.core.evaluation import USER_NAMES, ideal_user_matrix
from teaching.core.learners import Distances
from teaching.core.simulate import model_choices, predicted_scores
from teaching.core.table import TrajectoryTable

CONDITIONS = ["exact", "prob-reward", "random", "coverage-approx*"]
FIXED = {"det-euclidean": 0.5}  # approx*'s τ fixed; every other user by the paper's rule


@pytest.mark.slow
def test_the_study_job_stores_the_ideal_user_matrix_of_its_conditions(inprocess_worker, transactional_db,
                                                                       demo_table, staff_client):
    table = TrajectoryTable.load(demo_table)
    picked = [int(e) for e in table.env_ids[[7, 3, 250]]]
    job = create_study_job(demo_table, check_job({
        "slug": "piloted", "conditions": CONDITIONS, "hyperparameters": FIXED, "hand_picked": {"mine": picked},
        # options 0.5 apart: none left for one cluster
        "is_open": False, "target_per_condition": 30, "test_set_thresholds": {"min_distance": 0.25}}))
    job = jobs.wait(job, progress=False, timeout=300)
    assert job.status == Job.SUCCEEDED, job.error
    study = Study.objects.get(slug="piloted")
    pilot = study.source["pilot"]
    names = CONDITIONS + ["mine"]
    assert pilot["conditions"] == names and pilot["users"] == list(USER_NAMES)
    assert pilot["prior"] == 1 / table.n_thetas

    # the same matrix, computed directly: teach's own users (every τ / λ by the rule, det-euclidean
    # fixed) on the study's frozen sequences, as table rows
    result = teach(table, hyperparameters=FIXED)
    row = {int(e): i for i, e in enumerate(table.env_ids)}
    sequences = {c.name: [row[e] for e in c.env_ids] for c in study.conditions.all()}
    direct = ideal_user_matrix(result.models, sequences, Distances(table), sequence_names=names)
    assert np.array_equal(np.array(pilot["matrix"]), direct)
    assert pilot["models"] == {u: str(m) for u, m in result.models.items()}
    assert pilot["models"]["det-euclidean"] == "det-euclidean(tau=0.5)"
    assert direct.shape == (5, 8) and 0 <= direct.min() and direct.max() <= 1 and direct.max() > pilot["prior"]

    # what learners of each model choose in the study's tests: teaching's choice table on the same
    # sequences and tests, with each user's τ / λ; the page's scores follow from it alone
    predicted = pilot["predicted"]
    star = [[o["is_theta_star"] for o in t["options"]].index(True) for t in study.test_set]
    assert predicted["theta_star_option"] == star and set(predicted["choice"]) == set(USER_NAMES)
    questions = [Question(row[t["env_id"]], tuple(o["theta_index"] for o in t["options"])) for t in study.test_set]
    direct_choice = model_choices(table, result.models, sequences, questions)
    for u in USER_NAMES:
        for c in names:
            np.testing.assert_allclose(predicted["choice"][u][c], direct_choice[u][c], atol=1e-6)

    # the dashboard page shows it, before the study is opened
    assert not study.is_open
    page = staff_client.get("/dashboard/piloted/").content.decode()
    section = page[page.index('id="pilot"'):]
    assert "Simulated pilot" in page and 'id="pilot-matrix"' in section
    for name, values in zip(names, direct, strict=True):
        tr = re.search(rf'<tr data-condition="{re.escape(name)}">(.*?)</tr>', section, re.S).group(1)
        assert re.findall(r"<td>(?:<strong>)?([0-9.]+)", tr) == [floatformat(v, 3) for v in values], name
    assert all(u in section for u in USER_NAMES)
    assert '<th title="det-euclidean(tau=0.5)">det-euclidean<br><small>τ = 0.5</small>' in section
    scores = section[section.index('id="predicted-scores"'):]
    for name in names:
        tr = re.search(rf'<tr data-condition="{re.escape(name)}">(.*?)</tr>', scores, re.S).group(1)
        want = [predicted_scores(np.array(direct_choice[u][name]), np.array(star), 0.1) for u in USER_NAMES]
        assert re.findall(r"<td>(?:<strong>)?(-?[0-9.]+)", tr) == [floatformat(w.mean, 2) for w in want], name
    # the model's predicted effect between the study's conditions (coverage-approx* vs random) is planned for
    r = staff_client.get("/dashboard/piloted/", {"alpha": "0.05", "power": "0.8", "d": "0.5", "model": "prob-reward",
                                                 "lapse": "0.2"})
    row = next(x for x in r.context["power_rows"]
               if x["comparison"] == "coverage-approx* vs random, predicted by prob-reward")
    a, b = (predicted_scores(np.array(direct_choice["prob-reward"][c]), np.array(star), 0.2)
            for c in ("coverage-approx*", "random"))
    # (the stored P(option) are rounded to 6 decimals)
    assert row["d"] == pytest.approx((a.mean - b.mean) / math.sqrt((a.sd ** 2 + b.sd ** 2) / 2), rel=1e-4)
    assert "predicted for prob-reward learners with lapse rate 0.2" in row["source"]


@pytest.fixture
def sized(make_study):
    """Studies whose target per condition sits on either side of the hand-worked case's 64."""
    return {n: make_study(f"n{n}", target_per_condition=n) for n in (63, 64)}


def power_page(client, slug, **query):
    r = client.get(f"/dashboard/{slug}/", query)
    assert r.status_code == 200
    return r, r.content.decode()


def test_the_power_table_against_statsmodels_by_hand(sized, staff_client):
    # Cohen (1988): d = 0.5, alpha .05 two-sided, power .8 -> 63.77 per group -> 64
    exact = TTestIndPower().solve_power(effect_size=0.5, alpha=0.05, power=0.8, ratio=1.0, alternative="two-sided")
    assert exact == pytest.approx(63.77, abs=0.01) and math.ceil(exact) == 64
    for n, reached in ((64, True), (63, False)):
        r, page = power_page(staff_client, f"n{n}", alpha="0.05", power="0.8", d="0.5")
        rows = {row["comparison"]: row for row in r.context["power_rows"]}
        mine = rows["your effect size"]
        assert (mine["d"], mine["needed"], mine["reached"]) == (0.5, 64, reached)
        for effect in PAPER_EFFECTS:  # the paper's effects: the same solver on the d each p implies
            assert rows[effect.comparison]["needed"] == math.ceil(TTestIndPower().solve_power(
                effect_size=effect.d, alpha=0.05, power=0.8, ratio=1.0, alternative="two-sided"))
        assert rows["approx* vs exact"]["needed"] == 41
        assert re.search(r'data-effect="your effect size">.*?<td class="needed">64</td>', page, re.S)
        assert mine["power_at_n"] == pytest.approx(TTestIndPower().power(0.5, nobs1=n, alpha=0.05), abs=1e-12)
        assert ("reaches the chosen power" in page) is reached and ("falls short" in page) is not reached


def test_the_power_form_defaults_to_the_papers_effect(study, staff_client):
    r, page = power_page(staff_client, study.slug)
    form = r.context["power_form"]
    assert not form.is_bound and form["alpha"].value() == 0.05 and form["power"].value() == 0.8
    assert form["d"].value() == round(PAPER_EFFECTS[0].d, 3) == 0.628
    rows = r.context["power_rows"]
    assert rows[-1]["needed"] == participants_needed(0.628) == 41
    assert r.context["power_n"] == study.target_per_condition == 10 and not r.context["power_reached"]
    assert 'id="no-pilot"' in page  # a study not built by the designer has no matrix; the power table still shows
    assert "approx* vs exact" in page and "Welch p = 0.025 with 27 + 27 participants" in page


@pytest.mark.parametrize("query, message", [
    ({"alpha": "2"}, "α must lie between 0.0001 and 0.5."),
    ({"alpha": "0"}, "α must lie between 0.0001 and 0.5."),
    ({"power": "abc"}, "Power must be a number, e.g. 0.8."),
    ({"power": "1"}, "Power must be at most 0.999."),
    ({"alpha": "0.5", "power": "0.3"}, "Power must be above α (0.5)"),  # no n reaches less than α
    ({"d": "-1"}, "The effect size d must lie between 0.05 and 5."),
    ({"d": "1e-9"}, "The effect size d must lie between 0.05 and 5."),
    ({"d": "nan"}, "The effect size d must be a number"),
    ({"d": "inf"}, "The effect size d must be a number"),
    ({"alpha": ""}, "α is needed, e.g. 0.05."),
])
def test_bad_power_input_gives_a_message_not_a_500(study, staff_client, query, message):
    full = {"alpha": "0.05", "power": "0.8", "d": "0.5", **query}
    r, page = power_page(staff_client, study.slug, **full)
    assert message.replace("'", "&#x27;") in page, page[page.index('id="pilot"'):][:3000]
    assert r.context["power_rows"] is None and 'id="power-table"' not in page


def test_two_per_condition_when_they_already_reach_the_power(study, staff_client):
    # statsmodels' solver has no answer here (NaN: the page used to say "finds no sample size");
    # 2 per condition is the answer, checked by hand: their power already exceeds .5
    r, page = power_page(staff_client, study.slug, alpha="0.2", power="0.5", d="2")
    mine = r.context["power_rows"][-1]
    assert mine["needed"] == 2 and TTestIndPower().power(2.0, nobs1=2, alpha=0.2) >= 0.5
    assert 'id="power-table"' in page


def test_the_pilot_is_for_researchers_only(study, client):
    r = client.get(f"/dashboard/{study.slug}/", {"alpha": "0.05", "power": "0.8", "d": "0.5"})
    assert r.status_code == 302 and r["Location"].startswith("/login/")


# --- the learner models' predictions, on a pilot written by hand -------------------------------------
def hand_pilot(study):
    """Two conditions, two tests with two options each (θ*'s first, then second); one user sure of θ* after
    coverage-approx* and guessing after random, another guessing after both."""
    sure, guess = [[1.0, 0.0], [0.0, 1.0]], [[0.5, 0.5], [0.5, 0.5]]
    store_pilot(study, {"conditions": ["coverage-approx*", "random"], "users": ["sure", "unsure"],
                        "matrix": [[1.0, 0.1], [0.1, 0.1]], "models": {},
                        "predicted": {"theta_star_option": [0, 1],
                                      "choice": {"sure": {"coverage-approx*": sure, "random": guess},
                                                 "unsure": {"coverage-approx*": guess, "random": guess}}}})


def test_the_predicted_scores_and_effect_by_hand(study, staff_client):
    hand_pilot(study)
    r, page = power_page(staff_client, study.slug, alpha="0.05", power="0.8", d="0.5", model="sure", lapse="0")
    # sure learners pick θ* and rate it 7 in both tests; guessers score ±(1 + Binomial(6, 1/2)):
    # mean 0, a test's variance 1.5 + 4² = 17.5, the mean of two tests' 17.5 / 2
    cells = {row["condition"]: row["cells"] for row in r.context["predicted"]["rows"]}
    assert (cells["coverage-approx*"][0]["mean"], cells["coverage-approx*"][0]["accuracy"]) == (7.0, 1.0)
    assert cells["random"][0]["mean"] == pytest.approx(0.0) and cells["random"][0]["accuracy"] == 0.5
    row = next(x for x in r.context["power_rows"] if x["comparison"] == "coverage-approx* vs random, predicted by sure")
    d = 7.0 / math.sqrt((0.0 + 17.5 / 2) / 2)
    assert row["d"] == pytest.approx(d) and row["needed"] == participants_needed(min(d, 5.0))
    assert 'id="predicted-scores"' in page and "lapse rate ε = 0.0" in page
    # learners who guess after both conditions predict no difference: nothing to plan for, said so
    r, page = power_page(staff_client, study.slug, model="unsure", lapse="0.3", alpha="0.05", power="0.8", d="0.5")
    row = next(x for x in r.context["power_rows"]
               if x["comparison"] == "coverage-approx* vs random, predicted by unsure")
    assert row["d"] == pytest.approx(0.0) and row["needed"] is None and row["reached"] is None
    assert "no difference to plan for" in page and r.context["power_reached"] is False  # "your effect" needs 64


@pytest.mark.parametrize("query, message", [
    ({"lapse": "1.5"}, "The lapse rate must lie between 0 and 1."),
    ({"lapse": "x"}, "The lapse rate must be a number, e.g. 0.1."),
    ({"model": "det-manhattan"}, "Select a valid choice."),
])
def test_bad_model_or_lapse_gives_a_message(study, staff_client, query, message):
    hand_pilot(study)
    r, page = power_page(staff_client, study.slug, **{"alpha": "0.05", "power": "0.8", "d": "0.5", **query})
    assert message in page and r.context["power_rows"] is None


def test_the_power_command_adds_a_models_predicted_effects(study):
    hand_pilot(study)
    out = io.StringIO()
    call_command("power", "--study", study.slug, "--model", "sure", "--lapse", "0", stdout=out)
    d = 7.0 / math.sqrt(17.5 / 4)
    needed = participants_needed(min(d, 5.0))
    assert re.search(rf"coverage-approx\* vs random, predicted by sure\s+{d:.3f}\s+{needed}\s", out.getvalue())
    call_command("power", "--study", study.slug, "--model", "unsure", stdout=(out := io.StringIO()))
    assert "no difference to plan for" in out.getvalue()
    for argv, message in [
            (["--model", "sure"], "--model needs --study"),
            (["--study", study.slug, "--model", "nope"], "choose from sure, unsure"),
            (["--study", study.slug, "--model", "sure", "--lapse", "2"], "--lapse must lie between 0 and 1")]:
        with pytest.raises(CommandError, match=re.escape(message)):
            call_command("power", *argv, stdout=io.StringIO())
