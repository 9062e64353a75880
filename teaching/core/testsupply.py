"""How many environments of a table could hold each test, by difficulty level: what the study designer
says before a study is built, so that a test set the build cannot draw is refused under its field.

The counts follow the selection's own rules, through its own functions (:mod:`teaching.core.testset` for
tests that choose among options, :mod:`teaching.core.showtests` for tests that show the way):

* an environment *hosts* a choice test of cluster c when θ* shows c in it and some option set meets the
  thresholds (every set looked at: ``testset._hosts``); it hosts a show test of c when it is eligible
  (``showtests.eligible_rows``);
* with a difficulty, a test of c may be drawn from its hosts of that level on the scale of every test
  cluster's hosts, or, where that is empty, on its own cluster's (``difficulty.Grading.candidates``); the
  count is that pool's size.

A choice test set needs every test cluster to have a test; a show test set at least one.

The designer counts before any training is chosen (``training_env_ids`` empty): the build then removes the
environments the conditions train on and grades what is left again.  Counts of zero are final — training
only removes environments — while a level counted here can still be used up by training on a table where
few environments hold it; the build then says so in one line.  The tests check on every shipped table that
the designer's answer and the build's agree (tests/teaching/core/test_test_supply.py).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .difficulty import DIFFICULTIES, grade
from .showtests import MIN_SHARE, SHOW, eligible_rows
from .testset import MIN_REGRET, _eligible, _hosts

CHOOSE = "choose"  # a test's kind when the participant chooses among options (showtests.SHOW: shows the way)
ANY = "none"  # the difficulty of an ungraded test set, as the study spec names it


@dataclass(frozen=True)
class TestSupply:
    """The environments that could hold each test cluster's test.

    kind: CHOOSE or SHOW.  clusters: the test clusters' names, in the domain's order.  hosts: per
    cluster, how many environments could hold its test, at any difficulty.  by_level: {difficulty:
    per cluster, how many a test of that level may be drawn from}."""

    __test__ = False  # not a pytest test class despite the name

    kind: str
    clusters: tuple[str, ...]
    hosts: tuple[int, ...]
    by_level: dict[str, tuple[int, ...]]

    def counts(self, difficulty: str | None = None) -> tuple[int, ...]:
        """Per cluster: environments a test of ``difficulty`` (None or ANY: any) may be drawn from."""
        return self.hosts if difficulty in (None, ANY) else self.by_level[difficulty]

    def feasible(self, difficulty: str | None = None) -> bool:
        """Whether a test set of this kind and difficulty can be drawn (module docstring)."""
        counts = self.counts(difficulty)
        return all(counts) if self.kind == CHOOSE else any(counts)

    def problem(self, difficulty: str | None = None) -> str:
        """Why no test set of ``difficulty`` can be drawn, in one line ("" when one can)."""
        if self.feasible(difficulty):
            return ""
        empty = [name for name, n in zip(self.clusters, self.counts(difficulty), strict=True) if not n]
        if difficulty in (None, ANY):
            return _lacking(self.kind, empty, "") + " at these thresholds: lower the minimum θ*-regret or " \
                "distance, or choose another table."
        better = [d for d in DIFFICULTIES if d != difficulty and self.feasible(d)]
        instead = (f"choose {' or '.join(better)}, or none" if better else "choose none") if self.feasible() \
            else "lower the minimum θ*-regret or distance"
        return f"{_lacking(self.kind, empty, f' of {difficulty} difficulty')}: {instead}."

    def describe(self) -> list[str]:
        """One line per cluster: how many environments each level (and any) offers, e.g.
        "'left': 40 in all; 12 low, 14 medium, 14 high"."""
        return [f"'{name}': {self.hosts[i]} in all; "
                + ", ".join(f"{self.by_level[d][i]} {d}" for d in DIFFICULTIES)
                for i, name in enumerate(self.clusters)]

    def as_dict(self) -> dict:
        return {"kind": self.kind, "clusters": list(self.clusters), "hosts": list(self.hosts),
                "by_level": {d: list(v) for d, v in self.by_level.items()},
                "feasible": {d: self.feasible(d) for d in (ANY, *DIFFICULTIES)}}


def _lacking(kind: str, empty: list[str], of: str) -> str:
    if kind == CHOOSE:
        said = ", ".join(f"'{name}'" for name in empty)
        return f"no environment of this table can hold a test{of} of {said}"
    return f"no environment of this table can hold a show test{of} of any strategy"


def ungraded_problem(kind: str, clusters: list[str], missing: list[str]) -> str:
    """:meth:`TestSupply.problem` of an ungraded test set, from :func:`clusters_without_a_test`'s answer
    alone (``clusters``: every test cluster's name)."""
    hosts = tuple(0 if name in missing else 1 for name in clusters)
    return TestSupply(kind, tuple(clusters), hosts, {}).problem(ANY)


def supply_of_tests(table, kind: str = CHOOSE, training_env_ids: list[list[int]] = (), *,
                min_regret: float = MIN_REGRET, min_distance: float | None = None,
                min_share: float = MIN_SHARE) -> TestSupply:
    """The :class:`TestSupply` of ``table`` for tests of ``kind`` (CHOOSE or SHOW) outside the environment
    ids in ``training_env_ids`` (none by default: the designer's view before Build).  ``min_regret`` is in
    θ*-reward units, ``min_distance`` in the domain's option distance (None: its min_option_distance);
    ``min_share`` (show tests) a fraction in [0, 1].  The seed plays no part: it picks among the hosts."""
    if kind not in (CHOOSE, SHOW):
        raise ValueError(f"unknown test kind {kind!r}; choose from {CHOOSE}, {SHOW}")
    domain = table.domain
    if kind == SHOW:
        rows = {c: [m for m, _ in found] for c, found in
                eligible_rows(table, list(training_env_ids), min_regret, min_share).items()}
    else:
        if min_distance is None:
            min_distance = domain.min_option_distance
        used = {int(e) for seq in training_env_ids for e in seq}
        eligible = _eligible(table, ~np.isin(np.asarray(table.env_ids), list(used)))
        rows = {c: sorted(found) for c, found in _hosts(table, eligible, 0, min_regret, min_distance).items()}
    grading = grade(table, rows) if any(rows.values()) else None
    by_level = {}
    for d in DIFFICULTIES:
        per = []
        for c in domain.test_clusters:
            pools = grading.candidates(c, d) if grading is not None and rows[c] else []
            per.append(next((len(pool) for _, pool in pools if pool), 0))
        by_level[d] = tuple(per)
    return TestSupply(kind, tuple(domain.cluster_names[c] for c in domain.test_clusters),
                      tuple(len(rows[c]) for c in domain.test_clusters), by_level)


def clusters_without_a_test(table, kind: str = CHOOSE, *, min_regret: float = MIN_REGRET,
                            min_distance: float | None = None, min_share: float = MIN_SHARE) -> list[str]:
    """The names of the test clusters no environment of ``table`` can hold a test of (any difficulty):
    :func:`supply_of_tests`'s zero counts, found by stopping at each cluster's first host (a choice test set on
    the demo table is answered in well under a second, its counts in several)."""
    if kind == SHOW:
        supply = supply_of_tests(table, SHOW, min_regret=min_regret, min_share=min_share)
        return [name for name, n in zip(supply.clusters, supply.hosts, strict=True) if not n]
    domain = table.domain
    if min_distance is None:
        min_distance = domain.min_option_distance
    eligible = _eligible(table, np.ones(table.n_envs, bool))
    missing = []
    for c in domain.test_clusters:
        if not any(_hosts(table, {c: [m]}, 0, min_regret, min_distance)[c] for m in eligible[c]):
            missing.append(domain.cluster_names[c])
    return missing
