"""``import-table``: a table folder made into the platform's table, with the robot it carries.

The round trip the issue asks for (the delivery gridworld's table written out and imported back teaches the same
sequences, test set and ideal-user matrix, bit for bit); distances worked by hand for a folder with recorded
paths and one without; refusals that write nothing; and the robot found by name from the table alone, by a fresh
process, and from TEACHING_TABLES, where a broken table is one line and every other robot keeps working."""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from teaching import teach
from teaching.__main__ import main
from teaching.api import TableError, TrajectoryTable
from teaching.core.domain import domain_names, get_domain, unregister
from teaching.importing import TableFolderError, registry
from teaching.importing.convert import import_table
from teaching.importing.export import export_table
from tests.teaching.importing.test_table_folder import PHI, TOML, with_paths, write

ROOT = Path(__file__).resolve().parents[3]


@pytest.fixture(autouse=True)
def _forget_imported_robots():
    """Each test's imported robots leave the registry with it (names are unique within a process)."""
    before = set(domain_names())
    yield
    for name in set(domain_names()) - before:
        unregister(name)
        registry.forget(name)


def _teach(table: Path, out: Path) -> dict:
    assert teach.main(["--table", str(table), "--out", str(out), "--no-progress"]) == 0
    return {p.name: p.read_bytes() for p in sorted(out.glob("*.json"))}


def test_the_gridworld_table_imported_back_teaches_the_same_bit_for_bit(gridworld_table, gridworld_teach, tmp_path):
    """Export, import, teach: the sequences (all but the table's own identity), the test set and the ideal-user
    matrix are the built table's, byte for byte."""
    built = TrajectoryTable.load(gridworld_table)
    imported = import_table(export_table(built, tmp_path / "folder"), tmp_path / "imported")
    assert imported.domain.name == "gridworld-export" and imported.meta["sampler"] == "imported"
    for name in ("thetas", "env_ids", "features", "strategy", "d_euclid"):
        assert np.asarray(getattr(imported, name)).tobytes() == np.asarray(getattr(built, name)).tobytes(), name
    assert np.array_equal(imported.env_class, built.env_class)
    assert imported.states(slice(None), slice(None)).tobytes() == \
        np.asarray(built.states(slice(None), slice(None)), np.float64).tobytes()

    ours = {p.name: p.read_bytes() for p in sorted(gridworld_teach.glob("*.json"))}  # the run's own teach output
    theirs = _teach(tmp_path / "imported", tmp_path / "teach")
    assert set(ours) == {"examples_per_cluster.json", "matrix.json", "sequences.json", "test_set.json"}
    assert theirs["test_set.json"] == ours["test_set.json"]
    assert theirs["matrix.json"] == ours["matrix.json"]
    assert theirs["examples_per_cluster.json"] == ours["examples_per_cluster.json"]
    a, b = json.loads(ours["sequences.json"]), json.loads(theirs["sequences.json"])
    assert a.pop("table")["path"] != b.pop("table")["path"]  # the one difference: which table it was
    assert a == b and len(a["conditions"]) == 9 and all(a["conditions"].values())
    assert len(json.loads(ours["test_set.json"])) == 4  # a real test set, one per tested strategy


def test_an_import_is_deterministic_and_content_hashed(tmp_path):
    folder = with_paths(tmp_path / "hand")
    first = import_table(folder, tmp_path / "a").meta["content_hash"]
    unregister("hand")
    registry.forget("hand")
    assert import_table(folder, tmp_path / "b").meta["content_hash"] == first
    assert TrajectoryTable.load(tmp_path / "b").meta["content_hash"] == first


def test_distances_by_hand_with_recorded_paths(tmp_path):
    """Objective k's path moves (k + 1, 1) m a step for 2 steps; scale 2 m.  Objective 1's path is (1, 0) m from
    θ*'s after step 1 and (2, 0) after step 2: distance (1/2 + 2/2) / 2 = 0.75; objective 2's is twice that."""
    table = import_table(with_paths(tmp_path / "hand"), tmp_path / "t")
    assert np.allclose(table.d_euclid, [[0, 0.75, 1.5]] * 3, rtol=0, atol=1e-7)  # float32: ~1e-7 of 1.5
    domain = table.domain
    assert domain.trajectory_shape == (3, 2) and domain.state_scale == (2.0, 2.0)
    payload = domain.scene_payload(11)
    # x: 0 .. objective 2's 6 m, y: 0 .. the agent's 5 m, each with 8 % of the larger span (6 m) around it
    assert np.allclose(payload["bounds"], [-0.48, 6.48, -0.48, 5.48], rtol=0, atol=1e-12)
    assert payload["agents"] == [[[5.0, 5.0]] * 3] and payload["dt"] == 1.0 and payload["unit"] == "m"
    assert domain.path_rows(table.states(1, 2)) == [[0.0, 0.0], [3.0, 1.0], [6.0, 2.0]]


def test_distances_by_hand_from_features_alone(tmp_path):
    """No recorded paths: two trajectories are as far apart as their features.  Environment 10's φ are (1, 3),
    (3, 1), (2, 2): |(2, -2)| = 2.828..., |(1, -1)| = 1.414...; environments 11 and 12's (0, 5), (5, 0), (2, 2):
    |(5, -5)| = 7.071..., |(2, -3)| = 3.605...  The folder's own distances are left out to be worked out."""
    folder = write(tmp_path / "hand")
    arrays = dict(np.load(folder / "features.npz"))
    np.savez(folder / "features.npz", **{k: v for k, v in arrays.items() if k != "distance"})
    table = import_table(folder, tmp_path / "t")
    want = [[0, 8 ** 0.5, 2 ** 0.5], [0, 50 ** 0.5, 13 ** 0.5], [0, 50 ** 0.5, 13 ** 0.5]]
    assert np.allclose(table.d_euclid, want, rtol=1e-6, atol=0)  # float32 keeps ~7 digits of each
    assert np.array_equal(table.features, PHI) and table.thetas.tolist() == [[-1, 0], [0, -1], [-1, -1]]
    domain = table.domain
    assert domain.class_names == ("narrow", "other") and domain.test_clusters == (0,)
    assert domain.cluster_names == ("narrow: squeeze", "none of these")
    assert table.strategy.tolist() == [[0, 1, 1], [1, 1, 1], [1, 1, 1]]  # the format's -1 is "none of these"
    assert domain.environment_class(np.array([12, 10])).tolist() == [1, 0]
    with pytest.raises(ValueError, match="environment 13 is not one of the imported robot 'hand'"):
        domain.environment_class(np.array([13]))


def test_a_refused_import_writes_nothing(tmp_path, capsys):
    taken = write(tmp_path / "taken", TOML.replace('name = "hand"', 'name = "gridworld"'))
    before = sorted(tmp_path.rglob("*"))
    with pytest.raises(TableFolderError, match="table.toml: name: 'gridworld' is already a robot's name here"):
        import_table(taken, tmp_path / "out")
    broken = with_paths(tmp_path / "broken", t=np.array([0.0, 2.0, 1.0]))
    before = sorted(tmp_path.rglob("*"))
    assert main(["import-table", str(broken), "--out", str(tmp_path / "out")]) == 1
    said = capsys.readouterr().out
    assert said.startswith("error: paths.npz: t[2]") and said.count("\n") == 1
    assert sorted(tmp_path.rglob("*")) == before  # no table, no hidden half-written one
    (tmp_path / "full").mkdir()
    (tmp_path / "full" / "x").write_text("")
    with pytest.raises(TableFolderError, match="full: not empty"):
        import_table(write(tmp_path / "hand"), tmp_path / "full")


def test_the_command_imports_and_the_table_works_with_teach_and_info(gridworld_tiny_table, tmp_path, capsys):
    folder = export_table(TrajectoryTable.load(gridworld_tiny_table), tmp_path / "folder", name="tiny-yards")
    assert main(["import-table", str(folder), "--out", str(tmp_path / "t")]) == 0
    said = capsys.readouterr().out
    assert "table: domain=tiny-yards preset=tiny-yards envs=48 thetas=24" in said
    assert "imported 48 environments x 24 objectives" in said
    assert main(["info", str(tmp_path / "t")]) == 0
    capsys.readouterr()
    assert main(["check-domain", "tiny-yards"]) == 2  # no planner here to check
    assert "tiny-yards has no presets to plan" in capsys.readouterr().err


def test_a_fresh_process_finds_the_robot_from_the_table_alone(tmp_path):
    import_table(with_paths(tmp_path / "hand"), tmp_path / "t")
    code = ("from teaching.api import TrajectoryTable, domain_names\n"
            f"t = TrajectoryTable.load({str(tmp_path / 't')!r})\n"
            "print(t.domain.name, t.domain.title, 'hand' in domain_names())")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert done.stdout.split() == ["hand", "A", "robot", "worked", "by", "hand", "True"], done.stderr


def test_an_edited_robot_is_refused_like_a_table_built_under_other_constants(tmp_path):
    import_table(with_paths(tmp_path / "hand"), tmp_path / "t")
    unregister("hand")
    registry.forget("hand")
    spec = tmp_path / "t" / "robot" / "robot.json"
    spec.write_text(spec.read_text().replace('"min_option_distance": 0.5', '"min_option_distance": 0.1'))
    with pytest.raises(TableError, match="was built with other world constants"):
        TrajectoryTable.load(tmp_path / "t")


def test_teaching_tables_registers_the_good_and_one_line_for_the_broken(tmp_path):
    """The site's and workers' way: TEACHING_TABLES names a folder of tables.  A damaged robot.json is one
    line in TABLE_ERRORS; the good table's robot and every built-in robot are there."""
    tables = tmp_path / "tables"
    import_table(with_paths(tmp_path / "hand"), tables / "good")
    import_table(write(tmp_path / "other", TOML.replace('name = "hand"', 'name = "other"')), tables / "bad")
    (tables / "bad" / "robot" / "robot.json").write_text('{"format": 1, "name": "other"')
    code = ("from teaching.api import domain_names, get_domain\n"
            "from teaching.importing.registry import TABLE_ERRORS\n"
            "print(sorted(domain_names()))\n"
            "print(len(TABLE_ERRORS), TABLE_ERRORS[0])\n"
            "print(get_domain('gridworld').name, get_domain('hand').title)")
    env = {**os.environ, "TEACHING_TABLES": str(tables)}
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, env=env,
                          timeout=120)
    lines = done.stdout.splitlines()
    assert "'hand'" in lines[0] and "'other'" not in lines[0] and "'gridworld'" in lines[0], done.stderr
    assert lines[1].startswith("1 ") and "bad/robot/robot.json: unreadable" in lines[1]
    assert lines[2] == "gridworld A robot worked by hand"


def test_a_name_is_one_robot(tmp_path):
    import_table(with_paths(tmp_path / "hand"), tmp_path / "t")
    assert get_domain("hand").title == "A robot worked by hand"
    other = write(tmp_path / "again", TOML.replace("A robot worked by hand", "Another"))
    with pytest.raises(TableFolderError, match="'hand' is already a robot's name here"):
        import_table(other, tmp_path / "t2")
