"""Each condition's estimated duration (studyapp/researcher/durations.py), worked by hand on a study of made-up
payloads, its warnings, and the dashboard's table of what each condition's participants go through."""
from __future__ import annotations

import pytest
from django.urls import reverse

from studyapp.models import Condition, Study
from studyapp.researcher import durations

pytestmark = pytest.mark.django_db


def _payload(rows: int, dt: float = 0.25) -> dict:
    return {"robot": [[0.0, 0.0]] * rows, "dt": dt}


@pytest.fixture
def made_up():
    """Two tests of four options, 21 rows at 0.25 s (5 s each); condition 'long' shows three 5 s examples
    and one of 41 rows (10 s), 'short' one 5 s example."""
    tests = [{"env_id": j, "options": [_payload(21) for _ in range(4)]} for j in range(2)]
    study = Study.objects.create(slug="timed", test_set=tests, estimated_minutes=6, duration_tolerance_minutes=1)
    Condition.objects.create(study=study, name="long", position=0,
                             training=[_payload(21), _payload(21), _payload(21), _payload(41)])
    Condition.objects.create(study=study, name="short", position=1, training=[_payload(21)])
    return study


def test_the_estimates_by_hand(made_up):
    # fixed: pages 200 s + 2 tests × (30 s rating + 4 options × 5 s) = 300 s
    # long: 4 examples × 8 s + (3 × 5 + 10) s of animation = 57 s -> 357 s = 5.95 min
    # short: 1 × 8 s + 5 s = 13 s -> 313 s = 5.2167 min
    long, short = durations.estimates(made_up)
    assert (long.condition, long.examples, long.animation_seconds) == ("long", 4, 25.0)
    assert long.minutes == pytest.approx(357 / 60, rel=1e-12)  # exact sums of binary fractions
    assert (short.examples, short.animation_seconds, short.minutes) == (1, 5.0, pytest.approx(313 / 60, rel=1e-12))
    assert durations.warnings(made_up, [long, short]) == []  # 0.73 min apart, within 1; both under 6
    made_up.comprehension_check, made_up.comprehension_questions = True, [
        {"question": "Q?", "choices": ["a", "b"], "right": [0]}] * 4  # 4 × 15 s more for everyone
    long, short = durations.estimates(made_up)
    assert long.minutes == pytest.approx(417 / 60, rel=1e-12) and short.minutes == pytest.approx(373 / 60, rel=1e-12)


def test_the_warnings_name_the_conditions_and_the_numbers(made_up):
    made_up.duration_tolerance_minutes, made_up.estimated_minutes = 0, 5
    said = durations.warnings(made_up, durations.estimates(made_up))
    assert said == [
        "Condition 'long' is estimated at 6 minutes and 'short' at 5: more than the 0 minutes they may differ by. "
        "Time on task then differs with the condition; consider other conditions, or a larger tolerance if that "
        "is intended.",
        "The consent page says about 5 minutes, but 'long', 'short' are estimated to take longer."]


def test_the_study_page_says_what_each_condition_goes_through(made_up, staff_client):
    made_up.duration_tolerance_minutes = 0
    made_up.save()
    page = staff_client.get(reverse("dashboard_study", args=[made_up.slug])).content.decode()
    assert '<tr data-condition="long"><td>long</td><td>4</td>' in page and "<td>6 min</td>" in page
    assert '<tr data-condition="short"><td>short</td><td>1</td>' in page and "<td>5 min</td>" in page
    assert "more than the 0 minutes they may differ by" in page and "The consent page says about 6 minutes" in page
