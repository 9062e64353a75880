"""Slow clients do not stop the site.

100 connections from one address trickle their request a byte at a time (half of them the
headers, half a declared 1,000-byte body), and each is reopened as soon as the server drops it,
for longer than the server's read timeouts.  Meanwhile a participant from another address asks
for the home page four times a second: every one of those GETs is answered.  Against gunicorn
alone (its 8 threads here, 20 in production on 2 cores, each blocked reading one slow request)
they go unanswered for as long as the trickle lasts, past the hang guard; scripts/serve.sh puts
nginx in front, which reads every request whole before gunicorn sees it.  Their latency is
printed, and measured with its bar (p95 under 1 s, production's worker count) by bench/latency.py.
Loopback only, bounded in time.
"""
from __future__ import annotations

import socket
import threading

import pytest

from tests.load import harness
from tests.services import wait_until

pytestmark = [pytest.mark.slow, pytest.mark.postgres, pytest.mark.redis]

SLOW_CONNECTIONS = 100
SLOW_ADDRESS = "127.0.250.1"  # one address for all of them
DURATION = 16.0  # seconds: longer than nginx's 10 s header and body timeouts
HANG_GUARD = 10.0  # seconds a GET may wait: tells "answered" from "stuck behind the slow requests"


class Trickler:
    """Keeps SLOW_CONNECTIONS slow requests open, one byte per connection every half second."""

    def __init__(self, port: int):
        self.port = port
        self.stop = threading.Event()
        self.opened = 0
        self.open_counts: list[int] = []
        self.thread = threading.Thread(target=self.run, daemon=True)

    def connect(self, i: int):
        try:
            s = socket.create_connection(("127.0.0.1", self.port), timeout=2, source_address=(SLOW_ADDRESS, 0))
        except OSError:
            return None
        self.opened += 1
        if i % 2:  # a whole header, then the body a byte at a time
            s.sendall(b"POST /s/none/p/none/1/ HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: "
                      b"application/x-www-form-urlencoded\r\nContent-Length: 1000\r\n\r\n")
        else:  # the request line, then the headers a byte at a time
            s.sendall(b"GET / HTTP/1.1\r\nHost: 127.0.0.1\r\n")
        s.setblocking(False)
        return s

    def run(self):
        conns = [self.connect(i) for i in range(SLOW_CONNECTIONS)]
        while not self.stop.wait(0.5):
            for i, s in enumerate(conns):
                if s is not None:
                    try:
                        if s.recv(4096, socket.MSG_PEEK) == b"":  # closed by the server
                            raise ConnectionError
                    except BlockingIOError:
                        pass  # open, nothing to read: still waiting for us
                    except OSError:
                        s.close()
                        s = None
                    else:
                        s.close()  # the server answered (a timeout or a refusal): give up this one
                        s = None
                if s is not None:
                    try:
                        s.send(b"x" if i % 2 else b"X")
                    except OSError:
                        s.close()
                        s = None
                conns[i] = s if s is not None else self.connect(i)
            self.open_counts.append(sum(s is not None for s in conns))
        for s in conns:
            if s is not None:
                s.close()


def under_slow_clients(server: harness.Server) -> tuple[list[harness.Visit], Trickler]:
    """The home page visited every 0.25 s for DURATION s while SLOW_CONNECTIONS slow requests
    from one address press on `server`; the visits and the trickler (its counts of open
    connections)."""
    url = server.base_url + "/"
    slow = Trickler(server.port)
    slow.thread.start()
    try:
        # every slow connection opened and trickling (the first round of bytes sent)
        wait_until(lambda: slow.open_counts, 300, "the slow connections opened and trickling", poll=0.05)
        visits = harness.visits_during(url, DURATION, timeout=HANG_GUARD)
    finally:
        slow.stop.set()
        slow.thread.join(10)
    print(f"{len(visits)} GETs during {DURATION:.0f} s of {SLOW_CONNECTIONS} slow connections from one address "
          f"({slow.opened} opened in all, {min(slow.open_counts)}-{max(slow.open_counts)} open at once): "
          f"{harness.latency_ms(visits)}")
    return visits, slow


def test_slow_clients_from_one_address_leave_the_site_responsive(shared_server):
    server = shared_server  # tests/load/conftest.py (shared with test_supervision.py and test_slow_bodies.py)
    assert harness.visit(server.base_url + "/", HANG_GUARD).answered
    visits, slow = under_slow_clients(server)
    assert min(slow.open_counts) >= SLOW_CONNECTIONS * 0.9  # the pressure really was on all along
    assert len(visits) >= 3 and all(v.answered for v in visits), [v.status for v in visits]
