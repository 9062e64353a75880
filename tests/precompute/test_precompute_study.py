"""Study jobs: one task per condition, then the test set, with an in-process worker."""
from __future__ import annotations

import io

import pytest
from django.core.management import CommandError, call_command

import teaching.core.table
from precompute import jobs
from precompute.models import Job
from precompute.sequences import condition_sequence
from precompute.study import create_study_job
from precompute.tasks import study_condition, study_finish
from studyapp.models import Study
from studyapp.researcher.specschema import check_job
from teaching.core.conditions import build_sequences, teach
from teaching.core.selection import ALL_CONDITIONS, CONDITIONS
from teaching.core.showtests import select_show_tests
from teaching.core.table import TableError, TrajectoryTable
from teaching.core.testset import select_test_set
from teaching.domains.driving.synthetic import synthetic_table
from tests.precompute.refusals import assert_refused_in_one_line
from tests.teaching.domains.worlds.shipped import shipped, tiny_table


@pytest.fixture(scope="module")
def table_path(tmp_path_factory):
    """A saved synthetic table (300 environments × 80 thetas): every condition and a test set exist."""
    path = tmp_path_factory.mktemp("synthetic")
    synthetic_table(300, 80, n_candidates=6, seed=4).save(path)
    return path


@pytest.fixture(scope="module")
def expected(table_path):
    table = TrajectoryTable.load(table_path)
    seqs = build_sequences(table, seed=0)
    return seqs, select_test_set(table, list(seqs.values()), seed=0)


@pytest.mark.parametrize("hyper", [{}, {"det-euclidean": 0.1, "prob-reward": 10.0}])
def test_each_condition_alone_equals_the_whole_teaching_run(table_path, hyper):
    table = TrajectoryTable.load(table_path)
    whole = build_sequences(table, seed=7, hyperparameters=hyper)
    for name in CONDITIONS:
        one = condition_sequence(table, name, seed=7, hyperparameters=hyper)
        assert one["env_ids"] == whole[name], name
        assert len(one["p"]) == len(one["env_ids"])
    assert condition_sequence(table, "det-euclidean", hyperparameters=hyper)["value"] == hyper.get(
        "det-euclidean", condition_sequence(table, "det-euclidean")["value"])


@pytest.mark.slow
def test_build_study_command_stores_sequences_on_the_conditions(
        inprocess_worker, transactional_db, table_path, expected):
    seqs, tests = expected
    out, err = io.StringIO(), io.StringIO()
    call_command("build_study", "--table", str(table_path), "--slug", "syn", "--name", "Synthetic",
                 "--wait", "--timeout", "180", stdout=out, stderr=err)
    study = Study.objects.get(slug="syn")
    assert study.is_open and study.name == "Synthetic"
    assert [c.name for c in study.conditions.all()] == list(CONDITIONS)
    for c in study.conditions.all():
        assert c.env_ids == seqs[c.name], c.name
        assert all(len(env["robot"]) == len(env["other"]) > 2 for env in c.training)
    assert [t["env_id"] for t in study.test_set] == [t["env_id"] for t in tests]
    job = Job.objects.get(kind=Job.STUDY)
    assert job.status == Job.SUCCEEDED and job.chunks_done == job.chunks_total == len(CONDITIONS) + 1
    assert set(job.result["conditions"]) == set(CONDITIONS)
    assert "test set:" in out.getvalue() and f"{len(CONDITIONS) + 1}/{len(CONDITIONS) + 1} parts" in err.getvalue()

    # a retry recomputes no condition: each one is already frozen on its Condition
    before = {p.key: p.finished_at for p in job.parts.all()}
    job = jobs.wait(jobs.retry(job), progress=False, timeout=180)
    assert job.status == Job.SUCCEEDED
    assert {p.key: p.finished_at for p in job.parts.all()} == before
    assert [c.env_ids for c in Study.objects.get(slug="syn").conditions.all()] == [seqs[c] for c in CONDITIONS]


@pytest.mark.slow
def test_build_study_subset_closed(inprocess_worker, transactional_db, table_path, expected):
    call_command("build_study", "--table", str(table_path), "--slug", "two", "--conditions", "exact,random",
                 "--closed", "--wait", "--no-progress", "--timeout", "180", stdout=io.StringIO())
    study = Study.objects.get(slug="two")
    assert not study.is_open and len(study.test_set) == 6
    assert [c.name for c in study.conditions.all()] == ["exact", "random"]


@pytest.mark.slow
def test_a_test_set_only_the_build_finds_impossible_is_said_in_one_line_without_a_traceback(
        inprocess_worker, transactional_db, table_path, staff_client):
    """What the designer cannot know before the conditions are selected (here: a θ*-regret no option has) is
    said on the job page as what to change, not as an exception; the study stays closed and cannot open."""
    job = create_study_job(table_path, check_job({"slug": "unbuildable", "conditions": ["exact"], "is_open": False,
                                                 "test_set_thresholds": {"min_regret": 1e9}}))
    job = jobs.wait(job, progress=False, timeout=180)
    assert_refused_in_one_line(job, staff_client, "unbuildable", "TestSetError", "No test set could be drawn")
    assert job.error.startswith("No test set could be drawn from the environments the conditions do not train on (")
    assert job.error.endswith("Choose another difficulty (the designer counts each level), lower the minimum "
                              "θ*-regret or distance, or fewer conditions, and build again.")


@pytest.mark.slow
def test_a_study_job_of_a_shipped_world_asks_to_show_the_way(inprocess_worker, transactional_db, tmp_path_factory):
    with shipped("taxi") as domain:
        table = tiny_table(tmp_path_factory, domain)
        call_command("build_study", "--table", str(table), "--slug", "taxi-show", "--conditions", "exact,random",
                     "--test-kind", "show", "--closed-loop", "loop:check_every=1,max_examples=3", "--wait",
                     "--no-progress", "--timeout", "180", stdout=io.StringIO())
        study = Study.objects.get(slug="taxi-show")
        want = select_show_tests(TrajectoryTable.load(table), [c.env_ids for c in study.conditions.all()], seed=0)
    assert study.is_open and study.test_kind == Study.SHOW
    assert [(t["env_id"], t["kind"]) for t in study.test_set] == [(t["env_id"], "show") for t in want]
    assert all("options" not in t for t in study.test_set)
    checks = study.conditions.get(name="loop").closed_loop["checks"]  # the closed loop's checks show the way too
    assert checks and all(c["kind"] == "show" and c["ways"] for c in checks)
    assert "predicted" not in study.source["pilot"] and "loop" in study.source["pilot"]["conditions"]


@pytest.mark.parametrize("argv, message", [
    (["--test-kind", "show"], "cannot replay and score a way"),
    (["--test-kind", "guess"], "'guess'"),
])
def test_a_study_job_refuses_show_tests_where_they_cannot_be(db, table_path, argv, message):
    with pytest.raises(CommandError, match=message):
        call_command("build_study", "--table", str(table_path), "--slug", "nope", "--conditions", "exact", *argv,
                     stdout=io.StringIO())


def test_the_hierarchical_condition_is_the_hierarchical_learners_greedy_sequence(table_path):
    """The condition a study may add beside the paper's nine: alone on a worker as in the whole run."""
    table = TrajectoryTable.load(table_path)
    whole = teach(table, seed=7)
    ids = table.env_ids
    one = condition_sequence(table, "hierarchical", seed=7)
    assert one["env_ids"] == [int(ids[e]) for e in whole.sequences["hierarchical"].envs]
    assert one["value"] == whole.models["hierarchical"].value
    assert "hierarchical" in ALL_CONDITIONS and "hierarchical" not in CONDITIONS


@pytest.mark.slow
def test_a_study_with_the_hierarchical_condition(inprocess_worker, transactional_db, table_path):
    call_command("build_study", "--table", str(table_path), "--slug", "hier", "--conditions", "exact,hierarchical",
                 "--wait", "--no-progress", "--timeout", "180", stdout=io.StringIO())
    study = Study.objects.get(slug="hier")
    hier = study.conditions.get(name="hierarchical")
    assert hier.env_ids == condition_sequence(TrajectoryTable.load(table_path), "hierarchical")["env_ids"]
    # the test set keeps clear of what this condition trains on, as of every other condition's
    assert not set(hier.env_ids) & {t["env_id"] for t in study.test_set}


def test_a_study_job_verifies_its_table_once(db, table_path, monkeypatch):
    """create_study_job hashes the table; its tasks only compare the hash it recorded."""
    real, hashed = teaching.core.table.content_hash, []
    monkeypatch.setattr(teaching.core.table, "content_hash", lambda *a: hashed.append(1) or real(*a))
    job = create_study_job(table_path, check_job({"slug": "once", "conditions": ["exact", "random"], "is_open": False}),
                           start=False)
    assert len(hashed) == 1
    assert job.params["content_hash"] == Study.objects.get(slug="once").source["content_hash"]
    for i, name in enumerate(job.params["conditions"]):
        study_condition(job_id=job.pk, spec=job.params, name=name, index=i)
    study_finish(job_id=job.pk, spec=job.params)
    assert len(hashed) == 1  # no task re-read the table's bytes
    assert len(Study.objects.get(slug="once").test_set) == 6


def test_a_study_task_refuses_a_table_other_than_the_verified_one(db, table_path):
    job = create_study_job(table_path, check_job({"slug": "other", "conditions": ["exact"]}), start=False)
    with pytest.raises(TableError, match="is not the one that was verified"):
        study_condition(job_id=job.pk, spec=dict(job.params, content_hash="0" * 64), name="exact", index=0)


@pytest.mark.parametrize("argv, message", [
    (["--table", "/nonexistent/table", "--slug", "x"], "no trajectory table at /nonexistent/table"),
    (["--preset", "nope", "--slug", "x"], "build it first: manage.py precompute_table"),
    (["--slug", "x", "--conditions", "exact,greedy"],
     "condition 'greedy': unknown selector 'greedy'; choose from exact"),
    (["--slug", "x", "--conditions", "exact,highlights:k=0"],
     "condition 'highlights:k=0': selector 'highlights': parameter 'k': must be an integer >= 1, got 0"),
    (["--slug", "x", "--conditions", "scot:k=2"], "condition 'scot:k=2': selector 'scot': unknown parameter 'k'; "
                                                  "it takes no parameters"),
    (["--slug", "x", "--test-difficulty", "hard"], "'test_difficulty' must be one of none, low, medium, high, not "
                                                   "'hard'"),
    (["--slug", "x", "--conditions", "exact,exact"], "a condition is listed twice"),
    (["--slug", "x", "--hyper", "det-euclidean"], "--hyper expects MODEL=VALUE"),
    (["--slug", "x", "--hyper", "det-euclidean=-1"], "must be a finite number > 0"),
    (["--slug", "x", "--hyper", "psychic=1"], "unknown learner model 'psychic'"),
    (["--slug", "x", "--approx-star", "psychic"], "'approx_star' must be one of exact, det-reward"),
    (["--slug", "x", "--target-per-condition", "0"], "'target_per_condition' must be a positive whole number"),
    (["--slug", "bad slug"], "'slug' may hold only letters, digits, - and _"),  # studyapp's rule, one place
])
def test_build_study_rejects_bad_arguments(db, table_path, argv, message, settings, tmp_path):
    settings.TABLES_DIR = tmp_path  # where --preset looks
    if "--table" not in argv and "--preset" not in argv:
        argv = ["--table", str(table_path)] + argv
    with pytest.raises(CommandError) as info:
        call_command("build_study", *argv)
    assert message in str(info.value)
    assert not Job.objects.exists()


def test_build_study_refuses_to_overwrite(db, table_path, make_study):
    make_study(slug="taken")
    with pytest.raises(CommandError, match="exists; pass --replace"):
        call_command("build_study", "--table", str(table_path), "--slug", "taken")
