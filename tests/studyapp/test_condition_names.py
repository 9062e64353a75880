"""Two names of one condition are refused wherever a study is made, and a study
stored with them earlier takes no participants and is not analysed; the Holm family holds
distinct pairs of the study's conditions only, each once; unknown names are messages.

The Holm-adjusted p values are checked against Welch's t and Holm's step-down worked by hand
(tests/studyapp/test_analysis_stats.py's references: the incomplete beta function, no SciPy t-test,
no statsmodels)."""
from __future__ import annotations

import io
import json

import numpy as np
import pandas as pd
import pytest
from django.core.management import call_command
from django.core.management.base import CommandError

from precompute.design import StudyDesignForm
from precompute.tables import built_tables
from studyapp.analysis import data as D
from studyapp.analysis import stats as S
from studyapp.models import Condition, Study
from studyapp.participant import assignment
from studyapp.researcher.specschema import check_job
from studyapp.researcher.studies import SpecError, build_study, table_spec
from tests.conftest import TINY_TEST_SET
from tests.studyapp.test_analysis_stats import COVERAGE_CELLS, by_hand_means, hand_holm, hand_welch, make_data

pytestmark = pytest.mark.django_db

STRATEGY = "conditions 'det-strategy' and 'prob-strategy' are one condition (det-strategy)"
EUCLID = "conditions 'det-euclidean' and 'det-euclid' are one condition (det-euclidean)"


def spec(tiny_table, slug, sequences):
    return dict(table_spec(tiny_table, slug=slug, sequences=sequences, **TINY_TEST_SET), name=slug)


# ------------------------------------------------------------------ aliases, where a study is made

@pytest.mark.parametrize("sequences, message", [
    ({"det-strategy": [500, 5780], "prob-strategy": [7107, 15245]}, STRATEGY),
    ({"det-euclidean": [500, 5780], "det-euclid": [7107, 15245]}, EUCLID),
    ({"exact": [500], "Exact": [7107]}, "conditions 'exact' and 'Exact' are one condition (exact)"),
])
def test_build_study_and_create_study_refuse_aliases(tiny_table, tmp_path, sequences, message):
    with pytest.raises(SpecError, match=r"keep one of the names") as caught:
        build_study(spec(tiny_table, "aliased", sequences))
    assert message in str(caught.value)
    path = tmp_path / "spec.json"
    path.write_text(json.dumps(spec(tiny_table, "aliased", sequences)))
    with pytest.raises(CommandError) as caught:
        call_command("create_study", str(path), stdout=io.StringIO())
    assert message in str(caught.value)
    assert not Study.objects.filter(slug="aliased").exists()


def test_the_study_jobs_check_refuses_aliases(tiny_table):
    with pytest.raises(SpecError, match=STRATEGY.replace("(", r"\(").replace(")", r"\)")):
        check_job({"slug": "aliased", "conditions": ["det-strategy", "prob-strategy"]})
    with pytest.raises(SpecError) as caught:  # a hand-picked condition under another name of a selected one
        check_job({"slug": "aliased", "conditions": ["det-euclidean"], "hand_picked": {"det-euclid": [500]}})
    assert EUCLID in str(caught.value)
    assert not Study.objects.filter(slug="aliased").exists()


def test_the_designer_refuses_a_hand_picked_alias(tiny_table):
    tables = [t for t in built_tables(tiny_table.parent) if t["path"] == str(tiny_table)]
    base = {"table": str(tiny_table), "slug": "designed", "conditions": ["exact", "det-euclidean"],
            "target_per_condition": "20", "recruitment": "link", "approx_star": "det-euclidean", "seed": "0",
            "min_regret": "0.001", "min_distance": "0.1", "estimated_minutes": "15", "hand_picked_env_ids": "500"}
    form = StudyDesignForm(dict(base, hand_picked_name="det_euclid"), tables=tables)
    assert not form.is_valid()
    assert form.errors["hand_picked_name"] == [
        "'det_euclid' is another name of the chosen condition 'det-euclidean': choose a name of its own."]
    assert StudyDesignForm(dict(base, hand_picked_name="mine"), tables=tables).is_valid()


# ------------------------------------------------------------------ a study stored with aliases earlier

@pytest.fixture
def stored_aliased(make_study):
    """A study made before the check existed: det-strategy and (by a rename) prob-strategy, open."""
    study = make_study("old", sequences={"det-strategy": [500, 5780, 12165], "exact": [7107, 15245]})
    Condition.objects.filter(study=study, name="exact").update(name="prob-strategy")
    assert study.is_open
    return study


def test_a_stored_aliased_study_takes_no_one_and_its_dashboard_says_why(stored_aliased, staff_client):
    assert stored_aliased.opening_problems()[0].startswith(STRATEGY)
    with pytest.raises(assignment.StudyClosed):
        assignment.assign(stored_aliased, "prolific", "p1")
    page = staff_client.get("/dashboard/old/").content.decode()
    assert "Cannot open: " + STRATEGY.replace("'", "&#x27;") in page
    r = staff_client.get("/s/old/", {"PROLIFIC_PID": "p2", "STUDY_ID": "s", "SESSION_ID": "x"})
    assert r.status_code != 500 and not stored_aliased.participants.exists()


def test_a_stored_aliased_study_is_not_analysed(stored_aliased, staff_client):
    with pytest.raises(S.ConditionError, match=STRATEGY.replace("(", r"\(").replace(")", r"\)")):
        D.analyze_study(stored_aliased)
    with pytest.raises(CommandError, match="are one condition"):
        call_command("analyze", "old", stdout=io.StringIO())
    r = staff_client.get("/dashboard/old/analysis/")
    page = r.content.decode()
    assert r.status_code == 200 and "This study cannot be analysed: " in page and "Welch" not in page
    r = staff_client.get("/dashboard/old/analysis/", {"fragment": "1"})
    assert "cannot be analysed" in r.content.decode()


def test_the_analysis_never_pools_two_names():
    # 3 + 3 training examples under two names of det-euclidean: pooled, a participant would count 6
    P, A, T = make_data({"det-euclidean": COVERAGE_CELLS["det-euclidean"], "exact": COVERAGE_CELLS["exact"]})
    T = pd.concat([T, pd.DataFrame([dict(condition="det-euclid", position=0, cluster=0)])], ignore_index=True)
    with pytest.raises(S.ConditionError, match=EUCLID.replace("(", r"\(").replace(")", r"\)")):
        S.analyze(P, A, T)
    with pytest.raises(S.ConditionError):
        S.participant_table(P, A, T)


# ------------------------------------------------------------------ the Holm family

@pytest.mark.parametrize("kwargs, message", [
    (dict(extra_comparisons=[("exact", "exact")]), "exact:exact compares exact with itself"),
    (dict(extra_comparisons=[("random", "det-euclidean")]),
     "random:det-euclidean is the planned comparison det-euclidean vs random again"),
    (dict(extra_comparisons=[("det-euclid", "exact")]), "is the planned comparison det-euclidean vs exact again"),
    (dict(extra_comparisons=[("exact", "coverage-random"), ("coverage-random", "exact")]),
     "coverage-random:exact is the named comparison exact vs coverage-random again"),
    (dict(extra_comparisons=[("foo", "exact")]), "'foo' is not a condition of this study"),
    (dict(approx_star="random"), "approx* must be one of the approximate models"),
    (dict(approx_star="coverage-random"), "not 'coverage-random'"),
    (dict(approx_star="foo"), "not 'foo'"),
    (dict(comparisons=[("exact", "random"), ("random", "exact")]), "random:exact is the planned comparison"),
])
def test_the_family_is_distinct_pairs_of_known_conditions(kwargs, message):
    P, A, T = make_data(COVERAGE_CELLS)
    with pytest.raises(S.ConditionError) as caught:
        S.analyze(P, A, T, **kwargs)
    assert message in str(caught.value)


def test_holm_over_distinct_pairs_by_hand():
    P, A, T = make_data(COVERAGE_CELLS)
    extra = [("coverage-approx*", "coverage-random"), ("exact", "random")]
    an = S.analyze(P, A, T, extra_comparisons=extra)
    pairs = [("det-euclidean", "exact"), ("det-euclidean", "random"), ("coverage-approx*", "random"),
             ("coverage-random", "random"), *extra]
    assert list(zip(an.welch["a"], an.welch["b"], strict=True)) == pairs
    means = by_hand_means(COVERAGE_CELLS)
    p = [hand_welch(means[a], means[b])["p"] for a, b in pairs]
    assert np.allclose(an.welch["p"], p, atol=1e-9)
    assert np.allclose(an.welch["p_holm"], hand_holm(p), atol=1e-9)
    # a family of six: the smallest p is multiplied by 6, not by a count with repeats in it
    i = int(np.argmin(p))
    assert an.welch.loc[i, "p_holm"] == pytest.approx(min(1.0, 6 * p[i]), abs=1e-9)


@pytest.fixture
def paper_names(make_study):
    seqs = {"exact": [500], "det-euclidean": [5780], "random": [7107], "coverage-approx*": [15245],
            "coverage-random": [586]}
    return make_study("fam", sequences=seqs)


@pytest.mark.parametrize("args, message", [
    (["--compare", "exact:exact"], "compares exact with itself"),
    (["--compare", "random:det-euclidean"], "is the planned comparison det-euclidean vs random again"),
    (["--compare", "foo:exact"], "'foo' is not a condition of this study"),
    (["--approx-star", "random"], "approx* must be one of the approximate models"),
    (["--approx-star", "coverage-random"], "not 'coverage-random'"),
    (["--approx-star", "foo"], "not 'foo'"),
])
def test_the_command_refuses_a_bad_family(paper_names, tmp_path, args, message):
    with pytest.raises(CommandError, match=message.replace("*", r"\*")):
        call_command("analyze", "fam", "--out", str(tmp_path), *args, stdout=io.StringIO())


@pytest.mark.parametrize("compare, message", [
    (["exact:exact"], "compares exact with itself"),
    (["foo:exact"], "&#x27;foo&#x27; is not a condition of this study"),
    (["exact"], "name two conditions as condition-a:condition-b"),
    (["random:det-euclidean"], "is the planned comparison det-euclidean vs random again"),
    (["coverage-random:exact", "exact:coverage-random"], "is the named comparison coverage-random vs exact again"),
])
def test_the_page_refuses_a_bad_compare_with_a_form_error(paper_names, staff_client, compare, message):
    for fragment in ({}, {"fragment": "1"}):
        r = staff_client.get("/dashboard/fam/analysis/", {"compare": compare, **fragment})
        page = r.content.decode()
        assert r.status_code == 400 and message in page and 'role="alert"' in page and "Traceback" not in page
    r = staff_client.get("/dashboard/fam/analysis/", {"compare": "coverage-random:exact"})
    assert r.status_code == 200 and "coverage-random vs exact" in r.content.decode()
