"""The command line: full run on a small saved table, and one-line errors with exit status 2."""
import json
import subprocess
import sys

import numpy as np
import pytest

from teaching.core.selection import CONDITIONS
from teaching.core.table import TrajectoryTable
from teaching.domains.driving.synthetic import synthetic_table
from teaching.teach import main


@pytest.fixture(scope="module")
def saved(tmp_path_factory):
    path = tmp_path_factory.mktemp("tables") / "syn"
    synthetic_table(200, 40, n_candidates=6, seed=8).save(path)
    return path


def test_full_run_writes_every_output(saved, tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["--table", str(saved), "--out", str(out), "--no-progress"]) == 0
    seqs = json.loads((out / "sequences.json").read_text())
    assert tuple(seqs["conditions"]) == CONDITIONS
    table = TrajectoryTable.load(saved)
    ids = set(table.env_ids.tolist())
    assert all(set(c["env_ids"]) <= ids for c in seqs["conditions"].values())
    assert len(seqs["conditions"]["random"]["env_ids"]) == 8
    assert len(seqs["hyperparameters"]["det-euclidean"]["sweep"]) == 11
    tests = json.loads((out / "test_set.json").read_text())
    assert len(tests) == 6 and all(len(t["options"]) == 4 for t in tests)
    matrix = json.loads((out / "matrix.json").read_text())
    # the paper's 8 x 7 with the hierarchical learner's row and column; + the two coverage rows
    assert np.array(matrix["matrix"]).shape == (9, 8) and matrix["user_names"][-1] == "hierarchical"
    assert np.array(matrix["extended_matrix"]).shape == (11, 8)
    # each user's P(option) in the 6 tests after each sequence, for a study's model-based pilot
    predicted = matrix["predicted"]
    assert set(predicted["choice"]) == set(matrix["user_names"]) and len(predicted["theta_star_option"]) == 6
    assert all(np.array(p).shape == (6, 4) and np.allclose(np.sum(p, axis=1), 1, atol=1e-5)
               for by_name in predicted["choice"].values() for p in by_name.values())
    assert set(predicted["choice"]["exact"]) == set(matrix["extended_sequence_names"])
    # the hierarchical learner is taught like the others but is no condition of the paper's study:
    # the test set keeps clear of the nine conditions' training, as it did before that learner
    assert "hierarchical" in seqs["model_sequences"] and "hierarchical" not in seqs["conditions"]
    trained = {e for c in seqs["conditions"].values() for e in c["env_ids"]}
    assert not trained & {t["env_id"] for t in tests}
    grids = json.loads((out / "examples_per_cluster.json").read_text())["grids"]
    assert np.array(grids["random"]).sum() == 8
    for png in ("sim_users.png", "examples_shown.png"):
        assert (out / png).read_bytes()[:4] == b"\x89PNG"


def _err(argv, capsys):
    code = main(argv)
    err = capsys.readouterr().err
    return code, err


@pytest.mark.parametrize("extra, message", [
    (["--approx-star", "det-manhattan"], "unknown learner model 'det-manhattan'"),
    (["--hyper", "det-manhattan=1"], "unknown learner model 'det-manhattan'"),
    (["--hyper", "det-euclidean=0"], "must be a finite number > 0"),
    (["--hyper", "prob-reward=-3"], "must be a finite number > 0"),
    (["--hyper", "prob-reward"], "MODEL=VALUE"),
])
def test_bad_model_or_hyperparameter(saved, tmp_path, capsys, extra, message):
    code, err = _err(["--table", str(saved), "--out", str(tmp_path / "o"), *extra], capsys)
    assert code == 2 and message in err and err.startswith("error:") and "Traceback" not in err


def test_table_without_theta_star(tmp_path, capsys):
    t = synthetic_table(20, 10, seed=1)
    t.thetas = t.thetas[1:].copy()
    for name in ("features", "strategy", "d_euclid", "controls"):
        setattr(t, name, np.ascontiguousarray(getattr(t, name)[:, 1:]))
    t.save(tmp_path / "t")
    code, err = _err(["--table", str(tmp_path / "t"), "--out", str(tmp_path / "o")], capsys)
    assert code == 2 and "does not contain θ*" in err


def test_empty_environment_set(tmp_path, capsys):
    t = synthetic_table(20, 10, seed=1)
    for name in ("env_ids", "features", "strategy", "d_euclid", "controls"):
        setattr(t, name, np.ascontiguousarray(getattr(t, name)[:0]))
    t.save(tmp_path / "t")
    code, err = _err(["--table", str(tmp_path / "t"), "--out", str(tmp_path / "o")], capsys)
    assert code == 2 and "no environments" in err


@pytest.mark.parametrize("entry", [["teaching", "teach"], ["teaching.teach"]])
def test_missing_table_and_real_entry_point(tmp_path, entry):
    """`python -m teaching teach`, and the older spelling saved outputs still quote."""
    proc = subprocess.run([sys.executable, "-m", *entry, "--table", str(tmp_path / "nope"),
                           "--out", str(tmp_path / "o")], capture_output=True, text=True)
    assert proc.returncode == 2
    assert "no trajectory table" in proc.stderr and "Traceback" not in proc.stderr


def test_the_one_command_writes_what_the_module_wrote(saved, tmp_path, capsys):
    """`python -m teaching teach` is the teach command itself: the same files, byte for byte, as the older
    `python -m teaching.teach`; and `python -m teaching --help` names every sub-command."""
    from teaching.__main__ import main as one_command  # noqa: PLC0415 (the module under test)

    argv = ["--table", str(saved), "--no-progress", "--selector", "scot"]
    assert main([*argv, "--out", str(tmp_path / "module")]) == 0
    assert one_command(["teach", *argv, "--out", str(tmp_path / "command")]) == 0
    written = sorted(p.name for p in (tmp_path / "module").iterdir())
    assert written == sorted(p.name for p in (tmp_path / "command").iterdir()) and "sequences.json" in written
    for name in written:
        assert (tmp_path / "module" / name).read_bytes() == (tmp_path / "command" / name).read_bytes(), name
    proc = subprocess.run([sys.executable, "-m", "teaching", "--help"], capture_output=True, text=True)
    assert proc.returncode == 0
    assert all(sub in proc.stdout for sub in ("build", "info", "teach", "sheet", "check-domain"))
