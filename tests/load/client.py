"""Simulated participants: a bounded asyncio HTTP client (aiohttp) for the load test.

Each participant has its own cookie jar and its own loopback source address
(127.0.x.y: Linux routes all of 127/8 to lo), so per-address rate limits see
one address per participant, as on launch day.  A participant arrives at its
moment in the arrival window, enters with a Prolific id, and then loops: GET
the step page, parse the form (CSRF token, action, fields), pause as a person
would, POST the answer (Accept: application/json, like the participant page's
save script), follow `next`, until the completion page shows the code.

Failed requests are retried the way the participant page retries a save:
connection errors, 5xx and 429 with exponential backoff and jitter, honouring
Retry-After.  Every attempt's status and latency is logged, and every answer
the server acknowledged goes into `Stats.acked`, which the caller compares
with the database.  Only loopback addresses are ever contacted.
"""
from __future__ import annotations

import asyncio
import html
import ipaddress
import json
import random
import re
import time
from collections import Counter, defaultdict
from dataclasses import dataclass, field
from urllib.parse import urlsplit

import aiohttp

RETRY_STATUSES = {429, 500, 502, 503, 504}
# Seconds a quick but genuine participant spends on each kind of step (pace 1.0): read the
# consent form, read the instructions, watch a 5.6 s training animation, play a test's four
# options, choose and rate them.  About 4.5 minutes for the demo study, faster than the paper's
# participants, so the request rate is on the high side of a real launch.
DWELL = {"consent": 10.0, "instructions": 20.0, "training": 7.0, "test": 30.0, "attention": 10.0,
         "demographics": 10.0}

CSRF_RE = re.compile(r'name="csrfmiddlewaretoken"\s+value="([^"]+)"')
ACTION_RE = re.compile(r'<form[^>]*\saction="(/s/[^"]+/p/[^"]+/\d+/)"')
CHOICE_RE = re.compile(r'name="choice"\s+value="([A-H])"')  # the letters the participant sees
CODE_RE = re.compile(r'id="completion-code">([^<]+)<')


class ParticipantFailed(Exception):
    """A participant could not finish: an unexpected answer, or retries ran out."""


@dataclass
class Config:
    base_url: str                 # http://127.0.0.1:PORT (loopback only)
    slug: str = "demo"
    participants: int = 100
    window: float = 20.0          # arrivals spread over this many seconds
    pace: float = 1.0             # pauses are DWELL x pace (1.0: realistic; CI compresses them)
    request_timeout: float = 30.0
    give_up_after: float = 120.0  # a request retried for longer than this fails its participant
    backoff_base: float = 0.25
    backoff_cap: float = 8.0
    run_id: str = "load"
    seed: int = 0

    def __post_init__(self):
        host = urlsplit(self.base_url).hostname
        if not ipaddress.ip_address(host).is_loopback:
            raise ValueError(f"the load client only talks to loopback addresses, not {host}")


@dataclass
class Stats:
    started: float = field(default_factory=time.monotonic)
    # endpoint -> [(start, seconds, status)]; status 0 = no HTTP response (connection error, timeout)
    attempts: dict = field(default_factory=lambda: defaultdict(list))
    errors: Counter = field(default_factory=Counter)          # (endpoint, kind) -> count
    acked: list = field(default_factory=list)                 # (token, step, kind, fingerprint)
    save_times: list = field(default_factory=list)            # answer: first attempt -> acknowledged
    finished: dict = field(default_factory=dict)              # pid -> (token, completion code)
    failed: dict = field(default_factory=dict)                # pid -> reason
    tokens: dict = field(default_factory=dict)                # pid -> token
    fault: list = field(default_factory=list)                 # [(start, end)] of injected faults
    ended: float | None = None

    def record(self, endpoint, start, seconds, status, kind=None):
        self.attempts[endpoint].append((start, seconds, status))
        if kind:
            self.errors[(endpoint, kind)] += 1


def source_address(i: int) -> str:
    """Participant i's own loopback address, 127.0.x.y (never 127.0.0.x, where servers listen)."""
    if i >= 254 * 250:
        raise ValueError("at most 63,500 participants have their own address")
    return f"127.0.{1 + i // 250}.{1 + i % 250}"


def parse_step(page: str) -> dict:
    """The step's kind and what its form needs, read from the page as a browser would see it."""
    code = CODE_RE.search(page)
    if code:
        return {"kind": "done", "code": html.unescape(code.group(1)).strip()}
    action, csrf = ACTION_RE.search(page), CSRF_RE.search(page)
    if not action:
        raise ParticipantFailed("step page without an answer form")
    step = {"action": html.unescape(action.group(1)), "csrf": csrf and html.unescape(csrf.group(1))}
    if 'name="consent"' in page:
        step["kind"] = "consent"
    elif 'name="ack"' in page:
        step["kind"] = "instructions"
    elif 'name="choice"' in page:
        step.update(kind="test", options=CHOICE_RE.findall(page))
    elif 'name="goals"' in page:
        step["kind"] = "attention"
    elif 'name="age"' in page:
        step["kind"] = "demographics"
    elif 'name="played"' in page:
        step["kind"] = "training"
    else:
        raise ParticipantFailed("step page of an unknown kind")
    return step


def answer_for(step: dict, rng: random.Random) -> tuple[list, dict]:
    """(form fields, fingerprint of what the database must hold) for a step."""
    kind = step["kind"]
    if kind == "consent":
        return [("consent", "yes")], {}
    if kind == "instructions":
        return [("ack", "1")], {}
    if kind == "training":
        return [("played", "1")], {}
    if kind == "test":
        options = step["options"]
        choice = rng.choice(options)
        ratings = {k: rng.randint(1, 7) for k in options}
        fields = [("choice", choice)] + [("played", k) for k in options]
        fields += [(f"rating_{k}", str(r)) for k, r in ratings.items()]
        # the page shows letters only; the harness maps the stored answer back through its order
        return fields, {"shown_choice": choice, "shown_ratings": ratings}
    if kind == "attention":
        return [("goals", "merge"), ("goals", "forward")], {"passed": True}
    if kind == "demographics":
        age = rng.randint(18, 80)
        return [("age", str(age)), ("gender", rng.choice(["female", "male", "non-binary"]))], {"age": age}
    raise ParticipantFailed(f"no answer for a {kind} step")


class Participant:
    def __init__(self, i: int, cfg: Config, stats: Stats, arrival: float):
        self.i, self.cfg, self.stats, self.arrival = i, cfg, stats, arrival
        self.pid = f"{cfg.run_id}-{i:05d}"
        self.rng = random.Random(f"{cfg.seed}-{i}")
        self.origin = cfg.base_url.rstrip("/")

    def backoff(self, attempt: int) -> float:
        return min(self.cfg.backoff_cap, self.cfg.backoff_base * 2 ** attempt) * self.rng.uniform(0.5, 1.0)

    async def request(self, session, endpoint, method, url, expect, **kwargs):
        """One logical request with the participant page's retries; returns (response, body)."""
        first, attempt = time.monotonic(), 0
        while True:
            start = time.monotonic()
            delay = None
            try:
                async with session.request(method, url, allow_redirects=False, **kwargs) as r:
                    body = await r.text()
                seconds = time.monotonic() - start
                if r.status in RETRY_STATUSES:
                    self.stats.record(endpoint, start, seconds, r.status, kind=str(r.status))
                    retry_after = r.headers.get("Retry-After", "")
                    if retry_after.isdigit():
                        delay = min(float(retry_after), 30.0) + self.rng.uniform(0, 0.5)
                elif r.status != expect:
                    self.stats.record(endpoint, start, seconds, r.status, kind=str(r.status))
                    raise ParticipantFailed(f"{method} {url}: {r.status} (expected {expect}): {body[:200]!r}")
                else:
                    self.stats.record(endpoint, start, seconds, r.status)
                    return r, body, first
            except (TimeoutError, aiohttp.ClientError, ConnectionError) as exc:
                kind = "timeout" if isinstance(exc, asyncio.TimeoutError) else type(exc).__name__
                self.stats.record(endpoint, start, time.monotonic() - start, 0, kind=kind)
            delay = delay if delay is not None else self.backoff(attempt)
            attempt += 1
            if time.monotonic() + delay - first > self.cfg.give_up_after:
                raise ParticipantFailed(f"{method} {url}: gave up after {attempt} attempts")
            await asyncio.sleep(delay)

    async def pause(self, kind):
        mean = self.cfg.pace * DWELL.get(kind, 10.0)
        if mean > 0:
            await asyncio.sleep(self.rng.lognormvariate(0, 0.5) * mean / 1.133)  # E[lognormal(0, .5)] = 1.133

    async def run(self):
        await asyncio.sleep(self.arrival)
        jar = aiohttp.CookieJar(unsafe=True)  # unsafe: keep cookies set by an IP-address host
        # A browser silently resends a request whose reused keep-alive connection the server had
        # just closed; aiohttp does not, so idle connections are dropped before gunicorn's 5 s
        # keepalive ends rather than counted as errors the participant would never see.
        connector = aiohttp.TCPConnector(local_addr=(source_address(self.i), 0), limit=4, keepalive_timeout=3)
        timeout = aiohttp.ClientTimeout(total=self.cfg.request_timeout)
        async with aiohttp.ClientSession(self.origin, cookie_jar=jar, connector=connector, timeout=timeout) as s:
            try:
                await self.flow(s)
            except ParticipantFailed as exc:
                self.stats.failed[self.pid] = str(exc)

    async def flow(self, s):
        params = {"PROLIFIC_PID": self.pid, "STUDY_ID": self.cfg.run_id, "SESSION_ID": f"session-{self.i}"}
        r, _, _ = await self.request(s, "entry", "GET", f"/s/{self.cfg.slug}/", 302, params=params)
        url = urlsplit(r.headers["Location"]).path
        token = url.rstrip("/").rsplit("/", 1)[-1]
        self.stats.tokens[self.pid] = token
        headers = {"Accept": "application/json", "Origin": self.origin}
        for _ in range(100):  # a flow has ~20 steps; never loop forever on a confused server
            _, page, _ = await self.request(s, "step", "GET", url, 200)
            step = parse_step(page)
            if step["kind"] == "done":
                self.stats.finished[self.pid] = (token, step["code"])
                return
            await self.pause(step["kind"])
            fields, fingerprint = answer_for(step, self.rng)
            if step["csrf"]:
                fields.append(("csrfmiddlewaretoken", step["csrf"]))
            _, body, first = await self.request(s, "answer", "POST", step["action"], 200, data=fields,
                                                headers=dict(headers, Referer=self.origin + url))
            reply = _json(body)
            if not reply.get("ok"):
                raise ParticipantFailed(f"answer not acknowledged: {body[:200]!r}")
            index = int(step["action"].rstrip("/").rsplit("/", 1)[-1])
            self.stats.acked.append((token, index, step["kind"], fingerprint))
            self.stats.save_times.append(time.monotonic() - first)
            url = urlsplit(reply["next"]).path
        raise ParticipantFailed("more than 100 steps")


def _json(body: str) -> dict:
    try:
        return json.loads(body)
    except ValueError:
        return {}


def arrivals(cfg: Config) -> list[float]:
    """Arrival offsets spread uniformly at random over the window (a Poisson-like launch burst)."""
    rng = random.Random(cfg.seed)
    return sorted(rng.uniform(0, cfg.window) for _ in range(cfg.participants))


async def run_participants(cfg: Config, stats: Stats, fault=None) -> Stats:
    """Run every participant to the end; `fault` (an async callable taking stats) runs alongside."""
    stats.started = time.monotonic()
    tasks = [asyncio.create_task(Participant(i, cfg, stats, t).run()) for i, t in enumerate(arrivals(cfg))]
    fault_task = asyncio.create_task(fault(stats)) if fault else None
    try:
        await asyncio.gather(*tasks)
    finally:
        stats.ended = time.monotonic()
        if fault_task:
            await fault_task  # a fault must always finish its own recovery (PostgreSQL back up)
    return stats
