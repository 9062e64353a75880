"""What the logs say: assignments, completions and job events, one line each,
without personal data (participants by row id, never by platform id)."""
import logging

import pytest
from django.conf import settings

from studyapp.participant import assignment

pytestmark = pytest.mark.django_db


def test_assignment_and_completion_are_logged_without_personal_data(study, complete, caplog):
    with caplog.at_level(logging.INFO):
        p = assignment.assign(study, "prolific", "PID-PRIVATE-4711", platform_session_id="SESSION-PRIVATE")
        assignment.assign(study, "prolific", "PID-PRIVATE-4711")  # returning: not assigned again
        complete(p)
    lines = [r.getMessage() for r in caplog.records if r.name.startswith("studyapp")]
    assert sum(m.startswith(f"assigned participant {p.pk} (prolific) to condition") for m in lines) == 1
    assert any(m.startswith(f"participant {p.pk} completed study {study.slug!r}") for m in lines)
    assert "PID-PRIVATE" not in caplog.text and "SESSION-PRIVATE" not in caplog.text


def test_every_logger_of_ours_reaches_the_one_handler():
    cfg = settings.LOGGING
    assert cfg["root"]["handlers"] == ["console"]
    for name in ("django", "studyapp", "precompute"):
        assert "handlers" not in cfg["loggers"][name]  # propagate to the root: no line written twice
    assert logging.getLogger("precompute.tasks").getEffectiveLevel() <= logging.INFO
