"""The designer refuses tests the build could not draw, under the field to change, before any job starts,
and shows how many environments of the chosen table could hold each test (precompute/supply.py)."""
from __future__ import annotations

import html

import pytest
from django.core.cache import cache
from django.test import Client

from precompute.design import StudyDesignForm
from precompute.models import Job
from precompute.tables import built_tables
from studyapp.models import Study
from teaching.api import TrajectoryTable, supply_of_tests

pytestmark = pytest.mark.django_db
FORM = {"slug": "designed", "name": "Designed", "conditions": ["exact", "random"], "target_per_condition": "20",
        "recruitment": "link", "approx_star": "det-euclidean", "seed": "0", "min_regret": "0.001",
        "min_distance": "0.1", "estimated_minutes": "15"}


@pytest.fixture
def tiny(settings, tiny_table, tmp_path):
    """The tiny driving table, listed by the designer (and nothing cached from another test)."""
    settings.TABLES_DIR = tiny_table.parent
    settings.CACHES = {"default": {"BACKEND": "django.core.cache.backends.locmem.LocMemCache",
                                   "LOCATION": str(tmp_path)}}
    cache.clear()
    return tiny_table


def _errors(table, **changes) -> dict:
    form = StudyDesignForm(dict(FORM, table=str(table), **changes), tables=built_tables())
    form.is_valid()
    return {field: " ".join(errors) for field, errors in form.errors.items()}


def test_each_infeasible_setting_is_refused_under_its_field_and_starts_nothing(tiny, staff_client):
    assert _errors(tiny) == {} and _errors(tiny, test_difficulty="high") == {}
    cases = [
        # at the default distance two strategies have no environment with four options far enough apart
        ({"min_distance": "0.5"}, "min_regret", "No environment of this table can hold a test of 'braking: stay in "
                                                "lane', 'tailgating: stay (speed up)' at these thresholds: lower the "
                                                "minimum θ*-regret or distance, or choose another table."),
        ({"test_difficulty": "low"}, "test_difficulty", "No environment of this table can hold a test of low "
                                                        "difficulty of 'braking: stay in lane', 'braking: change "
                                                        "lane', 'tailgating: stay (speed up)': choose high, or none."),
        ({"test_difficulty": "medium"}, "test_difficulty", "of medium difficulty of"),
        ({"test_kind": "show"}, "test_kind", "This table's robot cannot be shown the way: the driving domain"),
    ]
    for changes, field, message in cases:
        errors = _errors(tiny, **changes)
        assert list(errors) == [field] and message in errors[field], (changes, errors)
        r = staff_client.post("/precompute/design/", dict(FORM, table=str(tiny), **changes))
        page = r.content.decode()
        assert r.status_code == 200 and html.escape(message) in page and "Traceback" not in page
        # said once, under the field: not again at the top of the form
        assert page.count(html.escape(message)) == 1
    assert not Job.objects.exists() and not Study.objects.exists()


def test_the_page_gets_the_counts_it_shows_beside_the_test_fields(tiny, staff_client):
    page = staff_client.get("/precompute/design/").content.decode()
    assert 'data-test-supply="/precompute/design/supply.json"' in page
    url = "/precompute/design/supply.json"
    r = staff_client.get(url, {"table": str(tiny), "kind": "choose", "min_distance": "0.1"})
    data = r.json()
    expected = supply_of_tests(TrajectoryTable.load(tiny), "choose", min_distance=0.1)
    assert r.status_code == 200 and data["hosts"] == list(expected.hosts) == [6, 5, 1, 1, 3, 1]
    assert data["clusters"] == list(expected.clusters) and data["lines"] == expected.describe()
    assert data["feasible"] == {"none": True, "low": False, "medium": False, "high": True}
    assert data["problems"]["low"] == "N" + expected.problem("low")[1:] and data["problems"]["high"] == ""
    assert staff_client.get(url, {"table": str(tiny)}).json()["hosts"] == [2, 2, 0, 1, 2, 0]  # the default distance
    table = str(tiny)
    for query, status in [({"table": "/etc"}, 404), ({"table": table, "kind": "pick"}, 400),
                          ({"table": table, "min_regret": "-1"}, 400), ({"table": table, "min_regret": "x"}, 400),
                          ({"table": table, "min_distance": "nan"}, 400)]:
        r = staff_client.get(url, query)
        assert r.status_code == status and r.json()["error"], query
    r = Client().get(url, {"table": table})  # researchers only
    assert r.status_code == 302 and r["Location"].startswith("/login/")
