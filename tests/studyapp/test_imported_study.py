"""A study of an imported robot (docs/importing.md): built on a table made by import-table, served by a process
that had never heard of the robot (it finds it from the study's table), walked through by a participant, its
pages drawn by the top-down scene with nothing of the environments' ids or the objectives on them; and the
designer lists the imported table."""
from __future__ import annotations

import json

import numpy as np
import pytest
from django.test import Client

from precompute.tables import built_tables
from studyapp.models import StepKind
from studyapp.researcher.studies import build_study
from teaching.api import TrajectoryTable, domain_names
from teaching.core.domain import unregister
from teaching.importing import registry
from teaching.importing.convert import import_table
from teaching.importing.export import export_table
from tests.studyapp.test_stimuli import embedded, real_spec, walk

NAME = "yards-imported"


@pytest.fixture
def imported(gridworld_tiny_table, tmp_path):
    """The tiny gridworld table exported and imported back as the robot NAME, in a folder of tables; the robot
    leaves the registry afterwards."""
    folder = export_table(TrajectoryTable.load(gridworld_tiny_table), tmp_path / "folder", name=NAME)
    path = tmp_path / "tables" / NAME
    import_table(folder, path)
    yield path
    forget()


def forget():
    """As a fresh process: the robot not registered."""
    if NAME in domain_names():
        unregister(NAME)
    registry.forget(NAME)


def test_a_study_of_an_imported_robot_runs_in_a_process_that_never_saw_it(db, imported):
    table = TrajectoryTable.load(imported)
    study = build_study(real_spec(table, imported, slug="imported"))
    assert study.domain == NAME
    keys = set(table.domain.page_keys) | {"robot"}
    ids = {int(e) for e in table.env_ids}
    forget()
    assert study.running_problems() == []  # found from the study's own table
    forget()
    pages = list(walk(Client(), study, "imp-1"))
    assert [step.kind for _, step, _ in pages][-1] == StepKind.DONE
    for _, step, html in pages:
        assert "scenes/topdown.js" in html or step.kind not in (StepKind.TRAINING, StepKind.TEST)
        data = embedded(html)
        if step.kind == StepKind.TRAINING:
            assert set(data["env-data"]) == keys
        if step.kind == StepKind.TEST:
            assert set(data["scene-data"]) == keys - {"robot"} and sorted(data["option-robots"]) == list("ABCD")
        for payload in data.values():  # no environment id nor θ index in what the page's scripts read
            text = json.dumps(payload)
            assert '"env_id"' not in text and '"theta_index"' not in text
            assert not any(f'"{k}": {e}' in text for e in ids for k in ("env", "id"))
    participant = pages[-1][0]
    participant.refresh_from_db()
    assert participant.completed_at is not None


def test_the_designer_lists_an_imported_table_whose_robot_it_had_not_seen(imported):
    forget()
    listed = [t for t in built_tables(imported.parent) if t["domain"] == NAME]
    assert [t["path"] for t in listed] == [str(imported)]
    assert listed[0]["envs"] == 48 and listed[0]["thetas"] == 24


def test_a_study_whose_imported_table_is_gone_says_so_in_one_line(db, imported, tmp_path):
    table = TrajectoryTable.load(imported)
    study = build_study(real_spec(table, imported, slug="gone"))
    forget()
    imported.rename(tmp_path / "moved")
    problems = study.running_problems()
    assert len(problems) == 1 and f"Its robot '{NAME}' is not registered on this server" in problems[0]


def test_a_study_of_a_robot_with_nothing_to_show_is_refused_in_one_line(db, gridworld_tiny_table, tmp_path):
    """A table imported from features alone (no recorded paths, no videos) teaches and fits, but participants
    would see nothing: building a study on it is refused, naming what is missing."""
    folder = export_table(TrajectoryTable.load(gridworld_tiny_table), tmp_path / "folder", name="blind")
    toml = (folder / "table.toml").read_text()
    (folder / "table.toml").write_text(toml[:toml.index("[paths]")] + toml[toml.index("[[features]]"):])
    (folder / "paths.npz").unlink()
    table = import_table(folder, tmp_path / "blind")
    try:
        with pytest.raises(ValueError, match="'blind' has neither videos nor recorded paths to show") as err:
            build_study(real_spec(table, tmp_path / "blind", slug="blind"))
        assert "\n" not in str(err.value)
    finally:
        unregister("blind")
        registry.forget("blind")


def test_a_table_kept_although_suboptimal_says_so_on_the_dashboard(db, gridworld_tiny_table, tmp_path, staff_client):
    """keep_suboptimal = true is recorded in the table and shown on the study's dashboard page, with the
    check's counts; a study on an optimal table shows nothing of it."""
    folder = export_table(TrajectoryTable.load(gridworld_tiny_table), tmp_path / "folder", name="kept")
    data = dict(np.load(folder / "features.npz"))
    phi = data["features"].copy()
    m = int(np.flatnonzero((phi != phi[:, :1]).any(axis=(1, 2)))[0])  # an environment with another trajectory
    k = int(np.flatnonzero((phi[m] != phi[m, 0]).any(axis=1))[0])
    phi[m, 0] = data["features"][m, k]  # θ*'s row given another objective's trajectory: not its best
    np.savez(folder / "features.npz", **{**data, "features": phi})
    toml = (folder / "table.toml").read_text()
    kept = toml.replace("min_option_distance", "keep_suboptimal = true\nmin_option_distance")
    (folder / "table.toml").write_text(kept)
    table = import_table(folder, tmp_path / "kept")
    try:
        assert table.meta["imported"]["keep_suboptimal"] and "θ*'s trajectory is not the best" in \
            table.meta["imported"]["optimality"]
        study = build_study(real_spec(table, tmp_path / "kept", slug="kept"))
        page = staff_client.get(f"/dashboard/{study.slug}/").content.decode()
        assert 'id="kept-suboptimal"' in page and "θ*&#x27;s trajectory is not the best under θ* in 1 of 48" in page
    finally:
        unregister("kept")
        registry.forget("kept")


def test_an_optimal_imported_table_says_nothing_of_it(db, imported, staff_client):
    study = build_study(real_spec(TrajectoryTable.load(imported), imported, slug="optimal"))
    assert "kept_suboptimal" not in study.source
    assert 'id="kept-suboptimal"' not in staff_client.get(f"/dashboard/{study.slug}/").content.decode()
