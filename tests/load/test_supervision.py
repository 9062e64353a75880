"""scripts/serve.sh under supervisord: a killed Celery worker never takes the participant site
down, comes back on its own, and its job resumes at once; a killed web
server comes back without touching the worker.

Participants go through the whole study (tests/load/client.py) while a table job runs on the
server's own worker; the worker's process group is SIGKILLed in the middle of a chunk (as the
out-of-memory killer would).  No participant request may fail: not one 5xx, not one refused
connection, every acknowledged answer stored once.
"""
from __future__ import annotations

import asyncio
import os
import re
import signal
import subprocess
import sys
import time

import psycopg
import pytest

from precompute import work
from tests.load import client, harness, run
from tests.services import wait_until

pytestmark = [pytest.mark.slow, pytest.mark.postgres, pytest.mark.redis]

def program_pid(server: harness.Server, name: str) -> int:
    """The pid supervisord reports for one of its programs (0 while it is not running)."""
    env = dict(server.env, SERVE_ROOT=str(harness.ROOT))
    out = subprocess.run([str(harness.ROOT / ".venv/bin/supervisorctl"), "-c", "config/supervisord.conf", "pid", name],
                         cwd=harness.ROOT, env=env, capture_output=True, text=True, timeout=30)
    return int(out.stdout.strip()) if out.stdout.strip().isdigit() else 0


def start_table_job(server: harness.Server, out) -> int:
    """A small table job on the server's worker: 4 chunks of ~1 s each, long enough to kill one."""
    text = server._run([sys.executable, "manage.py", "precompute_table", "--preset", "tiny", "--envs", "64",
                        "--thetas", "128", "--chunk-size", "16", "--out", str(out)])
    return int(re.search(r"job (\d+):", text).group(1))


def job_status(server: harness.Server, job_id: int) -> str:
    with psycopg.connect(server.db_url.replace("postgres://", "postgresql://", 1)) as conn:
        return conn.execute("SELECT status FROM precompute_job WHERE id = %s", [job_id]).fetchone()[0]


def test_a_killed_worker_comes_back_and_its_job_resumes_while_participants_carry_on(tmp_path, shared_server):
    events: dict = {}
    server = shared_server  # tests/load/conftest.py: what this test reads of its logs is what came after `since`
    since = server.mark()
    web_pid, worker_pid = program_pid(server, "web"), program_pid(server, "worker")
    assert web_pid and worker_pid
    out = tmp_path / "table"

    def kill_worker_mid_chunk():
        # The worker is stopped while the job is launched: the launch is a subprocess that, on a
        # busy machine, can take longer to start and exit than the job's four chunks take to
        # run, and the kill below must find a chunk in progress.
        os.killpg(worker_pid, signal.SIGSTOP)
        try:
            job_id = start_table_job(server, out)
        finally:
            os.killpg(worker_pid, signal.SIGCONT)

        def mid_chunk():
            log = work.read_journal(out)
            stored = {e["key"] for e in log if e["event"] == "stored"}
            started = [e for e in log if e["event"] == "start" and e["key"] not in stored]
            assert started or not any(e["event"] == "published" for e in log), \
                "the job finished before a chunk was seen in progress"
            return started

        victim = wait_until(mid_chunk, 900, "the worker starting a chunk", poll=0.01)[-1]
        readies = server.log_since(since).count(" ready.")
        os.killpg(worker_pid, signal.SIGKILL)  # main process and pool child, as the OOM killer would
        killed = time.monotonic()
        wait_until(lambda: program_pid(server, "worker") not in (0, worker_pid), 300, "a new worker process")
        wait_until(lambda: server.log_since(since).count(" ready.") > readies, 300, "the new worker ready")
        events.update(job_id=job_id, victim=victim, back_s=time.monotonic() - killed)
        wait_until(lambda: job_status(server, job_id) in ("succeeded", "failed"), 900, "the job finishing", 0.2)
        events["resumed_s"] = time.monotonic() - killed

    async def fault(stats):
        await asyncio.sleep(3)
        await asyncio.to_thread(kill_worker_mid_chunk)

    cfg = client.Config(base_url=server.base_url, slug=server.study[0], participants=40, window=15, pace=0.03,
                        run_id=f"supervision{os.getpid()}")
    stats = client.Stats()
    asyncio.run(client.run_participants(cfg, stats, fault))
    result = run.summarise(stats, harness.check_database(server.db_url, cfg.slug, stats))
    statuses = server.server_statuses(since)
    new_worker = program_pid(server, "worker")
    log = server.log_since(since)

    # participants: not one failed request while the worker was killed and came back
    db = result["db"]
    nginx_errors = [line for line in log.splitlines() if "[error]" in line or "[crit]" in line][-10:]
    assert not result["failed"] and not result["errors"], (result["failed"], result["errors"], nginx_errors)
    assert not [s for s in statuses if s.startswith("5")], statuses
    assert db["answers_stored"] == db["answers_acked"] > 40 * 10 and not db["lost"] and not db["duplicated"]
    assert db["completed"] == 40

    # the worker: back on its own (a new process that said "ready."); the web server untouched.
    # How soon is printed here and measured by bench/latency.py.
    print(f"worker back in {events['back_s']:.1f} s, job finished {events['resumed_s']:.1f} s after the kill")
    assert program_pid(server, "web") == web_pid

    # its job: resumed at once (the message put back, not left for the one-hour visibility timeout)
    assert job_status(server, events["job_id"]) == "succeeded", log[-3000:]
    assert "put back 1 task(s) left by a worker that died" in log
    redone = [e for e in work.read_journal(out) if e["event"] == "stored" and e["key"] == events["victim"]["key"]]
    assert len(redone) == 1 and redone[0]["host"] != events["victim"]["host"]

    # and the other way round: a killed web server comes back without touching the worker
    os.killpg(web_pid, signal.SIGKILL)
    wait_until(lambda: program_pid(server, "web") not in (0, web_pid), 300, "a new web server process")
    wait_until(lambda: _serves(server), 300, "the web server serving again", poll=0.2)
    assert program_pid(server, "worker") == new_worker


def _serves(server: harness.Server) -> bool:
    try:
        with harness.NO_PROXY.open(server.base_url + "/", timeout=5) as r:
            return r.status == 200
    except OSError:
        return False
