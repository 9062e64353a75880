"""gunicorn settings for the study app (scripts/serve.sh; docs/operations.md).

    gunicorn -c config/gunicorn.conf.py config.wsgi

Environment (all optional):

* ``GUNICORN_BIND``      — address to listen on (default 127.0.0.1:8000: the TLS proxy in front
                           forwards to it; nothing else should reach it)
* ``WEB_CONCURRENCY``    — worker processes (default 2 × cores + 1)
* ``GUNICORN_THREADS``   — threads per worker (default 4)
* ``GUNICORN_TIMEOUT``   — seconds before a silent worker is killed and replaced (default 30)
* ``GUNICORN_ACCESS_LOG``— file for the access log, "-" for stdout (default), "" for none
* ``FORWARDED_ALLOW_IPS``— proxies whose X-Forwarded-* headers gunicorn trusts (default 127.0.0.1)
* ``GUNICORN_CONTROL_SOCKET`` — gunicornc's control socket (default ``$VAR_DIR/gunicorn.ctl``)
* ``OPENBLAS_NUM_THREADS`` — BLAS threads per worker (default 1, below)
"""
import hashlib
import multiprocessing
import os
import time
from pathlib import Path

# One BLAS thread per web worker: a closed-loop decision's matrix-vector product (85 MB at paper size) would
# otherwise start a thread per core in each of the 2 × cores + 1 workers, and under load they fight over the
# cores the workers already share.  Set before any worker imports NumPy.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

bind = os.environ.get("GUNICORN_BIND", "127.0.0.1:8000")

# Requests spend much of their time waiting on PostgreSQL, so a process per core is not enough
# to keep the cores busy: 2n+1 processes, each with a few threads for overlapping waits.  Every
# thread holds at most one database connection (CONN_MAX_AGE), so workers × threads must stay
# well under PostgreSQL's max_connections (100 by default): 5 × 4 = 20 on 2 cores.
workers = int(os.environ.get("WEB_CONCURRENCY", 2 * multiprocessing.cpu_count() + 1))
worker_class = "gthread"
threads = int(os.environ.get("GUNICORN_THREADS", "4"))

# No participant request does more than a few database round trips: a request still running
# after 30 s is stuck, and its worker is replaced.  Stopping waits as long for requests in flight,
# so a deploy or Ctrl-C never cuts an answer being saved.
timeout = int(os.environ.get("GUNICORN_TIMEOUT", "30"))
graceful_timeout = 30
# Keep idle connections a little longer than the gap between a page and its static files, and
# longer than nginx keeps its idle connections to gunicorn (2 s, config/nginx.conf.template).
keepalive = 5
# Recycle workers now and then so that slow leaks in a long recruitment never build up;
# the jitter keeps them from restarting all at once.
max_requests = 5000
max_requests_jitter = 500



def _control_socket() -> str:
    """This instance's own control socket (``gunicornc -s PATH``), under its VAR_DIR.

    gunicorn's default is one path per user ($XDG_RUNTIME_DIR or $HOME/.gunicorn/gunicorn.ctl):
    a second instance on the machine (another study, a load test, a staging copy) unlinks the
    first one's socket and takes it over, so ``gunicornc`` would reload or shrink the wrong
    server, and the first to stop removes the other's socket.  A Unix socket's path is limited
    to 107 bytes: a VAR_DIR too deep for it gets a path under /tmp named by its hash instead.
    """
    if os.environ.get("GUNICORN_CONTROL_SOCKET"):
        return os.environ["GUNICORN_CONTROL_SOCKET"]
    var = Path(os.environ.get("VAR_DIR") or Path(__file__).resolve().parent.parent / "var").resolve()
    path = str(var / "gunicorn.ctl")
    if len(path.encode()) <= 100:
        return path
    return f"/tmp/study-gunicorn-{hashlib.sha1(str(var).encode()).hexdigest()[:12]}.ctl"


control_socket = _control_socket()

forwarded_allow_ips = os.environ.get("FORWARDED_ALLOW_IPS", "127.0.0.1")

_access = os.environ.get("GUNICORN_ACCESS_LOG", "-")
accesslog = _access or None
# Combined log format plus the request time in milliseconds (%(M)s), for latency alarms.
access_log_format = '%(h)s %(l)s %(u)s %(t)s "%(r)s" %(s)s %(b)s "%(f)s" "%(a)s" %(M)sms'
errorlog = "-"
loglevel = os.environ.get("GUNICORN_LOG_LEVEL", "info")
# Heartbeat files in memory, not on a disk that may stall under load.
worker_tmp_dir = "/dev/shm" if os.path.isdir("/dev/shm") else None


def post_worker_init(worker):
    """Import every view (the URLconf pulls in the analysis stack: ~1.5 s of CPU) and compile the
    participant templates before this worker takes its first request, so that no participant
    waits for it after a deploy, a restart or a max_requests recycle."""
    # Django loads in the worker, not when gunicorn reads this file
    from django.db import connection  # noqa: PLC0415
    from django.template.loader import get_template  # noqa: PLC0415
    from django.urls import get_resolver  # noqa: PLC0415

    from studyapp.models import StepKind  # noqa: PLC0415
    from studyapp.participant.closedloop import warm_packs  # noqa: PLC0415

    start = time.monotonic()
    get_resolver().url_patterns  # noqa: B018  (the access loads the URLconf)
    for kind in StepKind:
        get_template(f"studyapp/step_{kind}.html")
    packs = warm_packs()
    connection.close()  # the boot thread's: the worker's request threads open their own
    worker.log.info("worker %s warm in %.1f s (%d closed-loop packs mapped)", worker.pid, time.monotonic() - start,
                    packs)
