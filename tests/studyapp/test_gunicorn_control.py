"""Each gunicorn instance has its own control socket, under its own VAR_DIR.

gunicorn's default is one socket per user ($HOME/.gunicorn/gunicorn.ctl): a second instance
unlinks the first one's and takes it over, so ``gunicornc`` would act on the wrong server.
Two real gunicorns (config/gunicorn.conf.py, one worker each, on Unix sockets) run side by side.
"""
import json
import os
import signal
import subprocess
import sys
from pathlib import Path

from tests.services import wait_until

ROOT = Path(__file__).resolve().parents[2]
BIN = Path(sys.executable).parent


def start(tmp_path: Path, name: str, home: Path):
    var = tmp_path / name
    var.mkdir()
    env = {k: v for k, v in os.environ.items() if k not in ("XDG_RUNTIME_DIR", "GUNICORN_CONTROL_SOCKET")}
    env.update(HOME=str(home), VAR_DIR=str(var), GUNICORN_BIND=f"unix:{var}/web.sock", WEB_CONCURRENCY="1",
               GUNICORN_THREADS="1", GUNICORN_ACCESS_LOG="", DEBUG="0", SECRET_KEY="x" * 50,
               DATABASE_URL=f"sqlite:///{var}/db.sqlite3", DJANGO_SETTINGS_MODULE="config.settings")
    with open(var / "gunicorn.log", "w") as log:  # the child keeps its own descriptor
        proc = subprocess.Popen([BIN / "gunicorn", "-c", "config/gunicorn.conf.py", "config.wsgi"], cwd=ROOT,
                                env=env, stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
    return proc, var / "gunicorn.ctl"


def stats(sock: Path) -> dict:
    out = subprocess.run([BIN / "gunicornc", "-s", str(sock), "-c", "show stats", "-j"],
                         capture_output=True, text=True, timeout=20)
    assert out.returncode == 0, out.stdout + out.stderr
    return json.loads(out.stdout)


def wait_for(path: Path, timeout: float = 300):
    wait_until(path.exists, timeout, f"{path} appearing", poll=0.2)


def test_two_instances_get_their_own_control_sockets(tmp_path):
    home = tmp_path / "home"
    home.mkdir()
    procs = []
    try:
        a, sock_a = start(tmp_path, "a", home)
        procs.append(a)
        b, sock_b = start(tmp_path, "b", home)
        procs.append(b)
        wait_for(sock_a)
        wait_for(sock_b)
        assert sock_a != sock_b
        assert stats(sock_a)["pid"] == a.pid and stats(sock_b)["pid"] == b.pid  # each answers for itself
        assert not (home / ".gunicorn").exists()  # nothing in the shared per-user place
        a.send_signal(signal.SIGTERM)
        a.wait(30)
        assert not sock_a.exists()  # the first one's exit removes its own socket only
        assert stats(sock_b)["pid"] == b.pid
    finally:
        for p in procs:
            if p.poll() is None:
                os.killpg(p.pid, signal.SIGKILL)
                p.wait(10)
