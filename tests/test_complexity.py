"""The functions a newcomer reads first stay small enough to read: each of these has a cyclomatic complexity
of at most 10 (McCabe's, as ruff's C901 counts it), so that a new kind of step or page is added in its own
module rather than as one more branch here."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
MOST = 10
# function -> the module that holds it
READ_FIRST = {
    "step_context": "studyapp/views.py",  # what every participant page is given
    "run_participant": "studyapp/analysis/simulate.py",  # a simulated participant's walk
    "steps_for": "studyapp/flow.py",  # the participant's steps
    "parse_world": "teaching/domains/_grid/worldfile.py",  # what a world file becomes
}


def too_complex(path: str, most: int) -> dict[str, str]:
    """function name -> ruff's message, for each function of `path` above `most`."""
    proc = subprocess.run([sys.executable, "-m", "ruff", "check", "--isolated", "--select", "C901", "--config",
                           f"lint.mccabe.max-complexity = {most}", "--output-format", "json", path],
                          cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert proc.returncode in (0, 1), proc.stderr
    found = json.loads(proc.stdout)
    return {f["message"].split("`")[1]: f["message"] for f in found}


@pytest.mark.parametrize("function, path", READ_FIRST.items())
def test_the_functions_a_newcomer_reads_first_are_small(function, path):
    assert function in (ROOT / path).read_text()
    assert function not in too_complex(path, MOST)


def test_the_count_finds_a_complex_function():
    """The check above is only as good as its count: the flow's recording is known to be above 5."""
    assert "record" in too_complex("studyapp/flow.py", 5)
