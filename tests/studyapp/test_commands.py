"""Management commands: create_study from a JSON spec, setup_demo (idempotent, prints the links)."""
import io
import json
import re

import numpy as np
import pytest
from django.contrib.auth import get_user_model
from django.core.management import call_command
from django.core.management.base import CommandError

import studyapp.researcher.studies
from studyapp import trajectories as tj
from studyapp.models import Condition, Participant, Study
from studyapp.participant import assignment
from studyapp.participant.assignment import assign
from studyapp.researcher.specschema import check_job
from studyapp.researcher.studies import SpecError, freeze_condition, freeze_test_set, new_study, table_spec
from teaching.api import TrajectoryTable, select_test_set
from teaching.domains.driving.synthetic import synthetic_table
from tests.conftest import TINY_TEST_SET

pytestmark = pytest.mark.django_db


def write(tmp_path, spec):
    path = tmp_path / "spec.json"
    path.write_text(json.dumps(spec))
    return path


SEQUENCES = {"exact": [500, 586], "random": [1149, 1473, 1945]}  # environments of the tiny table


@pytest.fixture
def spec(tiny_table):
    """A spec on the tiny table: its conditions, and a test set from teaching.core.testset."""
    return dict(table_spec(tiny_table, slug="cmd", sequences=SEQUENCES, **TINY_TEST_SET),
                name="From a spec", target_per_condition=12)


def test_create_study_from_spec(tmp_path, spec, tiny_table):
    out = io.StringIO()
    call_command("create_study", str(write(tmp_path, spec)), stdout=out)
    s = Study.objects.get(slug="cmd")
    table = TrajectoryTable.load(tiny_table)
    assert s.target_per_condition == 12 and s.source["kind"] == "table"
    assert s.source["content_hash"] == table.meta["content_hash"]
    assert [c.name for c in s.conditions.all()] == ["exact", "random"]
    assert s.conditions.get(name="random").env_ids == [1149, 1473, 1945]
    assert len(s.test_set) == 6 and "/s/cmd/" in out.getvalue()
    training_ids = {500, 586, 1149, 1473, 1945}
    assert not training_ids & {t["env_id"] for t in s.test_set}  # tests disjoint from training
    # what a participant is shown is the table's own trajectory: theta*'s, bit for bit (to 3 decimals)
    i = int(np.flatnonzero(table.env_ids == 1473)[0])
    shown = s.conditions.get(name="random").training[1]["robot"]
    assert np.allclose(shown, table.states(i, table.theta_star_index), atol=5e-4)


def test_a_spec_without_a_table_is_refused(tmp_path, spec):
    """No trajectory may come from anywhere but a table: nothing else says what theta* does."""
    del spec["table"]
    with pytest.raises(CommandError, match=re.escape("a spec needs a 'table'")):
        call_command("create_study", str(write(tmp_path, spec)), stdout=io.StringIO())
    assert not Study.objects.exists()


def test_an_environment_not_in_the_table_is_refused(tmp_path, spec):
    spec["conditions"][0]["env_ids"] = [99999999]
    with pytest.raises(CommandError, match="environment 99999999 is not in the table"):
        call_command("create_study", str(write(tmp_path, spec)), stdout=io.StringIO())
    assert not Study.objects.exists()


def test_create_study_is_idempotent_and_replace_is_guarded(tmp_path, spec):
    path = write(tmp_path, spec)
    call_command("create_study", str(path), stdout=io.StringIO())
    call_command("create_study", str(path), stdout=io.StringIO())
    assert Study.objects.count() == 1 and Condition.objects.count() == 2
    changed = dict(spec, conditions=[{"name": "only", "env_ids": [500]}])
    call_command("create_study", str(write(tmp_path, changed)), "--replace", stdout=io.StringIO())
    assert [c.name for c in Study.objects.get().conditions.all()] == ["only"]
    s = Study.objects.get()
    Participant.objects.create(study=s, condition=s.conditions.get())
    with pytest.raises(CommandError, match="already has participants"):
        call_command("create_study", str(path), "--replace", stdout=io.StringIO())


@pytest.mark.parametrize("spec, message", [
    ({"conditions": [{"name": "a", "env_ids": [1]}]}, "slug"),
    ({"slug": "x", "conditions": []}, "conditions"),
    ({"slug": "x", "conditions": [{"name": "a", "env_ids": [1]}, {"name": "a", "env_ids": [2]}]}, "unique"),
    ({"slug": "x", "conditions": [{"name": "a", "env_ids": []}]}, "env_ids"),
    ({"slug": "x", "conditions": [{"name": "a", "env_ids": [1]}]}, "needs a 'table'"),
    ({"slug": "x", "table": "/nonexistent", "conditions": [{"name": "a", "env_ids": [1]}]}, "test_set"),
])
def test_create_study_rejects_bad_specs(tmp_path, spec, message):
    with pytest.raises(CommandError, match=message):
        call_command("create_study", str(write(tmp_path, spec)), stdout=io.StringIO())
    assert not Study.objects.exists()


def test_create_study_unreadable_file(tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    with pytest.raises(CommandError, match="cannot read"):
        call_command("create_study", str(bad))
    with pytest.raises(CommandError, match="cannot read"):
        call_command("create_study", str(tmp_path / "missing.json"))


def test_setup_demo_without_a_table_says_how_to_build_one(tmp_path, monkeypatch):
    monkeypatch.setenv("DEMO_TABLE", str(tmp_path / "no-table"))
    with pytest.raises(CommandError) as exc:
        call_command("setup_demo", stdout=io.StringIO())
    assert str(exc.value) == (f"no trajectory table at {tmp_path / 'no-table'}: build the demo's with "
                              f"`python -m teaching build --preset demo --out {tmp_path / 'no-table'}` "
                              "(or run `make demo`)")
    assert not Study.objects.exists()


@pytest.mark.slow
def test_setup_demo_is_idempotent_and_prints_links(demo_table, monkeypatch):
    """The demo on the real demo table, through the real pipeline (selection and test set)."""
    monkeypatch.setenv("DEMO_TABLE", str(demo_table))
    out = io.StringIO()
    call_command("setup_demo", "--demo-login", stdout=out)
    call_command("setup_demo", "--demo-login", stdout=io.StringIO())
    text = out.getvalue()
    s = Study.objects.get(slug="demo")
    names = {c.name for c in s.conditions.all()}
    assert len(names) == 9 and {"exact", "random", "coverage-approx*", "coverage-random"} <= names
    assert "http://127.0.0.1:8000/s/demo/" in text and "/dashboard/demo/" in text
    assert "researcher / demo-password" in text and "trajectories: table" in text
    assert s.source["content_hash"] == TrajectoryTable.load(demo_table).meta["content_hash"]
    assert len(s.test_set) == 6 and s.is_open
    user = get_user_model().objects.get(username="researcher")
    assert user.is_staff and user.check_password("demo-password")
    assert get_user_model().objects.count() == 1 and Study.objects.count() == 1


def test_create_study_from_a_saved_table(tmp_path):
    table = synthetic_table(n_envs=16, n_thetas=8, seed=2)
    table.save(tmp_path / "table")
    ids = [int(e) for e in table.env_ids]
    tests = [{"env_id": e, "options": [{"theta_index": k, "is_theta_star": k == 0} for k in (0, 1, 2, 3)]}
             for e in ids[10:16]]
    spec = {"slug": "tab", "table": str(tmp_path / "table"), "test_set": tests,
            "conditions": [{"name": "exact", "env_ids": ids[:3]}, {"name": "random", "env_ids": ids[3:8]}]}
    call_command("create_study", str(write(tmp_path, spec)), stdout=io.StringIO())
    s = Study.objects.get(slug="tab")
    assert s.source["kind"] == "table" and s.source["content_hash"] == table.meta["content_hash"]
    assert s.conditions.get(name="random").env_ids == ids[3:8]
    assert [t["env_id"] for t in s.test_set] == ids[10:16]
    assert all(len(o["robot"]) == 21 for t in s.test_set for o in t["options"])
    # a test environment that is also shown in training is refused, and nothing is created
    spec.update(slug="tab2", test_set=[dict(tests[0], env_id=ids[4])] + tests[1:])
    with pytest.raises(CommandError, match=rf"test environments \[{ids[4]}\] also appear in a training"):
        call_command("create_study", str(write(tmp_path, spec)), stdout=io.StringIO())
    assert not Study.objects.filter(slug="tab2").exists()


def test_setup_demo_uses_the_table_when_the_pipeline_works(tmp_path, monkeypatch):
    """With a table, the demo's conditions and tests come from teaching.core.selection / teaching.core.testset
    (through teaching.api, which studyapp.researcher.studies imports them from)."""
    table = synthetic_table(n_envs=16, n_thetas=8, seed=3)
    table.save(tmp_path / "table")
    ids = [int(e) for e in table.env_ids]
    calls = {}

    def build_sequences(t, *, seed):
        calls["sequences"] = (t.meta["content_hash"], seed)
        return {"exact": ids[:2], "det-euclidean": ids[2:5]}

    def select_test_set(t, training, seed):
        calls["tests"] = training
        return [{"env_id": e, "options": [{"theta_index": k, "is_theta_star": k == 0} for k in (2, 0, 1, 3)]}
                for e in ids[8:14]]

    monkeypatch.setattr(studyapp.researcher.studies, "build_sequences", build_sequences)
    monkeypatch.setattr(studyapp.researcher.studies, "select_test_set", select_test_set)
    out = io.StringIO()
    call_command("setup_demo", "--table", str(tmp_path / "table"), stdout=out)
    s = Study.objects.get(slug="demo")
    assert s.source == {"kind": "table", "table": str(tmp_path / "table"), "content_hash": table.meta["content_hash"],
                        "theta_star": [float(v) for v in table.thetas[0]], "domain": "driving"}
    assert s.domain == "driving"
    assert calls == {"sequences": (table.meta["content_hash"], 0), "tests": [ids[:2], ids[2:5]]}
    assert {c.name: c.env_ids for c in s.conditions.all()} == {"exact": ids[:2], "det-euclidean": ids[2:5]}
    assert [o["is_theta_star"] for o in s.test_set[0]["options"]] == [False, True, False, False]
    assert "trajectories: table" in out.getvalue()


def test_setup_demo_rebuilds_after_the_table_changes_but_never_under_participants(tmp_path, monkeypatch):
    """A rebuilt demo table must not leave the demo serving stale trajectories, unless people have taken part."""
    def use(seed):
        table = synthetic_table(n_envs=16, n_thetas=8, seed=seed)
        table.save(tmp_path / "table")
        ids = [int(e) for e in table.env_ids]
        monkeypatch.setattr(studyapp.researcher.studies, "build_sequences", lambda t, seed: {"exact": ids[:2]})
        monkeypatch.setattr(studyapp.researcher.studies, "select_test_set", lambda t, tr, s: [
            {"env_id": e, "options": [{"theta_index": k, "is_theta_star": k == 0} for k in range(4)]}
            for e in ids[8:14]])
        return table.meta["content_hash"]

    monkeypatch.setenv("DEMO_TABLE", str(tmp_path / "table"))
    with pytest.raises(CommandError, match="no trajectory table"):
        call_command("setup_demo", stdout=io.StringIO())
    assert not Study.objects.exists()  # no table yet: no demo

    first = use(3)
    call_command("setup_demo", stdout=io.StringIO())
    assert Study.objects.get(slug="demo").source["content_hash"] == first  # the table appeared: rebuilt
    call_command("setup_demo", stdout=io.StringIO())
    assert Study.objects.count() == 1 and Study.objects.get(slug="demo").source["content_hash"] == first

    assign(Study.objects.get(slug="demo"), "prolific", "someone")
    second = use(4)
    assert second != first
    out = io.StringIO()
    call_command("setup_demo", stdout=out)
    study = Study.objects.get(slug="demo")
    assert study.source["content_hash"] == first and study.participants.count() == 1  # kept, data intact
    assert "already has participants" in out.getvalue()


# --- from the output of `python -m teaching teach` ----------------------------------------------
@pytest.mark.slow
def test_create_study_from_the_teach_output(demo_table, demo_teach, staff_client):
    sequences = json.loads((demo_teach / "sequences.json").read_text())
    tests = json.loads((demo_teach / "test_set.json").read_text())
    out = io.StringIO()
    call_command("create_study", str(demo_teach), "--slug", "pilot", "--completion-code", "C1ABCDEF",
                 "--recruitment", "prolific", "--target", "25", stdout=out)
    s = Study.objects.get(slug="pilot")
    pilot = s.source.pop("pilot")
    assert s.source == {"kind": "table", "table": str(demo_table), "content_hash": sequences["table"]["content_hash"],
                        "theta_star": [-64.0, -0.1, -1.0, -0.1, -0.5], "domain": "driving"}
    # the simulated pilot: matrix.json's rows of the study's conditions, shown on its dashboard page
    matrix = json.loads((demo_teach / "matrix.json").read_text())
    rows = dict(zip(matrix["extended_sequence_names"], matrix["extended_matrix"], strict=True))
    assert pilot["conditions"] == list(sequences["conditions"]) and pilot["users"] == matrix["user_names"]
    assert pilot["matrix"] == [rows[n] for n in sequences["conditions"]] and pilot["prior"] == 1 / 200
    # and what learners of each model choose in its tests (matrix.json's, for exactly its conditions)
    assert pilot["predicted"]["theta_star_option"] == [
        [o["is_theta_star"] for o in t["options"]].index(True) for t in tests]
    assert pilot["predicted"]["choice"] == {u: {n: by_name[n] for n in sequences["conditions"]}
                                            for u, by_name in matrix["predicted"]["choice"].items()}
    page = staff_client.get("/dashboard/pilot/").content.decode()
    assert 'id="no-pilot"' not in page and "Ideal users" in page
    assert 'id="predicted-scores"' in page and 'id="no-predicted"' not in page
    assert {c.name: c.env_ids for c in s.conditions.all()} == {
        name: c["env_ids"] for name, c in sequences["conditions"].items()}
    assert [c.name for c in s.conditions.all()] == list(sequences["conditions"])  # in the teach output's order
    assert [t["env_id"] for t in s.test_set] == [t["env_id"] for t in tests]
    assert [[o["theta_index"] for o in t["options"]] for t in s.test_set] == [
        [o["theta_index"] for o in t["options"]] for t in tests]
    assert (s.recruitment, s.completion_code, s.target_per_condition, s.is_open) == ("prolific", "C1ABCDEF", 25, True)
    assert "study pilot: 9 conditions" in out.getvalue()
    # the sequences.json file itself (this was an AttributeError traceback), created closed
    call_command("create_study", str(demo_teach / "sequences.json"), "--slug", "pilot-2", "--closed",
                 stdout=io.StringIO())
    assert not Study.objects.get(slug="pilot-2").is_open


@pytest.mark.slow
def test_teach_output_errors_are_one_line(demo_teach, tmp_path):
    other = tmp_path / "other-table"
    synthetic_table(n_envs=16, n_thetas=8, seed=2).save(other)
    broken = tmp_path / "broken"
    broken.mkdir()
    (broken / "sequences.json").write_text((demo_teach / "sequences.json").read_text())
    (broken / "test_set.json").write_text(json.dumps({"error": "no test environment for cluster 'x'"}))
    cases = [
        ([str(demo_teach)], "needs a slug: give --slug"),
        ([str(demo_teach), "--slug", "bad slug!"], "'slug' may hold only letters"),
        ([str(demo_teach), "--slug", "x", "--table", str(other)], "is not the one the sequences were selected on"),
        ([str(demo_teach), "--slug", "x", "--table", str(tmp_path / "nowhere")], "cannot use the table"),
        ([str(broken), "--slug", "x"], "has no test set: no test environment for cluster 'x'"),
        ([str(tmp_path), "--slug", "x"], "sequences.json is missing"),
    ]
    for args, message in cases:
        with pytest.raises(CommandError) as exc:
            call_command("create_study", *args, stdout=io.StringIO())
        assert message in str(exc.value) and "\n" not in str(exc.value), (args, str(exc.value))
    assert not Study.objects.exists()


TABLE_TESTS = [{"env_id": 0, "options": [{"theta_index": k, "is_theta_star": k == 0} for k in range(4)]}]


@pytest.mark.parametrize("spec, message", [
    ([{"slug": "x"}], "a study spec is a JSON object, not a list"),
    ({"slug": "x", "conditions": {"exact": [1]}}, "non-empty 'conditions' list"),
    ({"slug": "x", "conditions": ["exact"]}, "condition 0 must be an object"),
    ({"slug": "x", "conditions": [{"name": "a", "env_ids": ["12"]}]}, "'env_ids' must be a list of environment ids"),
    ({"slug": "x", "conditions": [{"name": "a", "env_ids": [1]}], "target_per_condition": "ten"},
     "'target_per_condition' must be a positive whole number"),
    ({"slug": "x", "conditions": [{"name": "a", "env_ids": [1]}], "name": 5}, "'name' must be a string"),
    ({"slug": "x", "conditions": [{"name": "a", "env_ids": [1]}], "test_set": [{"env_id": 3}]},
     "test 0 must be an object with an 'env_id' and 'options'"),
    ({"slug": "x", "conditions": [{"name": "a", "env_ids": [1]}], "test_set": {"env_id": 3}},
     "'test_set' must be a list"),
])
def test_every_malformed_spec_is_a_one_line_error(tmp_path, spec, message):
    with pytest.raises(CommandError) as exc:
        call_command("create_study", str(write(tmp_path, spec)), stdout=io.StringIO())
    assert message in str(exc.value) and "\n" not in str(exc.value)
    assert not Study.objects.exists()


def test_table_backed_test_options_are_checked(tmp_path):
    table = synthetic_table(n_envs=16, n_thetas=8, seed=2)
    table.save(tmp_path / "table")
    ids = [int(e) for e in table.env_ids]
    base = {"slug": "t", "table": str(tmp_path / "table"), "conditions": [{"name": "exact", "env_ids": ids[:2]}]}
    star_lie = [{"env_id": ids[5], "options": [{"theta_index": k, "is_theta_star": k == 1} for k in range(4)]}]
    out_of_range = [{"env_id": ids[5], "options": [{"theta_index": k, "is_theta_star": k == 0} for k in (0, 1, 2, 8)]}]
    negative = [{"env_id": ids[5], "options": [{"theta_index": k, "is_theta_star": k == 0} for k in (0, 1, 2, -1)]}]
    for tests, message in ((star_lie, "but theta* is theta 0"), (out_of_range, "theta index 8 is not in the table"),
                           (negative, "theta index -1 is not in the table")):
        with pytest.raises(CommandError, match=re.escape(message)):
            call_command("create_study", str(write(tmp_path, dict(base, test_set=tests))), stdout=io.StringIO())
    assert not Study.objects.exists()


def test_a_table_built_for_another_theta_star_is_refused(tmp_path):
    table = synthetic_table(n_envs=16, n_thetas=8, seed=2)
    table.save(tmp_path / "table")
    ids = [int(e) for e in table.env_ids]
    tests = [{"env_id": ids[10], "options": [{"theta_index": k, "is_theta_star": k == 0} for k in range(4)]}]
    spec = {"slug": "star", "table": str(tmp_path / "table"), "test_set": tests,
            "conditions": [{"name": "exact", "env_ids": ids[:3]}], "theta_star": [-32, -0.2, -1, -0.1, -0.5]}
    with pytest.raises(CommandError, match=re.escape("was built for theta* = [-64.0, -0.1, -1.0, -0.1, -0.5], "
                                                     "not the study's theta* = [-32.0, -0.2, -1.0, -0.1, -0.5]")):
        call_command("create_study", str(write(tmp_path, spec)), stdout=io.StringIO())
    assert not Study.objects.exists()
    spec["theta_star"] = [float(v) for v in table.thetas[0]]  # the table's own θ*: accepted, and recorded
    call_command("create_study", str(write(tmp_path, spec)), stdout=io.StringIO())
    assert Study.objects.get(slug="star").source["theta_star"] == spec["theta_star"]


def test_a_study_with_participants_cannot_change_its_design(study, complete):
    """One set of rules for every way of making a study (studyapp/researcher/studies.py): once anyone has
    started, no condition, test set or replacement may change what they see."""
    training, tests = study.conditions.first().training, study.test_set
    assignment.assign(study, "prolific", "first-one")
    with pytest.raises(SpecError, match="already has participants: its design can no longer change"):
        freeze_condition(study.conditions.first(), training)
    with pytest.raises(SpecError, match="already has participants: its design can no longer change"):
        freeze_test_set(study, tests)
    with pytest.raises(SpecError, match="already has participants; refusing to replace it"):
        new_study(check_job({"slug": study.slug, "conditions": ["exact"]}), source={}, replace=True)
    study.refresh_from_db()
    assert study.test_set == tests and study.conditions.first().training == training


def test_freezing_checks_the_design(db, tiny_table):
    table = TrajectoryTable.load(tiny_table)
    s = new_study(check_job({"slug": "d1", "hand_picked": {"a": [500], "b": [1149]}}), source={"kind": "table"})
    assert not s.is_open and [c.name for c in s.conditions.all()] == ["a", "b"]
    with pytest.raises(SpecError, match="exists; pass --replace"):
        new_study(check_job({"slug": "d1", "hand_picked": {"a": [500]}}), source={})
    with pytest.raises(TypeError, match="takes a CheckedStudy"):  # a design no check has seen
        new_study({"slug": "d2", "conditions": ["a", "a"]}, source={})
    a, b = s.conditions.all()
    with pytest.raises(SpecError, match="needs at least one training example"):
        freeze_condition(a, [])
    freeze_condition(a, tj.training_from_table(table, [500, 586]))
    tests = tj.test_set_from_table(table, select_test_set(table, [[500, 586, 1149]], 0, **TINY_TEST_SET))
    with pytest.raises(SpecError, match="conditions without a training sequence: b"):
        freeze_test_set(s, tests)
    freeze_condition(b, tj.training_from_table(table, [1149]))
    overlapping = [dict(tests[0], env_id=1149)] + tests[1:]
    with pytest.raises(SpecError, match=r"test environments \[1149\] also appear in a training sequence"):
        freeze_test_set(s, overlapping)
    freeze_test_set(s, tests)
    s.refresh_from_db()
    assert s.is_open and len(s.test_set) == len(tests)


def test_a_study_whose_trajectories_come_from_no_table_cannot_open(study):
    """A study stored by an early version with synthesised placeholder trajectories stays closed."""
    study.is_open = False
    study.source = {"kind": "placeholder"}
    study.save()
    with pytest.raises(SpecError, match="do not come from a trajectory table"):
        freeze_test_set(study, study.test_set)
    assert not Study.objects.get(pk=study.pk).is_open
