"""Task logic and idempotency with an in-process worker (celery.contrib.testing).

The worker runs in a thread of the test process (solo pool, memory transport,
in-memory result store), so it shares the test database: these tests use
transactional_db so the worker's writes are visible.
"""
from __future__ import annotations

import collections
import io
import json
import os
import re
import sqlite3
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from datetime import datetime, timedelta
from pathlib import Path

import pytest
from django.core.management import CommandError, call_command
from django.utils import timezone

from precompute import jobs, work
from precompute.management.commands.precompute_table import resolve_preset
from precompute.models import Job
from precompute.tasks import table_chunk
from teaching.api import code_fingerprint
from teaching.core.domain import get_domain
from tests.services import blackhole

pytestmark = pytest.mark.slow


def stored_counts(out) -> collections.Counter:
    return collections.Counter(e["key"] for e in work.read_journal(out) if e["event"] == "stored")


def test_canvas_build_is_bit_identical_and_reruns_compute_nothing(
        inprocess_worker, transactional_db, small_preset, reference, tmp_path, assert_same_table):
    out = tmp_path / "table"
    job = jobs.wait(jobs.create_table_job(small_preset, out), progress=False, timeout=180)
    assert job.status == Job.SUCCEEDED, job.error
    assert (job.chunks_done, job.chunks_total, job.chunks_computed) == (4, 4, 4)
    assert job.trajectories_computed == small_preset.n_envs * small_preset.n_thetas
    assert job.parts.filter(computed=True).count() == 4
    assert job.result["content_hash"] == json.loads((out / "meta.json").read_text())["content_hash"]
    assert_same_table(out, reference)
    first = stored_counts(out)
    assert len(first) == 4 and set(first.values()) == {1}

    # Re-run: every chunk is found stored, nothing is computed, same table.
    job = jobs.wait(jobs.retry(job), progress=False, timeout=180)
    assert job.status == Job.SUCCEEDED and job.attempts == 2
    assert job.chunks_computed == 0 and job.trajectories_computed == 0
    assert stored_counts(out) == first
    assert_same_table(out, reference)

    # One chunk lost: only that one is computed again.
    lost = next(iter(first))
    work.chunk_path(out, lost).unlink()
    job.parts.filter(key=lost).delete()
    job = jobs.wait(jobs.retry(job), progress=False, timeout=180)
    assert job.status == Job.SUCCEEDED and job.chunks_computed == 1
    assert stored_counts(out)[lost] == 2 and sum(stored_counts(out).values()) == 5
    assert_same_table(out, reference)


def test_redelivered_chunk_task_skips_and_counts_once(transactional_db, small_preset, tmp_path):
    """A task delivered twice (e.g. acks_late after a lost connection) computes once and counts once."""
    out = tmp_path / "table"
    spec = work.table_spec(small_preset, out)
    job = Job.objects.create(kind=Job.TABLE, params={"preset": spec["preset"], "out": spec["out"]},
                             chunks_total=spec["n_chunks"])
    ids = work.chunk_ids(spec)[1]
    # a temporary file from a worker killed while writing is ignored
    (out / "chunks").mkdir(parents=True)
    stray = out / "chunks" / ".deadbeef.otherhost.1.x.tmp.npz"
    stray.write_bytes(b"half a chunk")
    first = table_chunk.apply(args=(job.pk, spec, 1, ids)).get()
    second = table_chunk.apply(args=(job.pk, spec, 1, ids)).get()
    assert first["computed"] and not second["computed"] and first["key"] == second["key"]
    job.refresh_from_db()
    assert job.chunks_done == 1 and job.chunks_computed == 1 and job.parts.count() == 1
    assert [e["event"] for e in work.read_journal(out)] == ["start", "stored", "skipped"]
    stored = sorted(p.name for p in (out / "chunks").glob("*.npz") if not p.name.startswith("."))
    assert stored == [f"{first['key']}.npz"]


def test_worker_with_other_identity_refuses(small_preset, tmp_path):
    spec = work.table_spec(small_preset, tmp_path / "t")
    spec["identity"] = dict(spec["identity"], world="another-world")
    with pytest.raises(work.ChunkError, match="another table identity"):
        work.compute_chunk(spec, work.chunk_ids(spec)[0])
    with pytest.raises(work.ChunkError, match="not stored"):
        work.publish(work.table_spec(small_preset, tmp_path / "t"))


def test_failure_is_shown_and_retried_from_the_dashboard(
        inprocess_worker, transactional_db, small_preset, tmp_path, monkeypatch, client, django_user_model,
        reference, assert_same_table):
    calls = {"n": 0}
    domain = get_domain(small_preset.domain)
    real = domain.plan_chunk  # the planner as the chunk builder calls it

    def flaky(env_ids, *args, **kwargs):
        calls["n"] += 1
        if calls["n"] == 2:
            raise FloatingPointError(f"planner diverged in environment {int(env_ids[0])}")
        return real(env_ids, *args, **kwargs)

    monkeypatch.setattr(domain, "plan_chunk", flaky)
    out = tmp_path / "table"
    job = jobs.wait(jobs.create_table_job(small_preset, out), progress=False, timeout=180)
    assert job.status == Job.FAILED
    assert re.fullmatch(r"chunk \d \(environments \d+\.\.\d+\): FloatingPointError: planner diverged in "
                        r"environment \d+", job.error), job.error
    assert "Traceback" in job.error_detail
    monkeypatch.setattr(domain, "plan_chunk", real)

    # the job page shows the error; retry is staff-only and POST-only
    url = job.get_absolute_url()
    assert client.get(url).status_code == 302  # to the admin login
    assert client.post(f"/precompute/jobs/{job.pk}/retry/").status_code == 302
    job.refresh_from_db()
    assert job.attempts == 1
    staff = django_user_model.objects.create_user("staff", password="pw-staff-123", is_staff=True)
    client.force_login(staff)
    page = client.get(url).content.decode()
    assert "FloatingPointError: planner diverged" in page and "Retry" in page
    assert client.get(f"/precompute/jobs/{job.pk}/retry/").status_code == 405
    status = client.get(f"/precompute/jobs/{job.pk}/status.json").json()
    assert status["status"] == "failed" and status["chunks_total"] == 4

    response = client.post(f"/precompute/jobs/{job.pk}/retry/")
    assert response.status_code == 302 and response["Location"] == url
    job = jobs.wait(job, progress=False, timeout=180)
    assert job.status == Job.SUCCEEDED and job.attempts == 2 and job.error == ""
    assert job.chunks_done == 4
    assert_same_table(out, reference)
    assert stored_counts(out).most_common(1)[0][1] == 1
    page = client.get(url).content.decode()
    assert "succeeded" in page and 'http-equiv="refresh"' not in page
    assert "Job" in client.get("/precompute/").content.decode()


def test_running_job_page_refreshes_itself(db, client, django_user_model, small_preset, tmp_path):
    spec = work.table_spec(small_preset, tmp_path)
    job = Job.objects.create(kind=Job.TABLE, params={"preset": spec["preset"], "out": spec["out"]},
                             chunks_total=4, chunks_done=1, status=Job.RUNNING)
    client.force_login(django_user_model.objects.create_user("s", password="pw-staff-123", is_staff=True))
    page = client.get(job.get_absolute_url()).content.decode()
    assert 'http-equiv="refresh"' in page and "1 / 4" in page and "Relaunch (if stalled)" in page
    assert "job-stalled" not in page  # it was launched just now

    Job.objects.filter(pk=job.pk).update(started_at=timezone.now() - timedelta(minutes=12))
    page = client.get(job.get_absolute_url()).content.decode()
    assert "No chunk has finished for 12 minutes" in page
    assert client.get(f"/precompute/jobs/{job.pk}/status.json").json()["stalled_minutes"] == 12


def test_command_waits_with_a_progress_bar(inprocess_worker, transactional_db, tmp_path):
    out, err = io.StringIO(), io.StringIO()
    call_command("precompute_table", "--preset", "tiny", "--envs", "8", "--thetas", "8", "--chunk-size", "4",
                 "--out", str(tmp_path / "t"), "--wait", "--timeout", "180", stdout=out, stderr=err)
    assert "table published at" in out.getvalue() and "2 chunks computed" in out.getvalue()
    bar = err.getvalue()
    assert "2/2 chunks" in bar and "traj/s" in bar and "table tiny-8x8-log-uniform-s0" in bar


@pytest.mark.parametrize("argv, message", [
    (["--preset", "huge"], "unknown preset 'huge'; choose one of tiny, demo, paper"),
    (["--preset", "tiny", "--envs", "2"], "the number of environments must lie in [4, 21,216] (driving)"),
    (["--preset", "gridworld-tiny", "--envs", "20000"],
     "the number of environments must lie in [4, 17,460] (gridworld)"),
    (["--preset", "tiny", "--thetas", "1"], "the number of thetas must be at least 2"),
    (["--preset", "tiny", "--chunk-size", "0"], "--chunk-size must be positive"),
    (["--preset", "tiny", "--chunk-size", "x"], "--chunk-size must be a whole number"),
    (["--preset", "tiny", "--sampler", "gauss"], "unknown sampler 'gauss'"),
])
def test_command_rejects_bad_arguments(db, argv, message):
    with pytest.raises(CommandError) as info:
        call_command("precompute_table", *argv)
    assert message in str(info.value)
    assert not Job.objects.exists()


def test_command_rejects_an_unwritable_output(db, tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("not a directory")
    with pytest.raises(CommandError, match="cannot write to"):
        call_command("precompute_table", "--preset", "tiny", "--out", str(blocker / "t"))
    assert not Job.objects.exists()


def test_worker_with_other_planner_code_refuses(small_preset, tmp_path):
    spec = dict(work.table_spec(small_preset, tmp_path / "t"), code="0123456789abcdef")
    with pytest.raises(work.ChunkError, match="runs other planner code"):
        work.compute_chunk(spec, work.chunk_ids(spec)[0])


def test_the_code_fingerprint_is_the_core_and_the_domain(small_preset, tmp_path):
    assert work.table_spec(small_preset, tmp_path / "t")["code"] == code_fingerprint(small_preset.domain)


def test_concurrent_publishers_do_not_interleave(small_preset, reference, tmp_path, assert_same_table):
    spec = work.table_spec(small_preset, tmp_path / "t")
    for ids in work.chunk_ids(spec):
        work.compute_chunk(spec, ids)
    with ThreadPoolExecutor(2) as pool:
        infos = list(pool.map(lambda _: work.publish(spec), range(2)))
    assert sorted(i["already_published"] for i in infos) == [False, True]
    assert infos[0]["content_hash"] == infos[1]["content_hash"]
    assert_same_table(tmp_path / "t", reference)
    assert [e["event"] for e in work.read_journal(tmp_path / "t")][-2:] == ["published", "verified"]


def test_unreachable_broker_is_a_clear_error(db, tmp_path, celery_app_with):
    celery_app_with(broker_url="redis://127.0.0.1:1/0", broker_transport_options={})
    with pytest.raises(CommandError, match=r"cannot send job \d+ to the broker at redis://127.0.0.1:1/0"):
        call_command("precompute_table", "--preset", "tiny", "--out", str(tmp_path / "t"))
    job = Job.objects.get()
    assert job.status == Job.FAILED and "Connection refused" in job.error


def test_a_hung_broker_fails_the_launch(tmp_path):
    """Redis accepts and never answers: `precompute_table` (production broker settings, in its own
    process) gives up by its broker timeouts with a one-line message and leaves a failed job, not a
    pending one.  How soon is printed, not asserted (a loaded machine stretches the process's own
    start-up); a launch that waited forever would run into the subprocess's hang guard."""
    root = Path(__file__).resolve().parents[2]
    db = tmp_path / "db.sqlite3"
    env = dict(os.environ, DATABASE_URL=f"sqlite:///{db}", VAR_DIR=str(tmp_path / "var"),
               DJANGO_SETTINGS_MODULE="config.settings")
    subprocess.run([sys.executable, "manage.py", "migrate", "--noinput", "-v", "0"], cwd=root, env=env, check=True,
                   timeout=600)
    with blackhole() as port:
        env["CELERY_BROKER_URL"] = broker = f"redis://127.0.0.1:{port}/0"
        start = time.monotonic()
        out = subprocess.run([sys.executable, "manage.py", "precompute_table", "--preset", "tiny", "--out",
                              str(tmp_path / "t")], cwd=root, env=env, capture_output=True, text=True, timeout=600)
        seconds = time.monotonic() - start
    assert out.returncode != 0
    assert f"cannot send job 1 to the broker at {broker}" in out.stderr and "Traceback" not in out.stderr
    with sqlite3.connect(db) as conn:
        (status, started, finished), = conn.execute("SELECT status, started_at, finished_at FROM precompute_job")
    assert status == "failed" and finished is not None
    waited = (datetime.fromisoformat(finished) - datetime.fromisoformat(started)).total_seconds()
    print(f"precompute_table gave up after {seconds:.1f} s ({waited:.1f} s from the launch): {out.stderr.strip()}")


def test_theta_star_travels_with_the_job_spec(tmp_path):
    """A worker rebuilds the preset from the job's JSON spec: another θ* must survive the trip
    and give another table identity (so its chunks never mix with the default θ*'s)."""
    star = (-32.0, -0.2, -1.0, -0.1, -0.5)
    preset = resolve_preset("tiny", theta_star="-32,-0.2,-1,-0.1,-0.5")
    assert preset.theta_star == star and preset.name.startswith("tiny-48x24-log-uniform-s0-star")
    spec = json.loads(json.dumps(work.table_spec(preset, tmp_path / "t")))
    assert work.preset_of(spec).theta_star == star
    _, thetas, _, identity = work._context(spec)
    assert tuple(thetas[0]) == star
    default = work.table_spec(resolve_preset("tiny"), tmp_path / "d")["identity"]
    assert identity["thetas_sha"] != default["thetas_sha"]
    with pytest.raises(CommandError, match="theta\\*: every weight of theta\\* must be a negative number"):
        resolve_preset("tiny", theta_star="-1,-1,-1,-1,1")
