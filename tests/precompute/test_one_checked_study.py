"""One checked study: each route that makes a study (a JSON spec through create_study, the study job from the
command line, the designer's form) checks the design once, into a frozen CheckedStudy, and everything
downstream takes that object.  So the field rules run once per route and so does the language check, and
the entry that makes a study job takes four parameters."""
from __future__ import annotations

import dataclasses
import inspect
import io
import json
from collections import Counter

import pytest
from django.core.management import call_command

from precompute.models import Job
from precompute.study import create_study_job
from studyapp.models import Study
from studyapp.researcher import specschema, studies
from studyapp.researcher.specschema import CheckedStudy, check_job
from studyapp.researcher.studies import table_spec
from tests.conftest import SMALL_SEQUENCES, TINY_TEST_SET

DESIGNER = {"slug": "designed", "target_per_condition": "20", "recruitment": "link", "approx_star": "det-euclidean",
            "seed": "0", "min_regret": "0.001", "min_distance": "0.1", "estimated_minutes": "15",
            "conditions": ["exact"], "language": "de"}


@pytest.fixture
def counted(monkeypatch):
    """How often the field rules (specschema._problems, where every declared field is checked) and the
    creation's language check (studies.language_problem) run."""
    calls = Counter()

    def counting(name, real):
        def wrapped(*args, **kwargs):
            calls[name] += 1
            return real(*args, **kwargs)
        return wrapped

    monkeypatch.setattr(specschema, "_problems", counting("fields", specschema._problems))
    monkeypatch.setattr(studies, "language_problem", counting("language", studies.language_problem))
    return calls


def test_a_json_spec_is_checked_once(db, tiny_table, tmp_path, counted):
    spec = {**table_spec(tiny_table, slug="from-json", sequences=SMALL_SEQUENCES, **TINY_TEST_SET), "language": "de"}
    path = tmp_path / "spec.json"
    path.write_text(json.dumps(spec))
    call_command("create_study", str(path), stdout=io.StringIO())
    assert Study.objects.get(slug="from-json").language == "de"
    assert counted == {"fields": 1, "language": 1}


def test_the_command_lines_study_job_is_checked_once(db, tiny_table, counted):
    call_command("build_study", "--table", str(tiny_table), "--slug", "from-cli", "--conditions", "exact",
                 stdout=io.StringIO())
    assert Job.objects.get(kind=Job.STUDY).params["slug"] == "from-cli"
    assert counted == {"fields": 1, "language": 1}


def test_the_designers_study_job_is_checked_once(db, tiny_table, settings, staff_client, counted):
    settings.TABLES_DIR = tiny_table.parent
    r = staff_client.post("/precompute/design/", {**DESIGNER, "table": str(tiny_table)})
    assert r.status_code == 302, r.content.decode()[-2000:]
    assert Study.objects.get(slug="designed").language == "de"
    assert counted == {"fields": 1, "language": 1}


def test_the_designer_says_what_only_the_job_finds_under_its_field(db, tiny_table, settings, staff_client,
                                                                  monkeypatch):
    """The language check runs where every study is made (studies.new_study), not in the form: its refusal
    still reaches the researcher under the language, with nothing written."""
    settings.TABLES_DIR = tiny_table.parent
    monkeypatch.setattr(studies, "language_problem", lambda domain, language: f"no {language} texts for this robot")
    page = staff_client.post("/precompute/design/", {**DESIGNER, "table": str(tiny_table)})
    assert page.status_code == 200
    assert page.context["form"].errors["language"] == ["no de texts for this robot"]
    assert not Job.objects.exists() and not Study.objects.exists()


def test_the_job_entry_takes_a_checked_study_and_four_parameters():
    assert list(inspect.signature(create_study_job).parameters) == ["table_path", "checked", "queue", "start"]
    checked = check_job({"slug": "frozen", "conditions": ["exact"]})
    with pytest.raises(dataclasses.FrozenInstanceError):
        checked.values = {}
    with pytest.raises(TypeError):
        checked.values["slug"] = "thawed"
    assert isinstance(checked, CheckedStudy) and checked.condition_names == ["exact"]
