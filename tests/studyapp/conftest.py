"""Fixtures of the study-app tests (tests/conftest.py has the project-wide ones)."""
import pytest

from studyapp.participant import assignment
from studyapp.researcher.studies import build_study, table_spec
from tests.conftest import SMALL_SEQUENCES, TINY_TEST_SET


@pytest.fixture
def participant(study):
    """A Prolific participant assigned through the real assignment code (test_flow.py has its own,
    who arrives through the entry view)."""
    return assignment.assign(study, "prolific", "csrf1")


# A closed-loop condition that asks many checks: up to 4 examples, a check question after each.
CLOSED_LOOP = {"model": "prob-euclidean", "value": 1.0, "lapse": 0.2, "max_examples": 4, "check_every": 1}


@pytest.fixture
def closed_loop_study(tiny_table, settings, tmp_path):
    """A study on the tiny table with a fixed sequence ("alpha") and a closed-loop condition ("closed-loop",
    CLOSED_LOOP), its decision files under a temporary VAR_DIR (test_closed_loop_flow.py's loop_study)."""
    settings.VAR_DIR = tmp_path
    spec = table_spec(tiny_table, slug="loop", sequences={"alpha": SMALL_SEQUENCES["alpha"]}, **TINY_TEST_SET)
    spec["conditions"].append({"name": "closed-loop", "closed_loop": CLOSED_LOOP})
    spec.update(name="Closed loop", completion_code="LOOP2026", target_per_condition=20)
    return build_study(spec)
