"""A study's conditions may be any registered selector, with its parameters, and its tests graded by
difficulty: the study job selects each condition with teaching's own selector and parameters, records
them with the study, draws every test of the asked difficulty, and its pilot and analysis cover them."""
from __future__ import annotations

import io

import pytest
from django.core.management import call_command

from precompute.design import StudyDesignForm
from precompute.management.commands.build_study import split_conditions
from precompute.models import Job
from precompute.tables import built_tables
from studyapp.analysis.data import analyze_study
from studyapp.analysis.simulate import simulate
from studyapp.models import Study
from teaching.core.conditions import condition_params, condition_sequence
from teaching.core.selectors import get_selector
from teaching.core.table import TrajectoryTable
from teaching.domains.driving.synthetic import synthetic_table

SELECTED = "exact,scot,bec-scaffold:k=1,highlights:k=3"
# condition name -> (selector, the parameters given)
CONDITIONS = {"exact": ("exact", {}), "scot": ("scot", {}), "bec-scaffold-k1": ("bec-scaffold", {"k": 1}),
              "highlights-k3": ("highlights", {"k": 3})}


@pytest.fixture(scope="module")
def table_path(tmp_path_factory):
    """A saved synthetic table (300 environments × 80 θ): SCOT's cover leaves a test environment of every
    difficulty in every cluster (the tiny table's 48 environments do not)."""
    path = tmp_path_factory.mktemp("synthetic")
    synthetic_table(300, 80, n_candidates=6, seed=4).save(path)
    return path


def test_a_selectors_parameters_keep_their_commas_on_the_command_line():
    assert split_conditions(SELECTED) == ["exact", "scot", "bec-scaffold:k=1", "highlights:k=3"]
    assert split_conditions("bec-scaffold:k=2,levels=4,scot") == ["bec-scaffold:k=2,levels=4", "scot"]


@pytest.mark.slow
def test_a_study_of_selectors_with_graded_tests(inprocess_worker, transactional_db, table_path):
    call_command("build_study", "--table", str(table_path), "--slug", "field", "--conditions", SELECTED,
                 "--test-difficulty", "medium", "--wait", "--no-progress", "--timeout", "180", stdout=io.StringIO())
    study = Study.objects.get(slug="field")
    table = TrajectoryTable.load(table_path)
    assert [c.name for c in study.conditions.all()] == list(CONDITIONS)
    for c in study.conditions.all():  # each condition is teaching's own selector, run with its parameters
        selector, params = CONDITIONS[c.name]
        seq, _, _ = condition_sequence(table, selector, params=params)
        assert c.env_ids == [int(table.env_ids[e]) for e in seq.envs], c.name
        recorded = {"selector": selector, "params": condition_params(selector, params)}
        assert study.source["selectors"][c.name] == recorded
    result = Job.objects.get(kind=Job.STUDY).result["conditions"]
    assert result["bec-scaffold-k1"]["selector"] == "bec-scaffold" and result["bec-scaffold-k1"]["params"]["k"] == 1

    # every test of the asked difficulty, kept with the study's test set
    assert study.source["test_difficulty"] == "medium"
    assert len(study.test_set) == 6 and {t["difficulty"] for t in study.test_set} == {"medium"}
    assert all(0 <= t["bec_size"] <= 1 for t in study.test_set)

    # the simulated pilot predicts every condition, the example-based ones included
    pilot = study.source["pilot"]
    assert pilot["conditions"] == list(CONDITIONS)
    assert set(pilot["predicted"]["choice"]["exact"]) == set(CONDITIONS)

    # the analysis reports the scores by the tests' difficulty
    simulate(study, n_per_condition=3)
    by_difficulty = analyze_study(study).by_difficulty
    assert set(by_difficulty["condition"]) == set(CONDITIONS) and set(by_difficulty["difficulty"]) == {"medium"}
    assert (by_difficulty["n_answers"] == 6 * by_difficulty["n"]).all()


@pytest.mark.django_db
def test_the_designer_offers_every_selector_with_its_parameters_in_the_conditions_section(tiny_table):
    tables = [t for t in built_tables(tiny_table.parent) if t["path"] == str(tiny_table)]
    form = StudyDesignForm({"table": str(tiny_table), "slug": "designed", "target_per_condition": "20",
                            "recruitment": "link", "approx_star": "det-euclidean", "seed": "0", "min_regret": "0.001",
                            "estimated_minutes": "15", "conditions": ["exact", "scot", "bec-scaffold", "highlights"],
                            "min_distance": "0.1",
                            "bec_scaffold_k": "1", "highlights_k": "3", "test_difficulty": "high"}, tables=tables)
    names = list(form.fields)
    assert {"scot", "bec-scaffold", "highlights"} <= {v for v, _ in form.fields["conditions"].choices}
    params = {"random_uniform_length": ("random-uniform", "length"),
              "bec_scaffold_k": ("bec-scaffold", "k"), "bec_scaffold_levels": ("bec-scaffold", "levels"),
              "bec_scaffold_samples": ("bec-scaffold", "samples"), "highlights_k": ("highlights", "k")}
    assert names[names.index("conditions") + 1:names.index("target_per_condition")] == list(params)
    for field, (selector, key) in params.items():  # default and bound: the selector's declaration
        declared = get_selector(selector).params[key]
        assert form.fields[field].initial == declared.default
        assert form.fields[field].min_value == declared.check.minimum
    assert names.index("test_difficulty") == names.index("min_distance") + 1
    assert form.is_valid(), form.errors
    job = form.cleaned_data["job"]
    assert job["test_difficulty"] == "high"  # the tiny table has no medium test of every cluster
    assert job["conditions"][1:] == [{"name": "scot", "selector": "scot", "params": {}},
                                     {"name": "bec-scaffold", "selector": "bec-scaffold", "params": {"k": 1}},
                                     {"name": "highlights", "selector": "highlights", "params": {"k": 3}}]
