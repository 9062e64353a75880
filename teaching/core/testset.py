"""Test environments for the study (paper, "Dependent Measures"; DESIGN §6).

One environment per strategy cluster in the domain's ``test_clusters`` (the paper: six, the
strategies of its three informative classes): in the environment for cluster c, θ* shows
strategy c.  Each gets 4 options, every one the optimal trajectory of some θ ∈ Θ: θ*'s own,
one more from cluster c and two from a sibling cluster (another strategy of the class).
An alternative must be clearly worse under θ*:

    regret = θ*·φ(ξ^θ*) - θ*·φ(ξ^θ) >= MIN_REGRET

and any two options must look different:

    d_euclid(ξ, ξ') >= the domain's min_option_distance

(the Euclidean learner's distance, DESIGN §5, as the domain defines it).  Environments are drawn at
random (seeded) from those not used in any training sequence; for each, up
to MAX_TRIES random option sets are drawn and the first one meeting the
thresholds is kept (rejection sampling); environments with none are skipped.

When no unused environment of cluster c has two θ in Θ taking the other
strategy (it happens on the paper's demo table: docs/decisions.md), the two remaining options may come from
either strategy of the class (``"rule": "relaxed"`` in the test's entry,
``"design"`` otherwise).  Trajectories that show no strategy are never options.

Tests may be graded by difficulty (Lee, Admoni & Simmons 2021): the eligible test environments are
every environment in no training sequence in which θ* shows one of the test clusters (in that
cluster's class) and which has the alternatives a test needs (one of the cluster and three of its
class, distinct, with θ*-regret >= min_regret: the relaxed rule's pools; the options' distance is
not checked, it needs drawing).  Their BEC sizes (:func:`teaching.core.bec.environment_sizes`: the
fraction of θ*'s orthant of weights under which θ*'s trajectory stays optimal against the table's
there, in [0, 1]) are cut at their tertiles q1 ≤ q2 (``numpy.quantile``, linear interpolation, over
that whole set, not per cluster).  A large BEC is easy: "low" difficulty is size > q2, "medium" q1 <
size ≤ q2, "high" size ≤ q1; a size equal to an edge counts as the harder level.  With a difficulty,
each test is drawn only among its cluster's environments of that level.
"""
from __future__ import annotations

import numpy as np

from . import bec
from .domain import siblings

MIN_REGRET = 1e-3  # θ*-reward units; on the demo table |θ*·φ(ξ^θ*)| has median 0.039 (see docs/teaching.md)
# option sets drawn per environment: 50 missed sets that exist (on one demo table no
# environment of one cluster passed in 50, one 0.87 apart passed in 200)
MAX_TRIES = 200
_PAIRS = np.triu_indices(4, 1)  # the 6 pairs among a test's 4 options
# Difficulty levels of a graded test, easiest first (large BEC first).
DIFFICULTIES = ("low", "medium", "high")


class TestSetError(ValueError):
    """No test set meets the constraints on this table."""

    __test__ = False  # not a pytest test class despite the name


def theta_star_regret(table, env_index: int) -> np.ndarray:
    """(N,) θ*·φ(ξ^θ*) - θ*·φ(ξ^θ) in one environment: how much worse each θ's trajectory is for θ*."""
    f = np.asarray(table.features[env_index], np.float64)
    return (f[0] - f) @ np.asarray(table.theta_star, np.float64)


def pairwise_distance(domain, states: np.ndarray) -> np.ndarray:
    """(k, T+1, S) -> (k, k) d_euclid between every pair of trajectories (the Euclidean learner's distance)."""
    return domain.euclidean_distance(states[:, None], states[None])


def _distinct(table, env_index: int, thetas: np.ndarray) -> np.ndarray:
    """One θ (the lowest index) per distinct trajectory among ``thetas``: θs sharing a trajectory
    share its features, so duplicates would never pass the distance test anyway."""
    if len(thetas) == 0:
        return thetas
    _, first = np.unique(np.asarray(table.features[env_index, thetas]), axis=0, return_index=True)
    return np.sort(thetas[first])


def _alternatives(table, env_index: int, cluster: int, min_regret: float, relaxed: bool):
    """((N,) θ*-regret, θs of ``cluster``, θs of its siblings (relaxed: of the whole class)), the θs
    being one per distinct trajectory with θ*-regret >= min_regret: who may be a test's options."""
    regret = theta_star_regret(table, env_index)
    strat = np.asarray(table.strategy[env_index])
    same = _distinct(table, env_index, np.flatnonzero((strat == cluster) & (regret >= min_regret)))
    wanted = np.isin(strat, siblings(table.domain, cluster)) | ((strat == cluster) if relaxed else False)
    return regret, same, _distinct(table, env_index, np.flatnonzero(wanted & (regret >= min_regret)))


def _draw_options(table, env_index: int, cluster: int, rng, min_regret, min_distance, max_tries,
                  relaxed: bool = False):
    """[θ*, same-cluster θ, other-cluster θ, other-cluster θ] or None when rejected; relaxed: the last
    two from either cluster of the class."""
    regret, same, other = _alternatives(table, env_index, cluster, min_regret, relaxed)
    if len(same) < 1 or len(other) < 2 + relaxed:
        return None
    pool = np.concatenate([[0], same, other])
    states = np.asarray(table.states(env_index, pool), np.float64)
    pos = {int(t): i for i, t in enumerate(pool)}
    for _ in range(max_tries):
        first = int(rng.choice(same))
        rest = other[other != first]
        if len(rest) < 2:
            return None
        pick = [0, first, *map(int, rng.choice(rest, size=2, replace=False))]
        # only the drawn options' distances: a draw is accepted within a few tries, and the whole pool's
        # matrix (a few hundred trajectories squared) cost most of the test set's time
        d = pairwise_distance(table.domain, states[[pos[t] for t in pick]])[_PAIRS]
        if d.min() >= min_distance:
            return pick, regret, float(d.min())
    return None


def difficulty_levels(size: np.ndarray) -> tuple[np.ndarray, tuple[float, float]]:
    """(level (E,) index into DIFFICULTIES, (q1, q2)): the tertiles of the BEC sizes ``size`` (E,)
    (numpy.quantile at 1/3 and 2/3); level "high" for size ≤ q1, "medium" for q1 < size ≤ q2,
    "low" for size > q2 (an edge counts as the harder side).  E ≥ 1."""
    size = np.asarray(size, np.float64)
    q1, q2 = (float(q) for q in np.quantile(size, [1 / 3, 2 / 3]))
    return np.where(size <= q1, 2, np.where(size <= q2, 1, 0)), (q1, q2)


def _eligible(table, free: np.ndarray) -> dict[int, np.ndarray]:
    """{test cluster c: rows (in table order) of the environments in ``free`` (M,) bool where θ*
    shows c, in c's class}."""
    domain = table.domain
    star_cluster = np.asarray(table.strategy[:, 0])
    env_class = np.asarray(table.env_class)
    return {c: np.flatnonzero(free & (star_cluster == c) & (env_class == domain.class_of_cluster[c]))
            for c in domain.test_clusters}


def _may_host_a_test(table, env_index: int, cluster: int, min_regret: float) -> bool:
    """Whether environment ``env_index`` has the alternatives a test of ``cluster`` needs under the
    relaxed rule (the weaker one): one of the cluster and three of its class, distinct, with
    θ*-regret >= min_regret.  The options' distance is not checked (it needs drawing)."""
    _, same, other = _alternatives(table, env_index, cluster, min_regret, relaxed=True)
    return len(same) >= 1 and len(other) >= 3


def graded(table, eligible: dict[int, np.ndarray], min_regret: float = MIN_REGRET
           ) -> tuple[dict[int, float], dict[int, int], tuple[float, float]]:
    """The difficulty of the eligible test environments ({cluster: rows}, :func:`_eligible`) that
    may host a test (:func:`_may_host_a_test`): ({row: BEC size}, {row: level index into
    DIFFICULTIES}, (q1, q2) the tertiles over them all, NaN when there is none)."""
    rows = np.array(sorted({int(m) for c, cand in eligible.items() for m in cand
                            if _may_host_a_test(table, int(m), c, min_regret)}), np.int64)
    if not len(rows):
        return {}, {}, (float("nan"), float("nan"))
    size = bec.environment_sizes(table, rows)
    level, edges = difficulty_levels(size)
    return (dict(zip(rows.tolist(), size.tolist(), strict=True)),
            dict(zip(rows.tolist(), level.tolist(), strict=True)), edges)


def select_test_set(table, training_env_ids: list[list[int]], seed: int = 0, min_regret: float = MIN_REGRET,
                    min_distance: float | None = None, max_tries: int = MAX_TRIES,
                    skip_missing: bool = False, difficulty: str | None = None) -> list[dict]:
    """One test environment per cluster of the domain's test_clusters, disjoint from every training sequence.

    Returns, in cluster order, dicts with env_id, env_index, cluster,
    cluster_name, env_class, min_option_distance and options: 4 dicts
    {theta_index, is_theta_star, cluster, regret} in a seeded random order.
    difficulty: None (any environment) or one of DIFFICULTIES: each test only among its cluster's
    environments of that level (module docstring); the dicts then also hold difficulty, bec_size
    (the environment's, in [0, 1]) and bec_tertiles ([q1, q2] over every eligible environment).
    Raises TestSetError when some cluster has no acceptable environment (of that difficulty), unless
    ``skip_missing`` (closed-loop check questions: as many clusters as the environments left over allow).
    """
    if difficulty is not None and difficulty not in DIFFICULTIES:
        raise ValueError(f"unknown test difficulty {difficulty!r}; choose from {', '.join(DIFFICULTIES)}")
    rng = np.random.default_rng(seed)
    domain = table.domain
    if min_distance is None:
        min_distance = domain.min_option_distance
    used = {int(e) for seq in training_env_ids for e in seq}
    env_ids = np.asarray(table.env_ids)
    eligible = _eligible(table, ~np.isin(env_ids, list(used)))
    if difficulty is not None:
        size, level, edges = graded(table, eligible, min_regret)
        wanted = DIFFICULTIES.index(difficulty)
    out = []
    for c in domain.test_clusters:
        cand = eligible[c]
        of_level = ""
        if difficulty is not None:
            cand = np.array([m for m in cand if level.get(int(m)) == wanted], np.int64)
            of_level = f" of {difficulty} difficulty"
        drawn = None
        for rule in ("design", "relaxed"):
            for m in rng.permutation(cand):
                drawn = _draw_options(table, int(m), c, rng, min_regret, min_distance, max_tries,
                                      relaxed=rule == "relaxed")
                if drawn is not None:
                    break
            if drawn is not None:
                break
        else:
            if skip_missing:
                continue
            raise TestSetError(
                f"no test environment{of_level} for cluster '{domain.cluster_names[c]}': {len(cand)} unused "
                f"environments{of_level} show it, none has 3 alternatives of its class's strategies (at least 1 of "
                f"this one) with θ*-regret >= {min_regret:g} that are pairwise >= {min_distance:g} apart")
        pick, regret, dmin = drawn
        strat = table.strategy[m]
        options = [{"theta_index": t, "is_theta_star": t == 0, "cluster": int(strat[t]),
                    "regret": float(regret[t])} for t in pick]
        options = [options[i] for i in rng.permutation(4)]
        test = {"env_id": int(env_ids[m]), "env_index": int(m), "cluster": c,
                "cluster_name": domain.cluster_names[c],
                "env_class": domain.class_names[domain.class_of_cluster[c]], "rule": rule,
                "min_option_distance": dmin, "options": options}
        if difficulty is not None:
            test.update(difficulty=difficulty, bec_size=size[int(m)], bec_tertiles=list(edges))
        out.append(test)
    return out
