"""The teaching core as a package others install: `pip install .` of this repository gives `import teaching`,
its full API and the `teaching` command, in an environment with no Django (pyproject.toml's [project])."""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
UV = Path(sys.executable).parent / "uv"  # `make venv` installs it; it installs from its cache, in seconds


def _run(args, **kwargs) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV", "DJANGO_SETTINGS_MODULE")}
    return subprocess.run([str(a) for a in args], capture_output=True, text=True, env=env, timeout=600, **kwargs)


@pytest.mark.slow
def test_the_core_installs_and_runs_without_django(tmp_path, tiny_table):
    # what a wheel is built from, copied, so that the build writes nothing into the checkout
    source = tmp_path / "source"
    source.mkdir()
    for name in ("pyproject.toml", "README.md", "LICENSE"):
        shutil.copy(ROOT / name, source / name)
    shutil.copytree(ROOT / "teaching", source / "teaching", ignore=shutil.ignore_patterns("__pycache__"))
    venv = tmp_path / "venv"
    made = _run([UV, "venv", "--quiet", "--python", sys.executable, venv])
    assert made.returncode == 0, made.stderr
    # the pins as constraints: the versions this suite runs on, which uv's cache already holds
    installed = _run([UV, "pip", "install", "--quiet", "--python", venv / "bin" / "python", source,
                      "--constraint", ROOT / "requirements.txt"])
    assert installed.returncode == 0, installed.stderr

    python, outside = venv / "bin" / "python", tmp_path  # run away from the checkout: only the installed copy
    probe = _run([python, "-c", "import importlib.util, teaching, teaching.api as api; "
                  "print(importlib.util.find_spec('django') is None, len(api.__all__), teaching.__file__)"],
                 cwd=outside)
    assert probe.returncode == 0, probe.stderr
    no_django, n_names, where = probe.stdout.split()
    assert no_django == "True" and where.startswith(str(venv)) and int(n_names) > 50

    helped = _run([venv / "bin" / "teaching", "--help"], cwd=outside)
    assert helped.returncode == 0, helped.stderr
    assert all(sub in helped.stdout for sub in ("build", "info", "teach", "sheet", "check-domain", "check-table",
                                                "export-table"))
    info = _run([venv / "bin" / "teaching", "info", tiny_table], cwd=outside)
    assert info.returncode == 0, info.stderr
    assert "domain=driving preset=tiny envs=48 thetas=24" in info.stdout
    # the shipped world files are package data: a grid world from a file loads from the installed copy
    worlds = _run([python, "-c", "from teaching.domains import WORLDS; print(sorted(p.name for p in "
                   "WORLDS.glob('*.toml')))"], cwd=outside)
    assert worlds.stdout.strip() == "['skateboard.toml', 'taxi.toml', 'two-goal.toml']", worlds.stderr
    # and is checked against its schema, package data too
    taxi = _run([python, "-c", "import teaching.domains; from teaching.core.domain import get_domain; "
                 "print(get_domain('taxi').n_environments)"], cwd=outside)
    assert taxi.returncode == 0 and taxi.stdout.strip() == "25600", taxi.stderr
    # a table folder is checked against the format's schema, package data too
    folder = outside / "folder"
    exported = _run([venv / "bin" / "teaching", "export-table", tiny_table, "--out", folder], cwd=outside)
    assert exported.returncode == 0, exported.stderr
    checked = _run([venv / "bin" / "teaching", "check-table", folder], cwd=outside)
    assert checked.returncode == 0 and "48 environments x 24 objectives" in checked.stdout, checked.stdout
