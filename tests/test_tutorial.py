"""The tutorial (docs/tutorial.md) followed as written, in this checkout, on the embedded default (SQLite, the
broker that needs no server): its `make demo` serves the demo study and prints the very links the tutorial
shows; a participant takes part through the participant link as a browser would post it (step 2); the
researcher logs in with the printed login and finds the study and the designer (steps 3 and 4); Ctrl-C stops
the site and its worker; and step 6's two commands analyse and export the study taken part in.

Steps 4 and 5 (the designer's Build, the pilot, Preview, Open study) are what
tests/browser/test_researcher_flow.py walks in Chromium, so step 6 runs here on the demo study in place of
the tutorial's `my-first`.  The clone itself is the README's first command, tried from a fresh clone before
an issue is closed; here `make demo` runs in the checkout under test, on a table directory of its own."""
from __future__ import annotations

import os
import random
import re
import signal
import subprocess
import threading
from http.cookiejar import CookieJar
from pathlib import Path
from urllib.parse import urlencode, urljoin
from urllib.request import HTTPCookieProcessor, Request, build_opener

import pytest

from tests.load.client import answer_for, parse_step
from tests.services import wait_until

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[1]
TUTORIAL = (ROOT / "docs" / "tutorial.md").read_text()
SERVED = 600  # seconds: a hang guard, ten times what `make demo` takes here on a built table
SERVICES = ("DATABASE_URL", "CELERY_BROKER_URL", "CELERY_RESULT_BACKEND", "CACHE_URL", "DEMO_TABLE")


def blocks(language: str) -> list[list[str]]:
    return [[line for line in b.splitlines() if line.strip()]
            for b in re.findall(rf"```{language}\n(.*?)```", TUTORIAL, re.S)]


def free_port() -> int:
    import socket  # noqa: PLC0415

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Demo:
    """`make demo` (or another target that serves) running in its own process group, its output read line by
    line."""

    def __init__(self, env: dict, target: str = "demo"):
        self.target = target
        self.proc = subprocess.Popen(["make", target], cwd=ROOT, env=env, stdout=subprocess.PIPE,
                                     stderr=subprocess.STDOUT, text=True, start_new_session=True)
        self.lines: list[str] = []
        self.reader = threading.Thread(target=self._read, daemon=True)
        self.reader.start()

    def _read(self):
        for line in self.proc.stdout:
            self.lines.append(line.rstrip("\n"))

    def tail(self) -> str:
        return "\n".join(self.lines[-40:])

    def wait_for(self, text: str, timeout: float) -> None:
        def printed():
            assert self.proc.poll() is None, f"make {self.target} stopped:\n" + self.tail()
            return any(text in line for line in self.lines)

        wait_until(printed, timeout, f"make {self.target} printing {text!r}", poll=0.2, detail=self.tail)

    def interrupt(self) -> int:
        """Ctrl-C as a terminal sends it: SIGINT to every process of the group; the exit status."""
        os.killpg(self.proc.pid, signal.SIGINT)
        try:
            return self.proc.wait(60)
        finally:
            self.reader.join(5)

    def group_alive(self) -> bool:
        try:
            os.killpg(self.proc.pid, 0)
        except ProcessLookupError:
            return False
        return True

    def kill(self):
        if self.group_alive():
            os.killpg(self.proc.pid, signal.SIGKILL)


def take_part(opener, link: str, answers=answer_for) -> str:
    """Step 2 as a browser posts it (tests/load/client.py reads each page's form, `answers` fills it in); the
    completion code."""
    page = opener.open(link, timeout=60).read().decode()
    rng = random.Random(7)
    for _ in range(100):
        step = parse_step(page)
        if step["kind"] == "done":
            return step["code"]
        fields, _ = answers(step, rng)
        body = urlencode([*fields, ("csrfmiddlewaretoken", step["csrf"])]).encode()
        page = opener.open(Request(urljoin(link, step["action"]), data=body), timeout=60).read().decode()
    raise AssertionError("the study did not end within 100 steps")


def log_in(opener, base: str, user: str, password: str, then: str) -> str:
    login = f"{base}/login/?next={then}"
    form = opener.open(login, timeout=60).read().decode()
    csrf = re.search(r'name="csrfmiddlewaretoken" value="([^"]+)"', form).group(1)
    body = urlencode({"username": user, "password": password, "csrfmiddlewaretoken": csrf}).encode()
    return opener.open(Request(login, data=body, headers={"Referer": login}), timeout=60).read().decode()


@pytest.fixture
def demo_env(demo_table, tmp_path):
    """The environment of a fresh machine's shell, with this run's built demo table as `make demo`'s."""
    tables = tmp_path / "tables"
    tables.mkdir()
    (tables / "demo").symlink_to(demo_table, target_is_directory=True)
    env = {k: v for k, v in os.environ.items() if k not in SERVICES and not k.startswith(("PYTEST", "DJANGO"))}
    port = free_port()
    env.update(VAR_DIR=str(tmp_path / "var"), TABLES_DIR=str(tables), DEMO_ADDR=f"127.0.0.1:{port}",
               PYTHONUNBUFFERED="1")  # each line as it is printed, as on a terminal
    return env, port


def test_the_tutorial_as_written_serves_takes_part_logs_in_stops_and_analyses(demo_env, tmp_path):
    env, port = demo_env
    clone, analyse = blocks("sh")
    assert clone[-1] == "make demo" and clone[0].startswith("git clone") and clone[1].startswith("cd ")
    printed = [line.replace("127.0.0.1:8000", f"127.0.0.1:{port}") for line in blocks("text")[0]]

    demo = Demo(env)
    try:
        demo.wait_for("Dashboard:", SERVED)
        start = next(i for i, line in enumerate(demo.lines) if line.startswith("Demo study"))
        assert demo.lines[start:start + len(printed)] == printed  # the links, word for word
        user, password = re.search(r"login: (\S+) / (\S+)\)", printed[-1]).groups()
        base = f"http://127.0.0.1:{port}"
        participant = printed[2].split()[-1]
        demo.wait_for("Quit the server with", 60)  # runserver is listening

        code = take_part(build_opener(HTTPCookieProcessor(CookieJar())), participant)
        assert code

        researcher = build_opener(HTTPCookieProcessor(CookieJar()))
        dashboard = log_in(researcher, base, user, password, "/dashboard/demo/")
        assert "Conditions" in dashboard and "demo" in dashboard
        designer = researcher.open(f"{base}/precompute/design/", timeout=60).read().decode()
        assert ">Build</button>" in designer

        assert demo.interrupt() in (0, 2, 130, -signal.SIGINT)  # however make reports an interrupted recipe
        wait_until(lambda: not demo.group_alive(), 30, "every process of make demo ending after Ctrl-C")
    finally:
        demo.kill()

    assert analyse == [".venv/bin/python manage.py analyze my-first",
                       ".venv/bin/python manage.py export_study my-first wide --out my-first.csv"]
    for line in analyse:
        words = line.replace("my-first.csv", str(tmp_path / "demo.csv")).replace("my-first", "demo").split()
        done = subprocess.run(words, cwd=ROOT, env=env, capture_output=True, text=True, timeout=SERVED)
        assert done.returncode == 0, done.stdout + done.stderr
    report = Path(env["VAR_DIR"]) / "analysis" / "demo"
    assert any(report.glob("*.html")), sorted(report.rglob("*"))
    wide = (tmp_path / "demo.csv").read_text().splitlines()
    assert len(wide) == 2 and code in wide[1]  # the header and the one participant, with their code
