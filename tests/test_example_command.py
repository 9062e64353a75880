"""The worked example's one command (examples/hallway/README.md), run as a researcher runs it on a fresh
machine: `make example` writes the robot's folder with its own planner, imports it, teaches, makes the study
and serves it on the embedded default; a participant takes part through the printed link as a browser posts
the forms, up to the completion code; Ctrl-C stops the site.  A second run reuses every output."""
from __future__ import annotations

import os
from http.cookiejar import CookieJar
from urllib.request import HTTPCookieProcessor, build_opener

import pytest

from tests.load.client import answer_for
from tests.test_tutorial import SERVICES, Demo, free_port, take_part

pytestmark = pytest.mark.slow
SERVED = 600  # seconds: a hang guard, ten times what the example's first run takes here


def hallway_answer(step: dict, rng) -> tuple[list, dict]:
    """The load harness's answers, but the attention check's right answer is the imported robot's own."""
    if step["kind"] == "attention":
        return [("goals", "robot")], {"passed": True}
    return answer_for(step, rng)


def test_make_example_imports_the_robot_serves_its_study_and_a_participant_finishes(tmp_path):
    env = {k: v for k, v in os.environ.items() if k not in SERVICES and not k.startswith(("PYTEST", "DJANGO"))}
    port = free_port()
    env.update(VAR_DIR=str(tmp_path / "var"), EXAMPLE_ADDR=f"127.0.0.1:{port}", PYTHONUNBUFFERED="1")
    for run in ("first", "again"):
        example = Demo(env, target="example")
        try:
            example.wait_for("Quit the server with", SERVED)  # runserver's line once it listens
            link = next(line for line in example.lines if line.startswith("take part:")).split()[-1]
            assert link == f"http://127.0.0.1:{port}/s/hallway/"
            said = "\n".join(example.lines)
            if run == "first":
                assert "imported 300 environments x 80 objectives" in said and "4 tests" in said, said
                code = take_part(build_opener(HTTPCookieProcessor(CookieJar())), link, hallway_answer)
                assert code
            else:  # every output kept; the study, with its participant, kept as it is
                assert "imported" not in said and "keeping the existing study 'hallway'" in said, said
            assert example.interrupt() in (0, -2, 130, 2)
        finally:
            example.kill()
    assert (tmp_path / "var" / "tables" / "hallway" / "robot" / "robot.json").is_file()
