"""Starting and stopping `celery worker` processes (tests, benchmark, ``manage.py up``).

A worker is started in its own session (process group), so stopping it can
reach its pool children even if the main process died: SIGTERM first (warm
shutdown: the running task finishes, unstarted messages go back), SIGKILL
for the group after a grace period.
"""
from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def host_id() -> str:
    """This process, as the build journal and a job's parts record who computed what."""
    return f"{socket.gethostname()}:{os.getpid()}"


def celery_executable(python: str = sys.executable) -> list[str]:
    return [python, "-m", "celery"]


def worker_command(queue: str = "celery", concurrency: int = 1, hostname: str | None = None,
                   loglevel: str = "info", pool: str = "prefork", python: str = sys.executable) -> list[str]:
    """`celery worker` for the project's app; `python`: another checkout's interpreter (bench/worker_boot.py)."""
    cmd = celery_executable(python) + ["-A", "config", "worker", f"--pool={pool}", "-c", str(concurrency),
                                 "-Q", queue, "-l", loglevel, "--without-gossip", "--without-mingle"]
    if hostname:
        cmd += ["-n", hostname]
    return cmd


def start_worker(queue: str = "celery", concurrency: int = 1, env: dict | None = None, log_path=None,
                 hostname: str | None = None, loglevel: str = "info") -> subprocess.Popen:
    full_env = dict(os.environ)
    full_env.update(env or {})
    full_env.setdefault("DJANGO_SETTINGS_MODULE", "config.settings")
    out = open(log_path, "ab") if log_path else subprocess.DEVNULL
    try:
        proc = subprocess.Popen(worker_command(queue, concurrency, hostname, loglevel), cwd=ROOT, env=full_env,
                                stdout=out, stderr=subprocess.STDOUT, start_new_session=True)
    finally:
        if log_path:
            out.close()
    proc.log_path = Path(log_path) if log_path else None
    return proc


def wait_ready(proc: subprocess.Popen, timeout: float = 60.0, poll: float = 0.1) -> None:
    """Wait for the worker's "ready." log line, looking every `poll` seconds."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            tail = proc.log_path.read_text()[-3000:] if proc.log_path else ""
            raise RuntimeError(f"celery worker exited with status {proc.returncode}:\n{tail}")
        if proc.log_path and proc.log_path.exists() and " ready." in proc.log_path.read_text():
            return
        time.sleep(poll)
    raise TimeoutError(f"celery worker not ready after {timeout:.0f} s")


def pool_children(pid: int) -> list[int]:
    """Child process ids of `pid` (Linux /proc)."""
    try:
        text = Path(f"/proc/{pid}/task/{pid}/children").read_text()
    except OSError:
        return []
    return [int(p) for p in text.split()]


def stop_worker(proc: subprocess.Popen, grace: float = 30.0) -> None:
    """Warm shutdown, then SIGKILL to the worker's process group (our own session) if needed."""
    if proc.poll() is None:
        try:
            proc.send_signal(signal.SIGTERM)
            proc.wait(grace)
        except subprocess.TimeoutExpired:
            pass
    try:
        os.killpg(proc.pid, signal.SIGKILL)  # pool children left behind by a killed main process
    except (ProcessLookupError, PermissionError):
        pass
    try:
        proc.wait(5)
    except subprocess.TimeoutExpired:
        pass
