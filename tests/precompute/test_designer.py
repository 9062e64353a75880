"""The study designer (issue 13, item 3, first part): a researcher picks a built table by its
identity, chooses conditions and settings, and "Build" selects every condition and the test set
on a worker; the study comes out closed, for previewing before it opens."""
from __future__ import annotations

import json

import pytest

from precompute import jobs
from precompute.models import Job
from studyapp.models import Study
from teaching.table import TrajectoryTable

pytestmark = pytest.mark.slow
FORM = {"slug": "designed", "name": "Designed", "conditions": ["exact", "random", "coverage-random"],
        "target_per_condition": "20", "recruitment": "prolific", "completion_code": "C0DE1234",
        "approx_star": "det-euclidean", "seed": "0"}


@pytest.fixture
def tables(settings, demo_table):
    settings.TABLES_DIR = demo_table.parent  # the session's tmp root: the demo table and other scratch dirs
    return demo_table


def test_design_build_on_a_worker_then_preview(inprocess_worker, transactional_db, tables, staff_client):
    meta = json.loads((tables / "meta.json").read_text())
    page = staff_client.get("/precompute/design/").content.decode()
    assert "1,200 environments × 200 θ" in page and meta["content_hash"][:16] in page
    assert "θ* = (-64, -0.1, -1, -0.1, -0.5)" in page

    r = staff_client.post("/precompute/design/", dict(FORM, table=str(tables)))
    job = Job.objects.get(kind=Job.STUDY)
    assert r.status_code == 302 and r["Location"] == job.get_absolute_url()
    job = jobs.wait(job, progress=False, timeout=180)
    assert job.status == Job.SUCCEEDED, job.error

    study = Study.objects.get(slug="designed")
    table = TrajectoryTable.load(tables)
    assert not study.is_open  # previewed first, opened on its dashboard page
    assert (study.recruitment, study.completion_code, study.target_per_condition) == ("prolific", "C0DE1234", 20)
    assert study.source["content_hash"] == meta["content_hash"] and study.source["theta_star"] == meta["theta_star"]
    assert [c.name for c in study.conditions.all()] == FORM["conditions"]
    assert all(c.training for c in study.conditions.all()) and len(study.test_set) == 6
    assert not {e for c in study.conditions.all() for e in c.env_ids} & {t["env_id"] for t in study.test_set}
    assert set(e for c in study.conditions.all() for e in c.env_ids) <= set(int(e) for e in table.env_ids)

    # the job page links to the study; its dashboard page previews each condition, then opens it
    assert "/dashboard/designed/" in staff_client.get(job.get_absolute_url()).content.decode()
    for condition in study.conditions.all():
        r = staff_client.post(f"/dashboard/designed/preview/{condition.pk}/")
        assert r.status_code == 302 and staff_client.get(r["Location"]).status_code == 200
    staff_client.post("/dashboard/designed/toggle/", {"open": "1"})
    assert Study.objects.get(slug="designed").is_open


def test_design_form_errors(db, tables, staff_client, make_study):
    make_study(slug="taken")
    cases = [
        (dict(FORM, slug="taken"), "exists already"),
        (dict(FORM, slug="bad slug"), "Enter a valid"),
        (dict(FORM, completion_code=""), "Prolific only accepts its study"),
        (dict(FORM, conditions=[]), "This field is required"),
        (dict(FORM, target_per_condition="1"), "greater than or equal to 2"),
        (dict(FORM, table="/nowhere"), "Select a valid choice"),
    ]
    for data, message in cases:
        data.setdefault("table", str(tables))
        r = staff_client.post("/precompute/design/", data)
        assert r.status_code == 200 and message in r.content.decode(), message
    assert not Job.objects.exists() and not Study.objects.filter(slug="designed").exists()


def test_the_designer_is_for_researchers_only(db, client, tables):
    r = client.get("/precompute/design/")
    assert r.status_code == 302 and r["Location"].startswith("/login/")
    assert client.post("/precompute/design/", dict(FORM, table=str(tables))).status_code == 302
    assert not Study.objects.exists()


def test_no_table_yet_says_how_to_build_one(db, settings, tmp_path, staff_client):
    settings.TABLES_DIR = tmp_path
    page = staff_client.get("/precompute/design/").content.decode()
    assert "No trajectory table is built" in page and "python -m teaching build --preset demo" in page
