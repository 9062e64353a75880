"""What the study designer says about a table's tests before Build: how many environments could hold each
test, per difficulty level (teaching's supply_of_tests), and why a chosen kind or difficulty cannot be built.

Counting takes seconds on a large table (every option set of every candidate environment is looked at), so
the answers are kept in Django's cache under the table's content hash and the thresholds: the page asks for
them in the background when a table is chosen, and "Build" then finds them ready.
"""
from __future__ import annotations

import json
from pathlib import Path

from django.core.cache import cache

from studyapp.models import Study
from studyapp.trajectories import cannot_show
from teaching.api import (
    MIN_REGRET,
    TableError,
    TrajectoryTable,
    clusters_without_a_test,
    get_domain,
    supply_of_tests,
    ungraded_problem,
)

CACHE_SECONDS = 7 * 24 * 3600  # a table's answer never changes: its content hash is in the key


def _key(path: str, *parts) -> str | None:
    try:
        content_hash = json.loads((Path(path) / "meta.json").read_text()).get("content_hash")
    except (OSError, ValueError):
        return None
    return ":".join(map(str, ("test-supply", content_hash, *parts))) if content_hash else None


def _load(path: str):
    return TrajectoryTable.load(path, verify=False)  # the designer lists published tables; the job verifies


def _cached(key: str | None, compute):
    """compute(), kept in Django's cache under ``key`` (None: a table without a content hash, not kept)."""
    return compute() if key is None else cache.get_or_set(key, compute, CACHE_SECONDS)


def counts(path: str, kind: str, min_regret: float | None = None, min_distance: float | None = None) -> dict:
    """teaching's TestSupply of the table at ``path`` as JSON-able data (TestSupply.as_dict, with ``lines``:
    its describe()), cached; TableError or OSError when the table cannot be read."""
    min_regret = MIN_REGRET if min_regret is None else min_regret

    def compute() -> dict:
        supply = supply_of_tests(_load(path), kind, min_regret=min_regret, min_distance=min_distance)
        return {**supply.as_dict(), "lines": supply.describe(), "problems": {
            d: _sentence(supply.problem(d)) for d in supply.as_dict()["feasible"]}}
    return _cached(_key(path, "counts", kind, min_regret, min_distance), compute)


def problem(path: str, domain: str, kind: str, difficulty: str | None, min_regret: float | None = None,
            min_distance: float | None = None) -> tuple[str, str]:
    """(field, why in one line) when the build's last step could not draw these tests on the table at
    ``path`` whatever the conditions train on; ("", "") when it can (training may still use the last
    environments of a level: the build says so).  ``domain``: the table's robot."""
    robot = get_domain(domain)
    if kind == Study.SHOW:
        why = cannot_show(robot)
        if why:
            return "test_kind", f"This table's robot cannot be shown the way: {why}."
    try:
        if difficulty in (None, "", "none"):
            # quick: each cluster's first host answers it (the counts are for the page, in the background)
            missing = _cached(_key(path, "missing", kind, min_regret, min_distance), lambda: clusters_without_a_test(
                _load(path), kind, min_regret=MIN_REGRET if min_regret is None else min_regret,
                min_distance=min_distance))
            why = ungraded_problem(kind, [robot.cluster_names[c] for c in robot.test_clusters], missing)
            return ("min_regret", _sentence(why)) if why else ("", "")
        why = counts(path, kind, min_regret, min_distance)["problems"][difficulty]
    except (TableError, OSError, ValueError) as exc:
        return "table", f"Cannot read this table: {exc}"
    return ("test_difficulty", why) if why else ("", "")


def _sentence(text: str) -> str:
    return text[:1].upper() + text[1:]
