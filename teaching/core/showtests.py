"""Show-the-way tests: the participant is given an environment and moves the robot the way they
think it would go; the answer is scored by its regret under θ* (the domain replays it).

One test per strategy cluster c in the domain's ``test_clusters``.  An environment is eligible for c
when

* it is in no training sequence,
* θ* shows c in it (``table.strategy[m, 0] == c``; a domain labels a class's strategies only in
  environments of that class, so c's class too), and
* at least ``min_share`` of the table's N candidate θ (θ* included; its own regret is 0, so it never
  counts) have an optimal trajectory there that is clearly worse under θ*:

      share_worse = #{θ : θ*·φ(ξ^θ*) - θ*·φ(ξ^θ) >= min_regret} / N >= min_share

  so that a participant passes only by knowing θ*, not by pursuing just any candidate objective.

``min_regret`` is in θ*-reward units (testset.MIN_REGRET by default, the choice tests' threshold);
``min_share`` is a fraction in [0, 1] (MIN_SHARE by default).  Each test is drawn uniformly (a seeded
NumPy Generator) among its cluster's eligible environments, in test-cluster order; a cluster with no
eligible environment is skipped, and TestSetError (one line naming the clusters and thresholds) is
raised when no cluster has one.  The same table, training and seed give the same tests.

Graded by difficulty (:mod:`teaching.core.difficulty`, as choice tests are): each test among its
cluster's eligible environments of that level on the scale of every test cluster's eligible
environments, or where it has none there, on its own cluster's; a cluster with none on either is
skipped, and the TestSetError when none has one says how many each level has.
"""
from __future__ import annotations

import numpy as np

from .difficulty import DIFFICULTIES, grade
from .testset import MIN_REGRET, TestSetError, theta_star_regret

SHOW = "show"  # a test's "kind" when the participant shows the way (a test without one chooses among options)


def is_show(test: dict) -> bool:
    """Whether `test` (a test set's dict, stored or from teach) asks the participant to show the way."""
    return test.get("kind") == SHOW


# a quarter of the candidates going wrong keeps a test informative while letting small worlds,
# whose environments offer only a few distinct trajectories, have one (their tiny tables: 0.42-0.75)
MIN_SHARE = 0.25


def share_worse(table, env_index: int, min_regret: float = MIN_REGRET) -> float:
    """The fraction of the table's N θ whose optimal trajectory in row ``env_index`` has θ*-regret
    >= ``min_regret`` (θ*-reward units), in [0, 1)."""
    return float(np.mean(theta_star_regret(table, env_index) >= min_regret))


def eligible_rows(table, training_env_ids: list[list[int]], min_regret: float = MIN_REGRET,
                  min_share: float = MIN_SHARE) -> dict[int, list[tuple[int, float]]]:
    """{test cluster c: [(table row, share_worse), ...] in table order}: the environments eligible for
    a show test of c (module docstring); a cluster with none maps to []."""
    used = {int(e) for seq in training_env_ids for e in seq}
    free = ~np.isin(np.asarray(table.env_ids), list(used))
    star = np.asarray(table.strategy[:, 0])
    out = {}
    for c in table.domain.test_clusters:
        rows = [(int(m), share_worse(table, int(m), min_regret)) for m in np.flatnonzero(free & (star == c))]
        out[c] = [(m, s) for m, s in rows if s >= min_share]
    return out


def select_show_tests(table, training_env_ids: list[list[int]], seed: int = 0, min_regret: float = MIN_REGRET,
                      min_share: float = MIN_SHARE, difficulty: str | None = None) -> list[dict]:
    """One show test per test cluster that has an eligible environment (module docstring).

    training_env_ids: lists of environment ids (not rows) the study trains on.  Returns, in
    test-cluster order, dicts {"env_id": int, "kind": "show", "cluster": int, "share_worse": float}, and
    with a difficulty (one of DIFFICULTIES) also difficulty, bec_size, bec_tertiles and graded.
    Raises TestSetError when no cluster has an eligible environment (of that difficulty).
    """
    if difficulty is not None and difficulty not in DIFFICULTIES:
        raise ValueError(f"unknown test difficulty {difficulty!r}; choose from {', '.join(DIFFICULTIES)}")
    rng = np.random.default_rng(seed)
    env_ids = np.asarray(table.env_ids)
    eligible = eligible_rows(table, training_env_ids, min_regret, min_share)
    share = {m: s for rows in eligible.values() for m, s in rows}
    grading = None if difficulty is None else grade(table, {c: [m for m, _ in rows] for c, rows in eligible.items()})
    out = []
    for c, rows in eligible.items():
        pools = [(None, [m for m, _ in rows])] if grading is None else grading.candidates(c, difficulty)
        scale, pool = next(((scale, pool) for scale, pool in pools if pool), (None, []))
        if not pool:
            continue
        m = pool[int(rng.integers(len(pool)))]
        test = {"env_id": int(env_ids[m]), "kind": SHOW, "cluster": int(c), "share_worse": share[m]}
        if grading is not None:
            test.update(difficulty=difficulty, **grading.record(m, scale))
        out.append(test)
    if not out:
        names = ", ".join(f"'{table.domain.cluster_names[c]}'" for c in table.domain.test_clusters)
        why = (f"no environment in no training sequence where θ* shows one has at least {min_share:g} of the θ with "
               f"θ*-regret >= {min_regret:g}")
        if grading is not None and any(eligible.values()):
            why = "; ".join(f"'{table.domain.cluster_names[c]}': {grading.counts(c)}" for c in eligible if eligible[c])
            why = f"of the eligible environments, {why}; ask for another difficulty, or none"
        of_level = "" if difficulty is None else f" of {difficulty} difficulty"
        raise TestSetError(f"no show test environment{of_level} for any of {names}: {why}")
    return out
