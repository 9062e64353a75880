"""Fixtures of the study-app tests (tests/conftest.py has the project-wide ones)."""
import pytest

from studyapp import assignment


@pytest.fixture
def participant(study):
    """A Prolific participant assigned through the real assignment code (test_flow.py has its own,
    who arrives through the entry view)."""
    return assignment.assign(study, "prolific", "csrf1")
