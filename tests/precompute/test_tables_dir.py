"""Where tables live is said once, by settings.TABLES_DIR: a table built on the
command line appears in the designer, build_study --preset reads it there, and the demo looks
there too."""
from __future__ import annotations

import io

import pytest
from django.core.management import CommandError, call_command

from precompute import jobs
from precompute.models import Job
from studyapp.researcher.studies import demo_table_path

TINY = ["--preset", "tiny", "--envs", "8", "--thetas", "8", "--chunk-size", "4"]


def test_a_table_built_on_the_command_line_appears_in_the_designer(inprocess_worker, transactional_db, settings,
                                                                    tmp_path, staff_client):
    settings.TABLES_DIR = tmp_path / "elsewhere"
    out = io.StringIO()
    call_command("precompute_table", *TINY, "--wait", "--timeout", "180", stdout=out, stderr=io.StringIO())
    job = Job.objects.get(kind=Job.TABLE)
    name = job.params["preset"]["name"]
    assert job.status == Job.SUCCEEDED and job.result_path == str(tmp_path / "elsewhere" / name)
    assert (tmp_path / "elsewhere" / name / "meta.json").exists()
    page = staff_client.get("/precompute/design/").content.decode()
    assert f'value="{tmp_path / "elsewhere" / name}"' in page and "8 environments × 8 θ" in page
    assert "No trajectory table is built" not in page

    # build_study --preset NAME reads TABLES_DIR/NAME: the table just built is found and used
    call_command("build_study", "--preset", name, "--slug", "from-dir", "--conditions", "exact", "--closed",
                 stdout=io.StringIO())
    study_job = Job.objects.get(kind=Job.STUDY)
    assert study_job.params["table"] == str((tmp_path / "elsewhere" / name).resolve())
    jobs.wait(study_job, progress=False, timeout=180)  # let the worker finish before it stops


def test_build_study_looks_for_a_preset_under_tables_dir(db, settings, tmp_path):
    settings.TABLES_DIR = tmp_path / "tables"
    with pytest.raises(CommandError, match=str(tmp_path / "tables" / "demo")):
        call_command("build_study", "--preset", "demo", "--slug", "nothing", stdout=io.StringIO())
    assert not Job.objects.exists()


def test_the_demo_reads_its_table_under_tables_dir(db, settings, tmp_path, monkeypatch):
    monkeypatch.delenv("DEMO_TABLE", raising=False)
    settings.TABLES_DIR = tmp_path / "tables"
    assert demo_table_path() == tmp_path / "tables" / "demo"
    with pytest.raises(CommandError, match=f"no trajectory table at {tmp_path / 'tables' / 'demo'}"):
        call_command("setup_demo", stdout=io.StringIO())
    monkeypatch.setenv("DEMO_TABLE", str(tmp_path / "own"))  # an explicit table still wins
    assert demo_table_path() == tmp_path / "own"
