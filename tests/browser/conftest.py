"""Fixtures the browser tests share."""
from __future__ import annotations

import pytest

from studyapp.studies import build_study, demo_spec
from teaching.core.table import TrajectoryTable
from tests.studyapp.test_stimuli import real_spec


@pytest.fixture
def staff_cookie(transactional_db, client):
    """A researcher's session cookie, for a browser context (ctx.add_cookies)."""
    from django.contrib.auth.models import User  # noqa: PLC0415

    user = User.objects.create_user("researcher", password="pw-stimuli-1", is_staff=True)
    client.force_login(user)
    return client.cookies["sessionid"].value


@pytest.fixture
def studies(transactional_db, demo_table, tiny_table, monkeypatch):
    """The demo study on the session's demo table, and a study with real stimuli on the tiny table:
    every scene the scene tests draw."""
    monkeypatch.setenv("DEMO_TABLE", str(demo_table))
    demo = build_study(demo_spec())
    real = build_study(real_spec(TrajectoryTable.load(tiny_table), tiny_table))
    return [demo, real]
