"""`python -m teaching sheet`: the contact sheet of every training example and test option.

The tiny table is the run's shared one (tests/conftest.py tiny_table).  Its teach output has no test set (too few
environments per cluster), so a synthetic table (as in test_teach_cli.py) covers the 6 tests × 4
options.  No Django."""
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from PIL import Image

from teaching.__main__ import main
from teaching.core.sheet import make_sheet
from teaching.domains.driving.synthetic import synthetic_table
from teaching.teach import main as teach_main

ROOT = Path(__file__).resolve().parents[3]


def run(*args, timeout=300):
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.run([sys.executable, "-m", "teaching", *args], cwd=ROOT, env=env, capture_output=True,
                          text=True, timeout=timeout)


def taught(table_dir: Path, out: Path) -> Path:
    """Run teach; on the tiny table it exits 2 (no test set) after writing everything else."""
    teach_main(["--table", str(table_dir), "--out", str(out), "--no-progress"])
    assert (out / "sequences.json").exists() and (out / "test_set.json").exists()
    return out


@pytest.fixture(scope="module")
def tiny(tiny_table, tmp_path_factory):
    return tiny_table, taught(tiny_table, tmp_path_factory.mktemp("sheet-tiny") / "teach")


@pytest.fixture(scope="module")
def syn(tmp_path_factory):
    root = tmp_path_factory.mktemp("sheet-syn")
    synthetic_table(200, 40, n_candidates=6, seed=8).save(root / "table")
    return root / "table", taught(root / "table", root / "teach")


def expected_panels(teach: Path) -> tuple[int, int]:
    seqs = json.loads((teach / "sequences.json").read_text())["conditions"]
    tests = json.loads((teach / "test_set.json").read_text())
    return sum(len(c["env_ids"]) for c in seqs.values()), (0 if isinstance(tests, dict) else len(tests))


def assert_png(path: Path, min_bytes=50_000):
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert path.stat().st_size > min_bytes
    w, h = Image.open(path).size
    assert 1500 < w < 8000 and 500 < h < 12000, (w, h)


def assert_clean_error(code, err, *needles):
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and "Traceback" not in err, err
    for needle in needles:
        assert needle in err, err


@pytest.mark.slow
def test_tiny_sheet_through_the_real_entry_point(tiny, tmp_path):
    table, teach = tiny
    out = tmp_path / "sheet.png"
    proc = run("sheet", "--table", str(table), "--teach", str(teach), "--out", str(out))
    assert proc.returncode == 0, proc.stderr
    n_train, n_tests = expected_panels(teach)
    assert n_tests == 0 and n_train > 0  # tiny: no test set; the sheet says so and still draws training
    assert f"drew {n_train} panels -> {out}" in proc.stdout
    assert "note: the teach output has no test set" in proc.stdout
    assert_png(out)


def test_every_example_and_option_is_drawn(syn, tmp_path):
    table, teach = syn
    n_train, n_tests = expected_panels(teach)
    assert n_tests == 6
    n, no_tests = make_sheet(table_dir=table, teach_dir=teach, out=tmp_path / "deep" / "sheet.png")
    assert no_tests is None
    assert n == n_train + 4 * n_tests
    assert_png(tmp_path / "deep" / "sheet.png")


def test_columns_wrap_long_sequences(syn, tmp_path, capsys):
    table, teach = syn
    n_train, n_tests = expected_panels(teach)
    assert main(["sheet", "--table", str(table), "--teach", str(teach), "--out", str(tmp_path / "s.png"),
                 "--columns", "2", "--dpi", "40"]) == 0
    assert f"drew {n_train + 4 * n_tests} panels" in capsys.readouterr().out
    w, h = Image.open(tmp_path / "s.png").size
    assert h > w  # 2 columns: many more rows than columns


def test_missing_table(syn, tmp_path, capsys):
    code = main(["sheet", "--table", str(tmp_path / "nope"), "--teach", str(syn[1]), "--out", str(tmp_path / "s.png")])
    assert_clean_error(code, capsys.readouterr().err, "no trajectory table")
    assert not (tmp_path / "s.png").exists()


def test_missing_teach_dir(syn, tmp_path, capsys):
    code = main(["sheet", "--table", str(syn[0]), "--teach", str(tmp_path / "nope"), "--out", str(tmp_path / "s.png")])
    assert_clean_error(code, capsys.readouterr().err, "no teach output", "sequences.json is missing")


def test_invalid_teach_dir(syn, tmp_path, capsys):
    bad = tmp_path / "bad"
    shutil.copytree(syn[1], bad)
    (bad / "sequences.json").write_text("{not json")
    code = main(["sheet", "--table", str(syn[0]), "--teach", str(bad), "--out", str(tmp_path / "s.png")])
    assert_clean_error(code, capsys.readouterr().err, "not valid JSON")
    (bad / "sequences.json").write_text(json.dumps({"table": {}, "conditions": {"x": {"env_ids": [-1]}}}))
    code = main(["sheet", "--table", str(syn[0]), "--teach", str(bad), "--out", str(tmp_path / "s.png")])
    assert_clean_error(code, capsys.readouterr().err, "not in the table")


@pytest.mark.slow
def test_teach_dir_from_another_table(tiny, syn, tmp_path):
    proc = run("sheet", "--table", str(tiny[0]), "--teach", str(syn[1]), "--out", str(tmp_path / "s.png"))
    assert_clean_error(proc.returncode, proc.stderr, "made from another table")
    assert proc.stdout == "" and not (tmp_path / "s.png").exists()


def test_out_must_be_a_png(syn, tmp_path, capsys):
    code = main(["sheet", "--table", str(syn[0]), "--teach", str(syn[1]), "--out", str(tmp_path / "s.pdf")])
    assert_clean_error(code, capsys.readouterr().err, ".png")
