"""The study designer: a researcher picks a built table by its
identity, chooses conditions and settings, and "Build" selects every condition and the test set
on a worker; the study comes out closed, for previewing before it opens."""
from __future__ import annotations

import html
import json
import re

import pytest

from precompute import jobs
from precompute.design import TUNABLE, StudyDesignForm, fixed_field
from precompute.designlayout import placed_fields
from precompute.models import Job
from precompute.tables import TableBuildForm, built_tables
from studyapp.models import Study
from teaching.api import TrajectoryTable, select_test_set, selector_names

pytestmark = pytest.mark.slow
FORM = {"slug": "designed", "name": "Designed", "conditions": ["exact", "random", "coverage-random"],
        "target_per_condition": "20", "recruitment": "prolific", "completion_code": "C0DE1234",
        "approx_star": "det-euclidean", "seed": "0", "min_regret": "0.001", "min_distance": "0.5",
        "estimated_minutes": "15"}  # what the browser sends: every field, the initial values unchanged


@pytest.fixture
def tables(settings, demo_table):
    settings.TABLES_DIR = demo_table.parent  # the session's tmp root: the demo table and other scratch dirs
    return demo_table


def test_design_build_on_a_worker_then_preview(inprocess_worker, transactional_db, tables, staff_client):
    meta = json.loads((tables / "meta.json").read_text())
    page = staff_client.get("/precompute/design/").content.decode()
    assert "1,200 environments × 200 θ" in page and meta["content_hash"][:16] in page
    assert "θ* = (closeness -64, acceleration -0.1, speed_deviation -1, turning -0.1, goal_distance -0.5)" in page
    assert 'optgroup label="driving (' in page  # tables are listed under their domain

    r = staff_client.post("/precompute/design/", dict(FORM, table=str(tables)))
    job = Job.objects.get(kind=Job.STUDY)
    assert r.status_code == 302 and r["Location"] == job.get_absolute_url()
    job = jobs.wait(job, progress=False, timeout=180)
    assert job.status == Job.SUCCEEDED, job.error

    study = Study.objects.get(slug="designed")
    table = TrajectoryTable.load(tables)
    assert not study.is_open  # previewed first, opened on its dashboard page
    assert (study.recruitment, study.completion_code, study.target_per_condition) == ("prolific", "C0DE1234", 20)
    assert study.source["content_hash"] == meta["content_hash"] and study.source["theta_star"] == meta["theta_star"]
    assert [c.name for c in study.conditions.all()] == FORM["conditions"]
    assert all(c.training for c in study.conditions.all()) and len(study.test_set) == 6
    assert not {e for c in study.conditions.all() for e in c.env_ids} & {t["env_id"] for t in study.test_set}
    assert set(e for c in study.conditions.all() for e in c.env_ids) <= set(int(e) for e in table.env_ids)

    # the job page links to the study; its dashboard page previews each condition, then opens it
    assert "/dashboard/designed/" in staff_client.get(job.get_absolute_url()).content.decode()
    for condition in study.conditions.all():
        r = staff_client.post(f"/dashboard/designed/preview/{condition.pk}/")
        assert r.status_code == 302 and staff_client.get(r["Location"]).status_code == 200
    staff_client.post("/dashboard/designed/toggle/", {"open": "1"})
    assert Study.objects.get(slug="designed").is_open


def test_design_with_fixed_tau_a_hand_picked_condition_thresholds_and_texts(inprocess_worker, transactional_db,
                                                                           tables, staff_client):
    """Every choice of the designer reaches the study: a fixed τ instead of the paper's rule, a
    condition of the researcher's own environments in their order, the test set's thresholds and
    the consent page's texts."""
    table = TrajectoryTable.load(tables)
    picked = [int(e) for e in table.env_ids[[7, 3, 250]]]
    form = dict(FORM, slug="own", conditions=["det-euclidean"], fixed_det_euclidean="0.5",
                hand_picked_name="mine", hand_picked_env_ids=", ".join(map(str, picked)), min_regret="0.002",
                min_distance="0.5", consent_text="Our own consent text.", estimated_minutes="9",
                payment="£1.50", contact="lab@example.org", ethics_reference="ERB-42", table=str(tables))
    r = staff_client.post("/precompute/design/", form)
    assert r.status_code == 302, r.content.decode()[:2000]
    job = jobs.wait(Job.objects.get(kind=Job.STUDY), progress=False, timeout=180)
    assert job.status == Job.SUCCEEDED, job.error
    study = Study.objects.get(slug="own")
    assert study.name == "Designed"  # the form's title, not the hand-picked condition's name
    assert [c.name for c in study.conditions.all()] == ["det-euclidean", "mine"]
    assert study.conditions.get(name="mine").env_ids == picked  # as given, in the order given
    assert job.result["conditions"]["det-euclidean"]["value"] == 0.5  # fixed, not the rule's
    assert job.result["conditions"]["mine"]["value"] is None
    assert job.params["test_set_thresholds"] == {"min_regret": 0.002, "min_distance": 0.5}
    assert all(o["regret"] >= 0.002 for t in select_again(table, study, job) for o in t["options"]
               if not o["is_theta_star"])
    assert (study.consent_text, study.estimated_minutes, study.payment, study.contact, study.ethics_reference) == (
        "Our own consent text.", 9, "£1.50", "lab@example.org", "ERB-42")
    assert not {e for c in study.conditions.all() for e in c.env_ids} & {t["env_id"] for t in study.test_set}


def select_again(table, study, job):
    """The test set the job chose, re-selected with the job's own seed and thresholds (the study
    stores its options' trajectories, not their regrets)."""
    tests = select_test_set(table, [c.env_ids for c in study.conditions.all()], seed=job.params["seed"],
                            **job.params["test_set_thresholds"])
    assert [t["env_id"] for t in tests] == [t["env_id"] for t in study.test_set]
    assert all(t["min_option_distance"] >= 0.5 for t in tests)
    return tests


def test_design_form_errors(db, tables, staff_client, make_study):
    make_study(slug="taken")
    cases = [
        (dict(FORM, slug="taken"), "exists already"),
        (dict(FORM, slug="bad slug"), "'slug' may hold only letters, digits, - and _, not 'bad slug'"),
        (dict(FORM, completion_code=""), "Prolific only accepts its study"),
        (dict(FORM, conditions=[]), "Choose at least one condition, or give a hand-picked or closed-loop one."),
        (dict(FORM, fixed_det_euclidean="abc"), "τ of det-euclidean must be a number greater than 0 (e.g. 0.5), "
                                                 "not 'abc'; leave it empty for the paper's rule."),
        (dict(FORM, fixed_prob_reward="-2"), "λ of prob-reward must be a number greater than 0"),
        (dict(FORM, hand_picked_env_ids="12, x"), "Give whole environment ids"),
        (dict(FORM, hand_picked_env_ids="999999"), "Not in this table: 999999"),
        (dict(FORM, hand_picked_env_ids="1", hand_picked_name="random"), "already one of the chosen conditions"),
        (dict(FORM, min_distance="-1"), "test-set threshold 'min_distance' must be a number, 0 or more, not -1.0"),
        (dict(FORM, estimated_minutes="ten"), "Enter a whole number"),
        (dict(FORM, target_per_condition="0"), "'target_per_condition' must be a positive whole number up to 100,000"),
        (dict(FORM, table="/nowhere"), "Select a valid choice"),
        (dict(FORM, test_kind="show"), "the driving domain cannot replay and score a way a participant shows"),
    ]
    for data, message in cases:
        data.setdefault("table", str(tables))
        r = staff_client.post("/precompute/design/", data)
        page = r.content.decode()
        assert r.status_code == 200 and html.escape(message) in page, message
        assert "--hyper" not in page and "MODEL=VALUE" not in page  # the researcher's words, not a command line
    assert not Job.objects.exists() and not Study.objects.filter(slug="designed").exists()


def test_the_designer_is_for_researchers_only(db, client, tables):
    r = client.get("/precompute/design/")
    assert r.status_code == 302 and r["Location"].startswith("/login/")
    assert client.post("/precompute/design/", dict(FORM, table=str(tables))).status_code == 302
    assert not Study.objects.exists()


def test_no_table_yet_says_how_to_build_one(db, settings, tmp_path, staff_client):
    settings.TABLES_DIR = tmp_path
    page = staff_client.get("/precompute/design/").content.decode()
    assert "No trajectory table is built" in page and "python -m teaching build --preset demo" in page


def test_build_a_table_from_the_designer_with_progress(inprocess_worker, transactional_db, settings, tmp_path,
                                                       staff_client):
    """No table yet: the researcher starts one on the workers, follows it on the job page, and the
    designer lists it, with its identity, once it is published."""
    settings.TABLES_DIR = tmp_path
    page = staff_client.get("/precompute/design/").content.decode()
    assert "No trajectory table is built" in page and "Build table" in page
    r = staff_client.post("/precompute/design/table/", {"preset": "tiny", "theta_star": "-32,-0.2,-1,-0.1,-0.5"})
    job = Job.objects.get(kind=Job.TABLE)
    assert r.status_code == 302 and r["Location"] == job.get_absolute_url()
    assert job.params["out"] == str(tmp_path / job.params["preset"]["name"])
    status = staff_client.get(f"/precompute/jobs/{job.pk}/status.json").json()  # what the job page polls
    assert status["chunks_total"] == 3 and status["kind"] == Job.TABLE
    job = jobs.wait(job, progress=False, timeout=180)
    assert job.status == Job.SUCCEEDED, job.error
    page = staff_client.get("/precompute/design/").content.decode()
    assert "48 environments × 24 θ" in page
    assert "θ* = (closeness -32, acceleration -0.2, speed_deviation -1, turning -0.1, goal_distance -0.5)" in page
    assert TrajectoryTable.load(job.params["out"]).meta["theta_star"] == [-32, -0.2, -1, -0.1, -0.5]


@pytest.mark.parametrize("data, message", [
    ({"preset": "huge"}, "Select a valid choice"),
    ({"preset": "tiny", "envs": "2"}, "A table needs at least 4 environments."),
    ({"preset": "tiny", "envs": "99999"}, "must lie in [4, 21,216] (driving), got 99999"),
    ({"preset": "gridworld-tiny", "envs": "20000"}, "must lie in [4, 17,460] (gridworld), got 20000"),
    ({"preset": "gridworld-tiny", "theta_star": "-1,-1,-1,-1,-1"}, "θ* needs one weight per feature (4), got 5"),
    ({"preset": "tiny", "thetas": "1"}, "A table needs at least 2 θ: θ* and one other."),
    ({"preset": "tiny", "theta_star": "-1,-1"}, "θ* needs one weight per feature (5), got 2"),
    ({"preset": "tiny", "theta_star": "-1,-1,-1,-1,1"}, "must be a negative number"),
    ({"preset": "tiny", "sampler": "gauss"}, "Select a valid choice"),
])
def test_table_form_errors(db, settings, tmp_path, staff_client, data, message):
    settings.TABLES_DIR = tmp_path
    r = staff_client.post("/precompute/design/table/", data)
    assert r.status_code == 400 and message in r.content.decode(), r.content.decode()[-3000:]
    assert not Job.objects.exists()


def test_table_builds_are_for_researchers_only(db, client):
    r = client.post("/precompute/design/table/", {"preset": "tiny"})
    assert r.status_code == 302 and r["Location"].startswith("/login/")
    assert not Job.objects.exists()


def field_block(page: str, name: str) -> str:
    """The rendered <div class="field"> of field `name` (label, input, help text, its errors)."""
    blocks = [b for b in page.split('<div class="field">') if f'id="id_{name}"' in b or f'for="id_{name}"' in b]
    assert len(blocks) == 1, name
    return blocks[0]


def test_the_table_form_shows_every_error_under_its_field(db, settings, tmp_path, staff_client):
    settings.TABLES_DIR = tmp_path
    r = staff_client.post("/precompute/design/table/", {"preset": "tiny", "envs": "2", "thetas": "1",
                                                         "theta_star": "-1,-1", "seed": "-3"})
    page = r.content.decode()
    assert r.status_code == 400 and set(r.context["table_form"].errors) == {"envs", "thetas", "theta_star", "seed"}
    for name, message in [("envs", "at least 4 environments"), ("thetas", "at least 2 θ"),
                          ("theta_star", "θ* needs one weight per feature (5), got 2"),
                          ("seed", "0 or more")]:
        assert message in field_block(page, name), name
    assert not Job.objects.exists()


def test_every_designer_field_has_help_and_each_model_its_own_tau_or_lambda(db, settings, tmp_path, staff_client):
    for form in (StudyDesignForm(tables=[]), TableBuildForm()):
        missing = [name for name, field in form.fields.items() if not field.help_text]
        assert not missing, f"{type(form).__name__}: no help text for {missing}"
    assert [m for m, _ in TUNABLE] == ["det-reward", "det-euclidean", "prob-reward", "prob-euclidean", "hierarchical"]
    assert dict(TUNABLE)["hierarchical"] == "λ"  # its λ within the strategy
    assert dict(TUNABLE)["det-euclidean"] == "τ" and dict(TUNABLE)["prob-reward"] == "λ"
    settings.TABLES_DIR = tmp_path
    page = staff_client.get("/precompute/design/").content.decode()
    assert re.search(r"Seeds the θ and environment samples", page)
    assert StudyDesignForm(tables=[]).fields[fixed_field("prob-euclidean")].label == \
        "prob-euclidean: fixed λ (optional)"


def test_the_designer_lists_tables_by_domain_with_thetas_feature_names(db, settings, tables, gridworld_table,
                                                                       staff_client):
    """A driving and a gridworld table side by side: each under its domain, θ* named by its features;
    the table form offers both domains' presets, each saying how many weights its θ* has."""
    import shutil  # noqa: PLC0415

    root = tables.parent
    if not (root / "yard").exists():
        shutil.copytree(gridworld_table, root / "yard")
    page = staff_client.get("/precompute/design/").content.decode()
    assert 'optgroup label="driving (' in page and 'optgroup label="gridworld (' in page
    assert "θ* = (carry_moves -1, cart_moves -0.3, mud -2.5, near_dog -1.2)" in page
    assert "gridworld: θ* has 4 weights (carry_moves, cart_moves, mud, near_dog)" in html.unescape(page)
    form = StudyDesignForm(dict(FORM, table=str(root / "yard")), tables=[])
    assert not form.is_valid() and "table" in form.errors  # only listed tables can be chosen


def test_design_a_gridworld_study_on_a_worker(inprocess_worker, transactional_db, settings, gridworld_table,
                                              staff_client):
    """The designer's Build on a gridworld table: the workers select its sequences and test set with the
    gridworld's own test clusters and option distance (the empty field), and the study is a gridworld one."""
    settings.TABLES_DIR = gridworld_table.parent
    form = {k: v for k, v in FORM.items() if k != "min_distance"}  # empty: the domain's default
    r = staff_client.post("/precompute/design/", dict(form, slug="yard-designed", table=str(gridworld_table)))
    job = Job.objects.get(kind=Job.STUDY)
    assert r.status_code == 302, r.content.decode()[-2000:]
    job = jobs.wait(job, progress=False, timeout=180)
    assert job.status == Job.SUCCEEDED, job.error
    assert "min_distance" not in job.params["test_set_thresholds"]
    study = Study.objects.get(slug="yard-designed")
    assert study.domain == "gridworld" and study.source["domain"] == "gridworld"
    assert len(study.test_set) == 4  # mud and dog strategies, one test each (the domain's test_clusters)
    assert all(set(t) >= {"yard", "dt", "options"} for t in study.test_set)
    for condition in study.conditions.all():  # every condition previews (its pages draw yards)
        r = staff_client.post(f"/dashboard/yard-designed/preview/{condition.pk}/")
        assert r.status_code == 302 and staff_client.get(r["Location"]).status_code == 200


# --- the page's layout: sections, conditions as rows, a summary before Build ---------------------------------
def test_every_designer_field_stands_in_exactly_one_place(db, tables):
    form = StudyDesignForm(tables=built_tables(tables.parent))
    placed = placed_fields(form)
    assert len(placed) == len(set(placed)), [f for f in placed if placed.count(f) > 1]
    assert set(placed) == set(form.fields)


def test_the_designer_is_in_sections_with_the_conditions_as_rows_and_a_summary_before_build(db, tables,
                                                                                           staff_client):
    page = staff_client.get("/precompute/design/").content.decode()
    legends = re.findall(r"<legend>(.*?)</legend>", page)
    assert legends == ["1. Study and table", "2. Conditions", "3. Tests", "4. Participants and payment", "5. Texts"]
    assert page.index('id="design-summary"') < page.index('<button type="submit">Build</button>')
    assert page.index("</fieldset>", page.index("5. Texts")) < page.index('id="design-summary"')
    rows = re.findall(r'<tr data-condition="([^"]+)">(.*?)</tr>', page, re.S)
    assert [name for name, _ in rows] == list(selector_names())  # one row per registered selector, in order
    for name, row in rows:
        assert f'name="conditions" value="{name}"' in row
        for field, (selector, _key, _f) in StudyDesignForm(tables=[]).selector_params.items():
            assert (f'name="{field}"' in row) == (selector == name), (name, field)  # its parameters on its row
    folds = re.findall(r'<details class="design-group"( open)?><summary>(.*?)</summary>', page)
    assert [title for _, title in folds] == ["A hand-picked condition", "A closed-loop condition",
                                             "Learner models and seed", "A performance bonus",
                                             "Time limit and a code for each way of ending",
                                             "The consent page", "A comprehension check"]
    assert not any(opened for opened, _ in folds)  # folded until needed


def test_a_folded_group_opens_on_its_error_and_the_sections_list_points_to_it(db, tables, staff_client):
    page = staff_client.post("/precompute/design/", dict(FORM, table=str(tables), hand_picked_env_ids="12, x",
                                                         loop_name="adaptive", loop_lapse="7")).content.decode()
    folds = dict((title, bool(opened)) for opened, title in
                 re.findall(r'<details class="design-group"( open)?><summary>(.*?)</summary>', page))
    assert folds == {"A hand-picked condition": True, "A closed-loop condition": True,
                     "Learner models and seed": False, "A performance bonus": False,
                     "Time limit and a code for each way of ending": False,
                     "The consent page": False, "A comprehension check": False}
    assert '<a href="#design-conditions" class="error">2. Conditions (to correct)</a>' in page
    assert '<a href="#design-tests">3. Tests</a>' in page
    assert "Give whole environment ids" in page
