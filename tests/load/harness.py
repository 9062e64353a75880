"""The server side of the load test: a fresh PostgreSQL database, the production server
(scripts/serve.sh: gunicorn + Celery worker) on a free loopback port, a PostgreSQL restart as
the fault, and the database checks against the client's log.

Everything started here is stopped here, whatever happens: the database is dropped, the
server's process groups are ended, and PostgreSQL is waited for until it accepts connections.
"""
from __future__ import annotations

import asyncio
import json
import os
import secrets
import signal
import socket
import subprocess
import sys
import time
import urllib.error
import urllib.request
from collections import Counter
from dataclasses import dataclass
from pathlib import Path
from urllib.parse import urlsplit, urlunsplit

import numpy as np
import psycopg
from psycopg import sql

from tests.services import PG_URL, postgres_reachable

ROOT = Path(__file__).resolve().parents[2]
REDIS_URL = os.environ.get("LOAD_TEST_REDIS", "redis://127.0.0.1:6379/14")
NO_PROXY = urllib.request.build_opener(urllib.request.ProxyHandler({}))  # loopback only, never via a proxy
# gunicorn workers of a server whose test checks behaviour rather than capacity (supervision, slow bodies, slow
# clients, the researcher's browser walk): each worker costs about 3 s of CPU to start and warm, which the
# suite's two cores share with every other test.  The load test keeps the production default (2 x cores + 1).
FEW_WORKERS = 2

BUILD_STUDY = """
import django
django.setup()
from studyapp.researcher.studies import build_study, demo_spec
study = build_study(demo_spec())
print(study.slug, study.conditions.count(), len(study.test_set))
"""


# Prepended to a study script: the fresh database's tables (`manage.py migrate`, in the script's process).
MIGRATE = """
import django
django.setup()
from django.core.management import call_command
call_command("migrate", interactive=False, verbosity=0)
"""


@dataclass(frozen=True)
class Visit:
    """One GET of a page as a visitor sees it: the HTTP status (None when no answer came within the
    timeout or the connection failed) and the seconds it took."""
    status: int | None
    seconds: float

    @property
    def answered(self) -> bool:
        return self.status == 200


def visit(url: str, timeout: float) -> Visit:
    """GET url, reading the whole body, giving up after `timeout` s."""
    start = time.monotonic()
    try:
        with NO_PROXY.open(url, timeout=timeout) as r:
            r.read()
            status = r.status
    except urllib.error.HTTPError as e:
        status = e.code
    except OSError:
        status = None
    return Visit(status, time.monotonic() - start)


def visits_during(url: str, seconds: float, timeout: float, every: float = 0.25) -> list[Visit]:
    """visit(url) every `every` s for `seconds`: what a normal visitor sees meanwhile."""
    visits, end = [], time.monotonic() + seconds
    while time.monotonic() < end:
        visits.append(visit(url, timeout))
        time.sleep(every)
    return visits


def latency_ms(visits: list[Visit]) -> str:
    """p50, p95 and max of the visits' seconds, in ms, for a printed line (never for an assertion)."""
    seconds = np.array([v.seconds for v in visits])
    p50, p95 = np.percentile(seconds, [50, 95], method="nearest")
    return f"p50 {p50 * 1000:.0f} ms, p95 {p95 * 1000:.0f} ms, max {seconds.max() * 1000:.0f} ms"


def with_database(url: str, name: str) -> str:
    parts = urlsplit(url)
    return urlunsplit(parts._replace(path="/" + name))


def connect(url: str, **kwargs):
    return psycopg.connect(url.replace("postgres://", "postgresql://", 1), connect_timeout=5, **kwargs)


def wait_for_postgres(url: str = PG_URL, timeout: float = 90) -> float:
    """Block until PostgreSQL accepts connections; returns the seconds waited."""
    start = time.monotonic()
    while not postgres_reachable(url):
        if time.monotonic() - start > timeout:
            raise RuntimeError(f"PostgreSQL at {url} not back after {timeout:.0f} s")
        time.sleep(0.2)
    return time.monotonic() - start


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


# --- the fault: restarting PostgreSQL ----------------------------------------------------
def local_cluster(url: str = PG_URL) -> tuple[str, str] | None:
    """(version, name) of the Debian cluster serving `url`'s port on this machine, if any."""
    port = str(urlsplit(url.replace("postgres://", "http://", 1)).port or 5432)
    try:
        out = subprocess.run(["pg_lsclusters", "--no-header"], capture_output=True, text=True, timeout=30).stdout
    except (OSError, subprocess.SubprocessError):
        return None
    for line in out.splitlines():
        fields = line.split()
        if len(fields) >= 3 and fields[2] == port:
            return fields[0], fields[1]
    return None


async def restart_postgres(cluster: tuple[str, str], url: str = PG_URL) -> float:
    """Restart the cluster (fast shutdown: open connections are cut, as in a crash-restart)."""
    version, name = cluster
    start = time.monotonic()
    proc = await asyncio.create_subprocess_exec(
        "pg_ctlcluster", "--skip-systemctl-redirect", version, name, "restart", "--", "-m", "fast",
        stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.STDOUT)
    out, _ = await proc.communicate()
    if proc.returncode != 0:
        raise RuntimeError(f"pg_ctlcluster restart failed ({proc.returncode}): {out.decode()[-500:]}")
    await asyncio.to_thread(wait_for_postgres, url)
    return time.monotonic() - start


def ensure_postgres_running(cluster, url: str = PG_URL) -> None:
    """After the run, whatever happened: PostgreSQL is up and accepting connections."""
    if cluster and not postgres_reachable(url):
        subprocess.run(["pg_ctlcluster", "--skip-systemctl-redirect", *cluster, "start"],
                       capture_output=True, timeout=120)
    wait_for_postgres(url)


# --- the server ----------------------------------------------------------------------------
class Server:
    """scripts/serve.sh on a fresh database and a free port; a context manager."""

    def __init__(self, workdir: Path, pg_url: str = PG_URL, redis_url: str = REDIS_URL,
                 workers: int | None = None, threads: int | None = None, demo_table=None,
                 study_script: str = BUILD_STUDY, env: dict | None = None):
        """study_script: Python run after migrate that builds the study and prints its slug, number of
        conditions and tests (default: the demo study); env: more environment for every process."""
        self.workdir = Path(workdir)
        self.workdir.mkdir(parents=True, exist_ok=True)
        self.db_name = f"load_{os.getpid()}_{secrets.token_hex(3)}"
        self.admin_url, self.db_url = pg_url, with_database(pg_url, self.db_name)
        self.port = free_port()
        self.base_url = f"http://127.0.0.1:{self.port}"
        self.log_path = self.workdir / "server.log"
        self.access_log = self.workdir / "access.log"
        self.proc = None
        self.env = {k: v for k, v in os.environ.items() if not k.startswith(("SECURE_", "DJANGO_"))}
        self.env.update(
            DATABASE_URL=self.db_url, CELERY_BROKER_URL=redis_url, CELERY_RESULT_BACKEND="django-db",
            CACHE_URL=redis_url, DEBUG="0", SECRET_KEY=secrets.token_urlsafe(50), ALLOWED_HOSTS="127.0.0.1",
            BIND=f"127.0.0.1:{self.port}", GUNICORN_ACCESS_LOG=str(self.access_log),
            VAR_DIR=str(self.workdir / "var"), PRECOMPUTE_QUEUE=f"load-{self.db_name}",
            DEMO_TABLE=str(demo_table or os.environ.get("DEMO_TABLE") or ROOT / "var/tables/demo"),
            DJANGO_SETTINGS_MODULE="config.settings", PYTHONUNBUFFERED="1", CELERY_LOG_LEVEL="INFO")
        self.env.update(env or {})
        self.study_script = study_script
        self.env.pop("DATABASE_TEST_NAME", None)
        if workers:
            self.env["WEB_CONCURRENCY"] = str(workers)
        self.workers = int(self.env.get("WEB_CONCURRENCY") or 2 * os.cpu_count() + 1)
        if threads:
            self.env["GUNICORN_THREADS"] = str(threads)

    def __enter__(self):
        try:
            self.start()
        except BaseException:
            self.stop()
            raise
        return self

    def __exit__(self, *exc):
        self.stop()

    def _run(self, args, timeout=300):
        out = subprocess.run(args, cwd=ROOT, env=self.env, capture_output=True, text=True, timeout=timeout)
        if out.returncode != 0:
            raise RuntimeError(f"{' '.join(map(str, args))} failed:\n{(out.stdout + out.stderr)[-3000:]}")
        return out.stdout

    def start(self, ready_timeout: float = 900):  # a hang guard: several gunicorn workers warm up, CPU-bound
        with connect(self.admin_url, autocommit=True) as conn:
            conn.execute(sql.SQL("CREATE DATABASE {}").format(sql.Identifier(self.db_name)))
        # migrate and the study in one process: a second Django start-up would cost seconds of CPU
        # (scripts/serve.sh migrates again below, with the system checks, as in production).
        self.study = self._run([sys.executable, "-c", MIGRATE + self.study_script], timeout=1800).split()
        # append mode: supervisord and its programs write to this file through descriptors of their own
        with open(self.log_path, "a") as log:
            self.proc = subprocess.Popen(["bash", "scripts/serve.sh"], cwd=ROOT, env=self.env, stdout=log,
                                         stderr=subprocess.STDOUT, start_new_session=True)
        deadline = time.monotonic() + ready_timeout
        while time.monotonic() < deadline:
            if self.proc.poll() is not None:
                raise RuntimeError(f"serve.sh exited ({self.proc.returncode}):\n{self.log_tail()}")
            # Ready: every gunicorn worker warm (config/gunicorn.conf.py logs it), the Celery worker
            # up (its boot would otherwise eat the first seconds' CPU), and the home page served.
            log = self.log_path.read_text()
            if log.count(" warm in ") >= self.workers and " ready." in log:
                try:
                    with NO_PROXY.open(self.base_url + "/", timeout=5) as r:
                        if r.status == 200:
                            return
                except OSError:
                    pass
            time.sleep(0.3)
        raise RuntimeError(f"server not ready after {ready_timeout:.0f} s:\n{self.log_tail()}")

    def children(self) -> list[int]:
        try:
            out = subprocess.run(["pgrep", "-P", str(self.proc.pid)], capture_output=True, text=True).stdout
            return [int(p) for p in out.split()]
        except (OSError, ValueError):
            return []

    def stop(self, timeout: float = 60):
        """SIGTERM to serve.sh stops gunicorn and the worker gracefully; stragglers are killed."""
        if self.proc is not None:
            children = self.children()
            if self.proc.poll() is None:
                self.proc.send_signal(signal.SIGTERM)
                try:
                    self.proc.wait(timeout)
                except subprocess.TimeoutExpired:
                    self.proc.kill()
                    self.proc.wait(10)
            for pid in children:  # supervisord gives each program its own process group
                try:
                    os.killpg(pid, signal.SIGKILL)
                except (ProcessLookupError, PermissionError):
                    pass
            self.proc = None
        try:
            wait_for_postgres(self.admin_url)
            with connect(self.admin_url, autocommit=True) as conn:
                conn.execute(sql.SQL("DROP DATABASE IF EXISTS {} WITH (FORCE)").format(sql.Identifier(self.db_name)))
        except (psycopg.Error, RuntimeError) as exc:
            print(f"could not drop the load-test database {self.db_name}: {exc}", file=sys.stderr)

    def log_tail(self, n: int = 3000) -> str:
        return self.log_path.read_text()[-n:] if self.log_path.exists() else ""

    def mark(self) -> dict:
        """Where the server's logs end now: log_since and server_statuses(since=...) read only what
        came after it (a server that several tests share)."""
        return {path: path.stat().st_size if path.exists() else 0 for path in (self.log_path, self.access_log)}

    def log_since(self, mark: dict) -> str:
        """The server's log (supervisord, nginx, gunicorn, the worker) written after `mark`."""
        return _read_from(self.log_path, mark[self.log_path])

    def server_statuses(self, since: dict | None = None) -> Counter:
        """Status codes in gunicorn's access log (what the server saw, retries included), since `mark`."""
        counts = Counter()
        if self.access_log.exists():
            for line in _read_from(self.access_log, since[self.access_log] if since else 0).splitlines():
                parts = line.split('"')
                if len(parts) > 2 and parts[2].split():
                    counts[parts[2].split()[0]] += 1
        return counts


def _read_from(path: Path, offset: int) -> str:
    if not path.exists():
        return ""
    with open(path, "rb") as f:
        f.seek(offset)
        return f.read().decode(errors="replace")


# --- checks against the database -------------------------------------------------------------
PAGE_KIND = {"check": "test", "feedback": "training"}


def check_database(db_url: str, slug: str, stats) -> dict:
    """Compare the client's acknowledged answers with the Answer rows; conditions and balance."""
    with connect(db_url) as conn:
        rows = conn.execute(
            "SELECT p.token, a.step, a.kind, a.data FROM studyapp_answer a "
            "JOIN studyapp_participant p ON p.id = a.participant_id JOIN studyapp_study s ON s.id = p.study_id "
            "WHERE s.slug = %s", [slug]).fetchall()
        people = conn.execute(
            "SELECT p.platform_pid, p.token, c.name, p.completion_code, p.completed_at IS NOT NULL "
            "FROM studyapp_participant p JOIN studyapp_condition c ON c.id = p.condition_id "
            "JOIN studyapp_study s ON s.id = p.study_id WHERE s.slug = %s", [slug]).fetchall()
        conditions = [r[0] for r in conn.execute(
            "SELECT c.name FROM studyapp_condition c JOIN studyapp_study s ON s.id = c.study_id "
            "WHERE s.slug = %s", [slug]).fetchall()]
    stored = Counter((token, step) for token, step, _, _ in rows)
    data = {(token, step): (kind, d if isinstance(d, dict) else json.loads(d)) for token, step, kind, d in rows}
    acked = Counter((token, step) for token, step, _, _ in stats.acked)
    # The client reads a step's kind off its page, where a closed loop's check question is a test page
    # and its feedback a training page.
    data = {k: (PAGE_KIND.get(kind, kind), d) for k, (kind, d) in data.items()}
    mismatched = []
    for kind, d in data.values():
        if kind == "test":  # what the participant saw: option letters in their display order
            d["shown_choice"] = "ABCDEFGH"[d["order"].index(d["choice"])]
            d["shown_ratings"] = {"ABCDEFGH"[pos]: d["ratings"][k] for pos, k in enumerate(d["order"])}
    for token, step, kind, fingerprint in stats.acked:
        got = data.get((token, step))
        if got and (got[0] != kind or any(got[1].get(k) != v for k, v in fingerprint.items())):
            mismatched.append((token, step, kind))
    per_pid = Counter(pid for pid, *_ in people)
    per_condition = Counter({name: 0 for name in conditions})
    per_condition.update(name for _, _, name, _, _ in people)
    codes = {pid: (token, code) for pid, token, _, code, done in people if done}
    return {
        "answers_acked": sum(acked.values()),
        "answers_stored": len(rows),
        "lost": sorted(k for k in acked if k not in stored),
        "duplicated": sorted(k for k, n in stored.items() if n > 1) + sorted(k for k, n in acked.items() if n > 1),
        "unacknowledged": sorted(k for k in stored if k not in acked),
        "mismatched": mismatched,
        "participants": len(people),
        "pids_with_several_participants": sorted(p for p, n in per_pid.items() if n > 1),
        "missing_participants": sorted(set(stats.tokens) - set(per_pid)),
        "per_condition": dict(per_condition),
        "balance": max(per_condition.values()) - min(per_condition.values()) if per_condition else 0,
        "completed": len(codes),
        "wrong_codes": sorted(pid for pid, seen in stats.finished.items() if codes.get(pid) != seen),
    }
