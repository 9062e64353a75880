"""`python -m teaching build|info` as a researcher runs it: summary on success, exit 2 and one
'error: ...' line (no traceback) on bad input."""
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from teaching.core.table import TrajectoryTable
from tests.builds import build_output

ROOT = Path(__file__).resolve().parents[2]


def run(*args, timeout=300):
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.run([sys.executable, "-m", "teaching", *args], cwd=ROOT, env=env, capture_output=True,
                          text=True, timeout=timeout)


@pytest.fixture
def here(capsys):
    """`python -m teaching ARGS` run as main(ARGS) in this process, the function the entry point exits with: the
    same exit code, stdout and stderr (as a CompletedProcess) without starting an interpreter for each bad input.
    The real entry point is run by the builds above and by test_unknown_preset."""
    from teaching.__main__ import main  # noqa: PLC0415

    def run_here(*args):
        try:
            code = main(list(args))
        except SystemExit as e:  # argparse's own errors
            code = e.code
        out, err = capsys.readouterr()
        return subprocess.CompletedProcess(["python", "-m", "teaching", *args], code, out, err)

    return run_here


def assert_clean_error(proc, *needles):
    assert proc.returncode == 2, (proc.stdout, proc.stderr)
    assert "Traceback" not in proc.stderr and "Traceback" not in proc.stdout
    assert "error:" in proc.stderr
    for needle in needles:
        assert needle in proc.stderr, proc.stderr


@pytest.mark.slow
def test_build_tiny_then_info(tiny_table):
    # the run's shared tiny table, built by `python -m teaching build --preset tiny` (tests/conftest.py): what that
    # command printed (it exited 0, or the fixture raised with its stderr)
    out, stdout = tiny_table, build_output(tiny_table)
    assert "table: domain=driving preset=tiny envs=48 thetas=24" in stdout
    assert "min d_reward: 0 (must be >= 0)" in stdout
    assert "theta* strategies per cluster:" in stdout
    # the stratified sample puts 12 environments in each class
    assert "environments per class: merging 12, braking 12, tailgating 12, other 12" in stdout
    assert "built 1,152 trajectories" in stdout  # 48 x 24
    assert (out / "meta.json").exists() and (out / "features.npy").exists()
    info = run("info", str(out))
    assert info.returncode == 0, info.stderr
    # info prints the same summary as the build (same table, same hash)
    assert info.stdout.strip() == stdout.strip().rsplit("\n", 1)[0].strip()


def test_unknown_preset():
    assert_clean_error(run("build", "--preset", "huge", "--out", "/tmp/never-written-teaching-table"),
                       "unknown preset", "tiny")
    assert not Path("/tmp/never-written-teaching-table").exists()


@pytest.mark.parametrize("n", ["1", "0", "-3"])
def test_too_few_thetas(tmp_path, n, here):
    assert_clean_error(here("build", "--preset", "tiny", "--out", str(tmp_path / "t"), "--thetas", n), "--thetas")
    assert not (tmp_path / "t").exists()


def test_unwritable_output(tmp_path, here):
    blocker = tmp_path / "a-file"
    blocker.write_text("x")
    assert_clean_error(here("build", "--preset", "tiny", "--out", str(blocker / "table")), "cannot write")


def test_info_on_a_missing_table(tmp_path, here):
    assert_clean_error(here("info", str(tmp_path / "missing")), "no trajectory table")


def test_info_on_an_altered_table(tmp_path, here):
    (tmp_path / "meta.json").write_text('{"world": "not this world"}')
    assert_clean_error(here("info", str(tmp_path)), "other world constants")


@pytest.mark.slow
def test_build_with_another_theta_star(tmp_path):
    """θ* is a parameter of the build: stored as theta 0 and in the table's meta, the preset renamed."""
    out = tmp_path / "star"
    proc = run("build", "--preset", "tiny", "--out", str(out), "--thetas", "8", "--theta-star=-32,-0.2,-1,-0.1,-0.5")
    assert proc.returncode == 0, proc.stderr
    assert "theta*: [-32.0, -0.2, -1.0, -0.1, -0.5]" in proc.stdout
    table = TrajectoryTable.load(out)
    assert np.array_equal(table.thetas[0], [-32, -0.2, -1, -0.1, -0.5])
    meta = json.loads((out / "meta.json").read_text())
    assert meta["theta_star"] == [-32.0, -0.2, -1.0, -0.1, -0.5]
    assert meta["preset"].startswith("tiny-48x8-log-uniform-s0-star")
    # the other thetas are drawn around this θ* (log-uniform: within a decade of each weight)
    ratio = np.asarray(table.thetas[1:]) / np.asarray(table.thetas[0])
    assert ratio.min() >= 0.1 and ratio.max() <= 10


@pytest.mark.parametrize("value, needle", [
    ("-1,-2,-3", "needs one weight per feature (5), got 3"),
    ("-64,-0.1,-1,-0.1,0", "must be a negative number"),
    ("-64,-0.1,-1,-0.1,nan", "must be a negative number"),
    ("-64,-0.1,x,-0.1,-0.5", "5 numbers separated by commas"),
])
def test_bad_theta_star(tmp_path, value, needle, here):
    assert_clean_error(here("build", "--preset", "tiny", "--out", str(tmp_path / "t"), f"--theta-star={value}"),
                       "--theta-star", needle)
    assert not (tmp_path / "t").exists()


def test_the_theta_star_help_names_every_registered_domains_features(capsys):
    """The help is written from the registry, so a new domain's features are listed without an edit here."""
    from teaching.__main__ import main  # noqa: PLC0415
    from teaching.core.domain import domain_names, get_domain  # noqa: PLC0415
    from tests.teaching import small_grid_domain as small  # noqa: PLC0415

    with small.registered():
        with pytest.raises(SystemExit):
            main(["build", "--help"])
        names = (*domain_names(), small.NAME)
        listed = {name: ", ".join(f.replace("_", " ") for f in get_domain(name).feature_names) for name in names}
    assert small.NAME in names
    text = " ".join(capsys.readouterr().out.split()).replace("- ", "-")  # argparse wraps lines at hyphens
    for name, features in listed.items():
        assert f"{name}: {features}" in text, name
