"""Many slow request bodies from many addresses, and gunicorn down: nginx keeps answering.

* 10,000 connections from 300 loopback addresses (127.1.x.y; Linux answers all of 127.0.0.0/8 on
  lo) each send a participant POST's headers and then trickle its body a byte every half second,
  for longer than nginx's 10 s client_body_timeout (which counts the gap between reads, so the
  trickle keeps them alive).  One address may hold 32 (CONN_PER_ADDRESS): the rest are refused
  with 503, and every refused or dropped connection is reopened.  Meanwhile the home page is
  asked for from 127.0.0.1 four times a second: every GET is answered (within a hang guard; the
  latency and its bar, p95 under 1 s, are bench/latency.py's).  With too few worker_connections
  nginx runs out at ~8,000 and drops the rest.
* gunicorn stopped (supervisorctl stop web): nginx answers its own page, 503 with Retry-After,
  a meta refresh and no-store, and JSON to a script asking for JSON.

Loopback only; the load generator is one thread with epoll, bounded in count and time.
"""
from __future__ import annotations

import errno
import resource
import select
import socket
import subprocess
import threading
import time
import urllib.error
import urllib.request

import pytest

from tests.load import harness
from tests.services import wait_until

pytestmark = [pytest.mark.slow, pytest.mark.postgres, pytest.mark.redis]

CONNECTIONS = 10_000
ADDRESSES = [f"127.1.{i // 250}.{i % 250 + 1}" for i in range(300)]  # never 127.0.0.1, the GETs' address
CAP = 32  # CONN_PER_ADDRESS, serve.sh's default
TRICKLE_EVERY = 0.5  # seconds between two bytes of one body
MAX_OPENS, REOPEN_PER_ROUND = 3 * CONNECTIONS, 1000
DURATION = 12.0  # seconds of GETs under full pressure: longer than client_body_timeout
HANG_GUARD = 10.0  # seconds a GET may wait: tells "answered" from "dropped or stuck"
HEAD = (b"POST /s/none/p/none/1/ HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/x-www-form-urlencoded"
        b"\r\nContent-Length: 1000\r\n\r\n")


class SlowBodies:
    """CONNECTIONS slow POSTs, opened in batches, each trickling one byte per TRICKLE_EVERY.

    A connection the server answers (its 503 for an address over the cap) or drops is counted and
    reopened from the same address, as an attacker would, so nginx stays under full pressure; the
    opens are bounded (MAX_OPENS in all, REOPEN_PER_ROUND a round) and everything stops at stop()
    or after max_seconds.
    """

    def __init__(self, port: int, max_seconds: float = 60):
        self.port, self.deadline = port, time.monotonic() + max_seconds
        self.stop_event = threading.Event()
        self.socks: dict[int, socket.socket] = {}
        self.pending_head: set[int] = set()
        self.index: dict[int, int] = {}  # fd -> connection number (its address)
        self.answered: dict[bytes, int] = {}
        self.closed = self.failed_connects = self.opened = 0
        self.reopen: list[int] = []
        self.open_counts: list[int] = []
        self.epoll = select.epoll()
        self.thread = threading.Thread(target=self.run, daemon=True)

    def open_one(self, i: int):
        s = socket.socket()
        s.setblocking(False)
        try:
            s.bind((ADDRESSES[i % len(ADDRESSES)], 0))
            s.connect_ex(("127.0.0.1", self.port))
        except OSError:
            s.close()
            self.failed_connects += 1
            return
        self.opened += 1
        self.socks[s.fileno()] = s
        self.index[s.fileno()] = i
        self.pending_head.add(s.fileno())
        self.epoll.register(s.fileno(), select.EPOLLIN | select.EPOLLRDHUP)

    def drop(self, fd: int, answer: bytes | None):
        s = self.socks.pop(fd)
        self.reopen.append(self.index.pop(fd))
        self.pending_head.discard(fd)
        self.epoll.unregister(fd)
        s.close()
        if answer:
            status = answer.split(b"\r\n", 1)[0][:12]  # "HTTP/1.1 503"
            self.answered[status] = self.answered.get(status, 0) + 1
        else:
            self.closed += 1

    def send(self, fd: int, data: bytes):
        try:
            self.socks[fd].send(data)
        except BlockingIOError:
            return  # still connecting, or the buffer is full: next round
        except OSError as exc:
            if exc.errno not in (errno.ENOTCONN,):
                self.drop(fd, None)
            return
        self.pending_head.discard(fd)

    def poll(self):
        for fd, _ in self.epoll.poll(0):
            if fd in self.socks:
                try:
                    data = self.socks[fd].recv(512)
                except OSError:
                    data = b""
                self.drop(fd, data)

    def run(self):
        try:
            for start in range(0, CONNECTIONS, 250):  # ~40 batches: the listen queue never overflows
                for i in range(start, min(start + 250, CONNECTIONS)):
                    self.open_one(i)
                time.sleep(0.02)
                for fd in list(self.pending_head):
                    self.send(fd, HEAD)
                self.poll()
            while not self.stop_event.wait(TRICKLE_EVERY) and time.monotonic() < self.deadline:
                for fd in list(self.socks):
                    if fd in self.socks:
                        self.send(fd, HEAD if fd in self.pending_head else b"x")
                self.poll()
                self.open_counts.append(len(self.socks))  # accepted and trickling (not yet reopened ones)
                again, self.reopen = self.reopen[:REOPEN_PER_ROUND], self.reopen[REOPEN_PER_ROUND:]
                for i in again:
                    if self.opened < MAX_OPENS:
                        self.open_one(i)
        finally:
            for s in self.socks.values():
                s.close()
            self.epoll.close()


@pytest.fixture
def server(shared_server):
    """The server of tests/load/conftest.py (shared with test_supervision.py and test_slow_clients.py)."""
    return shared_server


def under_slow_bodies(server) -> tuple[list[harness.Visit], SlowBodies]:
    """The home page visited every 0.25 s for DURATION s while CONNECTIONS slow bodies from
    ADDRESSES press on `server`; the visits and the load generator (its counts)."""
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    need = CONNECTIONS + 1000
    # the test must run: a machine whose hard limit is too low cannot show the property at all
    assert hard == resource.RLIM_INFINITY or hard >= need, f"this process may open only {hard} files; needs {need}"
    if soft < need:
        resource.setrlimit(resource.RLIMIT_NOFILE, (need, hard))
    slow = SlowBodies(server.port, max_seconds=600)  # stop_event ends it sooner; this bounds a stray run
    slow.thread.start()
    try:
        wait_until(lambda: len(slow.open_counts) >= 2, 300, "every slow connection opened and trickling", poll=0.1)
        visits = harness.visits_during(server.base_url + "/", DURATION, timeout=HANG_GUARD)
    finally:
        slow.stop_event.set()
        slow.thread.join(30)
        resource.setrlimit(resource.RLIMIT_NOFILE, (soft, hard))
    held = slow.open_counts[2:] or slow.open_counts
    print(f"{len(visits)} GETs during {DURATION:.0f} s of {CONNECTIONS} slow bodies from {len(ADDRESSES)} "
          f"addresses: {min(held)}-{max(held)} held open, {slow.opened} opened, answered {slow.answered}, dropped "
          f"{slow.closed}, connect failures {slow.failed_connects}; {harness.latency_ms(visits)}")
    return visits, slow


def test_ten_thousand_slow_bodies_from_300_addresses_leave_gets_answered(server):
    since = server.mark()
    assert harness.visit(server.base_url + "/", HANG_GUARD).answered
    visits, slow = under_slow_bodies(server)
    held = slow.open_counts[2:] or slow.open_counts
    # the pressure really was on: every address at its cap, trickling past client_body_timeout
    assert min(held) >= len(ADDRESSES) * CAP * 0.95
    assert slow.answered.get(b"HTTP/1.1 503", 0) >= CONNECTIONS - len(ADDRESSES) * CAP - 50  # over the cap
    assert len(visits) >= 3 and all(v.answered for v in visits), [v.status for v in visits]
    assert "worker_connections are not enough" not in server.log_since(since)


def supervisorctl(server, *args) -> str:
    env = dict(server.env, SERVE_ROOT=str(harness.ROOT))
    out = subprocess.run([str(harness.ROOT / ".venv/bin/supervisorctl"), "-c", "config/supervisord.conf", *args],
                         cwd=harness.ROOT, env=env, capture_output=True, text=True, timeout=60)
    return out.stdout + out.stderr


def test_gunicorn_down_shows_nginx_page_with_retry_after(server):
    url = server.base_url + "/"
    assert "stopped" in supervisorctl(server, "stop", "web").lower()
    try:
        with pytest.raises(urllib.error.HTTPError) as page:
            harness.NO_PROXY.open(url, timeout=10)
        r = page.value
        body = r.read().decode()
        assert r.code == 503 and r.headers["Retry-After"] == "10" and r.headers["Cache-Control"] == "no-store"
        assert r.headers["Content-Type"] == "text/html; charset=utf-8"
        assert "One moment, please" in body and '<meta http-equiv="refresh" content="10">' in body
        request = urllib.request.Request(server.base_url + "/s/x/p/y/1/", data=b"a=1",
                                                 headers={"Accept": "application/json"})
        with pytest.raises(urllib.error.HTTPError) as answer:  # the participant page's save loop
            harness.NO_PROXY.open(request, timeout=10)
        assert answer.value.code == 503 and answer.value.headers["Retry-After"] == "10"
        assert answer.value.headers["Content-Type"].startswith("application/json")
        assert b'"ok": false' in answer.value.read()
    finally:
        supervisorctl(server, "start", "web")
    wait_until(lambda: harness.visit(url, HANG_GUARD).answered, 300, "the site serving again", poll=0.5)
