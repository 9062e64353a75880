"""Typed, versioned job specs: a job stored by older code is relaunched and
completes; a stored spec this code cannot read is refused with a message naming the keys, never
launched as some other job; task arguments travel by keyword."""
from __future__ import annotations

import html

import pytest

from precompute import jobs, work
from precompute.models import Job
from precompute.specs import SPEC_VERSION, SpecFormatError, StudyJobSpec, TableJobSpec, read_spec
from precompute.study import create_study_job
from precompute.tasks import table_chunk, task_arguments
from studyapp.models import Study
from studyapp.researcher.specschema import check_job
from teaching.domains.driving.synthetic import synthetic_table

pytestmark = pytest.mark.slow

# A table job exactly as format version 1 stored it (precompute/jobs.py create_table_job:
# {"preset": ..., "out": ..., "queue": ...}, no version); "out" is filled in per test.
TABLE_V1 = {"preset": {"name": "tiny-8x8-log-uniform-s0", "n_envs": 8, "n_thetas": 8, "sampler": "log-uniform",
                       "seed": 0, "chunk_size": 4, "theta_star": [-64.0, -0.1, -1.0, -0.1, -0.5]},
            "out": None, "queue": None}
# A study job as format version 1 stored it (precompute/study.py create_study_job), with
# "open" where today's format says "open_when_done".
STUDY_V1 = {"study_id": None, "slug": "old-format", "table": None, "content_hash": None, "seed": 0,
            "approx_star": "det-euclidean", "hyperparameters": {}, "conditions": ["exact", "random"],
            "open": False, "queue": None, "hand_picked": {}, "test_set_thresholds": {}}


@pytest.fixture(scope="module")
def synthetic(tmp_path_factory):
    """A saved synthetic table (300 environments × 80 θ): every condition and a test set exist."""
    path = tmp_path_factory.mktemp("synthetic")
    synthetic_table(300, 80, n_candidates=6, seed=4).save(path)
    return path


def test_a_table_job_stored_in_the_previous_format_is_retried_and_completes(inprocess_worker, transactional_db,
                                                                             tmp_path, staff_client):
    out = tmp_path / "table"
    job = Job.objects.create(kind=Job.TABLE, params=dict(TABLE_V1, out=str(out)), chunks_total=2,
                             status=Job.FAILED, error="worker lost")
    r = staff_client.post(f"/precompute/jobs/{job.pk}/retry/")
    assert r.status_code == 302
    job = jobs.wait(job, progress=False, timeout=180)
    assert job.status == Job.SUCCEEDED, job.error
    assert job.result_path == str(out) and (out / "meta.json").exists() and job.chunks_done == 2
    assert job.params == {"version": SPEC_VERSION, **TABLE_V1, "out": str(out)}  # stored back in today's format


def test_a_study_job_stored_in_the_previous_format_is_retried_and_completes(inprocess_worker, transactional_db,
                                                                             synthetic, staff_client):
    job = create_study_job(synthetic, check_job({"slug": "old-format", "conditions": ["exact", "random"]}), start=False)
    study = Study.objects.get(slug="old-format")
    job.params = dict(STUDY_V1, study_id=study.pk, table=str(synthetic))  # as the old code wrote it
    job.save()
    assert staff_client.post(f"/precompute/jobs/{job.pk}/retry/").status_code == 302
    job = jobs.wait(job, progress=False, timeout=180)
    assert job.status == Job.SUCCEEDED, job.error
    study.refresh_from_db()
    assert all(c.training for c in study.conditions.all()) and study.test_set
    assert not study.is_open  # the old "open": False, read as open_when_done
    assert job.params["open_when_done"] is False and "open" not in job.params


@pytest.mark.parametrize("change, message", [
    ({"outdir": "/elsewhere"}, "unknown key(s) outdir"),
    ({"out": None}, "missing key(s) out"),
    ({"version": 9}, "version 9: this code reads versions 1 to"),
    ({"preset": dict(TABLE_V1["preset"], planner="v9")}, "does not fit teaching's Preset"),
])
def test_a_spec_that_cannot_be_read_fails_the_retry_clearly(db, tmp_path, staff_client, change, message):
    params = {k: v for k, v in {**TABLE_V1, "out": str(tmp_path), "version": 2, **change}.items() if v is not None}
    job = Job.objects.create(kind=Job.TABLE, params=params, chunks_total=2)
    r = staff_client.post(f"/precompute/jobs/{job.pk}/retry/", follow=True)
    job.refresh_from_db()
    assert job.status == Job.FAILED and job.error.startswith("stored spec: SpecFormatError") and message in job.error
    assert html.escape(message) in r.content.decode() and not job.canvas_id  # nothing was sent


def test_specs_round_trip_and_refuse_unknown_and_missing_keys():
    spec = StudyJobSpec(study_id=1, slug="s", table="/t", seed=3, approx_star="det-euclidean", conditions=["exact"],
                        open_when_done=False, hand_picked={"mine": [1, 2]})
    assert read_spec("study", spec.to_json()) == spec
    with pytest.raises(SpecFormatError, match=rf"study job spec \(version {SPEC_VERSION}\): unknown key\(s\) opened; "
                                              r"missing key\(s\) slug"):
        read_spec("study", {k: v for k, v in {**spec.to_json(), "opened": True}.items() if k != "slug"})
    assert TableJobSpec.from_json({"preset": {}, "out": "/o"}).queue is None  # the oldest rows had no queue
    with pytest.raises(SpecFormatError, match="unknown kind of job 'movie'"):
        read_spec("movie", {})


# A study job as version 2 stored it (before closed-loop conditions): read with none.
STUDY_V2 = {"version": 2, "study_id": 5, "slug": "v2", "table": "/t", "content_hash": "abc", "seed": 1,
            "approx_star": "det-euclidean", "hyperparameters": {}, "conditions": ["exact"], "hand_picked": {},
            "test_set_thresholds": {}, "open_when_done": True, "queue": None}


def test_a_version_2_study_spec_reads_with_no_closed_loop_condition():
    spec = read_spec("study", STUDY_V2)
    assert spec.closed_loop == {} and spec.conditions == ["exact"] and spec.seed == 1
    assert spec.to_json()["version"] == SPEC_VERSION == 5


# A study job as version 3 stored it (before selectors with parameters and graded tests): each condition
# is its own selector, with approx* for a coverage condition, and the tests are drawn from any environment.
STUDY_V3 = {**STUDY_V2, "version": 3, "conditions": ["exact", "coverage-approx*"], "closed_loop": {},
            "closed_loop_fit": {}}


def test_a_version_3_study_spec_reads_with_each_condition_its_own_selector():
    spec = read_spec("study", STUDY_V3)
    assert spec.selectors == {} and spec.test_difficulty is None and spec.conditions == ["exact", "coverage-approx*"]


# A study job as version 4 stored it (before tests that show the way): its tests choose among options.
STUDY_V4 = {**STUDY_V3, "version": 4, "selectors": {}, "test_difficulty": None}


def test_a_version_4_study_spec_reads_with_tests_that_choose():
    spec = read_spec("study", STUDY_V4)
    assert spec.test_kind == "choose" and spec.test_difficulty is None and spec.conditions == STUDY_V3["conditions"]


def test_task_arguments_travel_by_keyword(tmp_path):
    spec = work.table_spec(jobs.table_preset("tiny", envs=8, thetas=8, chunk_size=4), tmp_path / "t")
    canvas = jobs.table_canvas(7, spec, queue="q")
    assert [(s.args, sorted(s.kwargs)) for s in canvas.tasks] == [((), ["env_ids", "index", "job_id", "spec"])] * 2
    assert canvas.body.args == () and sorted(canvas.body.kwargs) == ["job_id", "spec"]
    by_name = {"job_id": 7, "spec": {}, "index": 2, "env_ids": [4, 5]}
    assert task_arguments(table_chunk, (), by_name) == by_name
    assert task_arguments(table_chunk, (7, {}, 2, [4, 5]), {}) == by_name  # a message queued by older code
