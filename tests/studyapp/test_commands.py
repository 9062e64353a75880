"""Management commands: create_study from a JSON spec, setup_demo (idempotent, prints the links)."""
import io
import json

import pytest
from django.contrib.auth import get_user_model
from django.core.management import call_command
from django.core.management.base import CommandError

from studyapp.models import Condition, Participant, Study

pytestmark = pytest.mark.django_db


def write(tmp_path, spec):
    path = tmp_path / "spec.json"
    path.write_text(json.dumps(spec))
    return path


SPEC = {"slug": "cmd", "name": "From a spec", "target_per_condition": 12,
        "conditions": [{"name": "exact", "env_ids": [100, 200]}, {"name": "random", "env_ids": [300, 400, 500]}]}


def test_create_study_from_spec(tmp_path):
    out = io.StringIO()
    call_command("create_study", str(write(tmp_path, SPEC)), stdout=out)
    s = Study.objects.get(slug="cmd")
    assert s.target_per_condition == 12 and s.source["kind"] == "placeholder"
    assert [c.name for c in s.conditions.all()] == ["exact", "random"]
    assert s.conditions.get(name="random").env_ids == [300, 400, 500]
    assert len(s.test_set) == 6 and "/s/cmd/" in out.getvalue()
    training_ids = {100, 200, 300, 400, 500}
    assert not training_ids & {t["env_id"] for t in s.test_set}  # tests disjoint from training


def test_create_study_is_idempotent_and_replace_is_guarded(tmp_path):
    path = write(tmp_path, SPEC)
    call_command("create_study", str(path), stdout=io.StringIO())
    call_command("create_study", str(path), stdout=io.StringIO())
    assert Study.objects.count() == 1 and Condition.objects.count() == 2
    changed = dict(SPEC, conditions=[{"name": "only", "env_ids": [7]}])
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
    ({"slug": "x", "conditions": [{"name": "a", "env_ids": [99999999]}]}, "environment ids"),
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


def test_setup_demo_is_idempotent_and_prints_links(tmp_path, monkeypatch):
    monkeypatch.setenv("DEMO_TABLE", str(tmp_path / "no-table"))
    out = io.StringIO()
    call_command("setup_demo", stdout=out)
    call_command("setup_demo", stdout=io.StringIO())
    text = out.getvalue()
    s = Study.objects.get(slug="demo")
    names = {c.name for c in s.conditions.all()}
    assert len(names) == 9 and {"exact", "random", "coverage-approx*", "coverage-random"} <= names
    assert "http://127.0.0.1:8000/s/demo/" in text and "/dashboard/demo/" in text
    assert "researcher / demo-password" in text and "PLACEHOLDER" in text
    user = get_user_model().objects.get(username="researcher")
    assert user.is_staff and user.check_password("demo-password")
    assert get_user_model().objects.count() == 1 and Study.objects.count() == 1


def test_create_study_from_a_saved_table(tmp_path):
    from teaching.synthetic import synthetic_table

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
    """With a table, the demo's conditions and tests come from teaching.selection / teaching.testset."""
    import teaching.selection
    import teaching.testset
    from teaching.synthetic import synthetic_table

    table = synthetic_table(n_envs=16, n_thetas=8, seed=3)
    table.save(tmp_path / "table")
    ids = [int(e) for e in table.env_ids]
    calls = {}

    def build_sequences(t, seed):
        calls["sequences"] = (t.meta["content_hash"], seed)
        return {"exact": ids[:2], "det-euclidean": ids[2:5]}

    def select_test_set(t, training, seed):
        calls["tests"] = training
        return [{"env_id": e, "options": [{"theta_index": k, "is_theta_star": k == 0} for k in (2, 0, 1, 3)]}
                for e in ids[8:14]]

    monkeypatch.setattr(teaching.selection, "build_sequences", build_sequences)
    monkeypatch.setattr(teaching.testset, "select_test_set", select_test_set)
    out = io.StringIO()
    call_command("setup_demo", "--table", str(tmp_path / "table"), stdout=out)
    s = Study.objects.get(slug="demo")
    assert s.source == {"kind": "table", "table": str(tmp_path / "table"), "content_hash": table.meta["content_hash"]}
    assert calls == {"sequences": (table.meta["content_hash"], 0), "tests": [ids[:2], ids[2:5]]}
    assert {c.name: c.env_ids for c in s.conditions.all()} == {"exact": ids[:2], "det-euclidean": ids[2:5]}
    assert [o["is_theta_star"] for o in s.test_set[0]["options"]] == [False, True, False, False]
    assert "trajectories: table" in out.getvalue() and "PLACEHOLDER" not in out.getvalue()


def test_setup_demo_rebuilds_after_the_table_changes_but_never_under_participants(tmp_path, monkeypatch):
    """A rebuilt demo table must not leave the demo serving stale trajectories, unless people have taken part."""
    import teaching.selection
    import teaching.testset
    from studyapp.assignment import assign
    from teaching.synthetic import synthetic_table

    def use(seed):
        table = synthetic_table(n_envs=16, n_thetas=8, seed=seed)
        table.save(tmp_path / "table")
        ids = [int(e) for e in table.env_ids]
        monkeypatch.setattr(teaching.selection, "build_sequences", lambda t, s: {"exact": ids[:2]})
        monkeypatch.setattr(teaching.testset, "select_test_set", lambda t, tr, s: [
            {"env_id": e, "options": [{"theta_index": k, "is_theta_star": k == 0} for k in range(4)]}
            for e in ids[8:14]])
        return table.meta["content_hash"]

    monkeypatch.setenv("DEMO_TABLE", str(tmp_path / "table"))
    call_command("setup_demo", stdout=io.StringIO())
    assert Study.objects.get(slug="demo").source["kind"] == "placeholder"  # no table yet

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
