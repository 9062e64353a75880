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

Tests may be graded by difficulty (:mod:`teaching.core.difficulty`): the eligible test environments are
every environment in no training sequence in which θ* shows one of the test clusters (in that
cluster's class) and in which some option set meets the thresholds (every set looked at, not sampled:
``_exact_draw``), graded by the exact size of their BEC.  With a difficulty, each test
is drawn among its cluster's environments of that level, relaxing in this order until one has options:
the level on the scale of every test cluster's environments with the design rule, then the relaxed
rule; then the level on its own cluster's scale, design then relaxed.  When none has, the TestSetError
says how many of the cluster's environments each level has on both scales.
"""
from __future__ import annotations

import numpy as np

from .difficulty import DIFFICULTIES, grade
from .domain import siblings

MIN_REGRET = 1e-3  # θ*-reward units; on the demo table |θ*·φ(ξ^θ*)| has median 0.039 (see docs/teaching.md)
# option sets drawn per environment: 50 missed sets that exist (on one demo table no
# environment of one cluster passed in 50, one 0.87 apart passed in 200)
MAX_TRIES = 200
_PAIRS = np.triu_indices(4, 1)  # the 6 pairs among a test's 4 options


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


def select_test_set(table, training_env_ids: list[list[int]], seed: int = 0, min_regret: float = MIN_REGRET,
                    min_distance: float | None = None, max_tries: int = MAX_TRIES,
                    skip_missing: bool = False, difficulty: str | None = None) -> list[dict]:
    """One test environment per cluster of the domain's test_clusters, disjoint from every training sequence.

    Returns, in cluster order, dicts with env_id, env_index, cluster,
    cluster_name, env_class, min_option_distance and options: 4 dicts
    {theta_index, is_theta_star, cluster, regret} in a seeded random order.
    difficulty: None (any environment) or one of DIFFICULTIES: each test only among its cluster's
    environments of that level (module docstring); the dicts then also hold difficulty, bec_size
    (the environment's exact size, in [0, 1]), bec_tertiles ([q1, q2] it was graded by) and graded
    ("all" or "cluster": which environments' tertiles).  Raises TestSetError when some cluster has no
    acceptable environment (of that difficulty), unless ``skip_missing`` (closed-loop check questions:
    as many clusters as the environments left over allow).
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
    grading = None
    if difficulty is not None:
        hosts = _hosts(table, eligible, seed, min_regret, min_distance)
        grading = grade(table, {c: sorted(found) for c, found in hosts.items()})
    out = []
    for c in domain.test_clusters:
        if grading is None:
            drawn = _draw_test(table, c, eligible[c], rng, min_regret, min_distance, max_tries)
        else:
            drawn = _graded_test(hosts[c], grading.candidates(c, difficulty), rng)
        if drawn is None:
            if skip_missing:
                continue
            raise TestSetError(_no_test(table, c, eligible[c], grading, difficulty, min_regret, min_distance))
        m, rule, scale, (pick, regret, dmin) = drawn
        strat = table.strategy[m]
        options = [{"theta_index": t, "is_theta_star": t == 0, "cluster": int(strat[t]),
                    "regret": float(regret[t])} for t in pick]
        options = [options[i] for i in rng.permutation(4)]
        test = {"env_id": int(env_ids[m]), "env_index": int(m), "cluster": c,
                "cluster_name": domain.cluster_names[c],
                "env_class": domain.class_names[domain.class_of_cluster[c]], "rule": rule,
                "min_option_distance": dmin, "options": options}
        if grading is not None:
            test.update(difficulty=difficulty, **grading.record(int(m), scale))
        out.append(test)
    return out


def _draw_test(table, cluster: int, cand, rng, min_regret, min_distance, max_tries):
    """(row, rule, None, options) of the first environment of ``cand`` (rows, in a seeded random order),
    under the design rule and then the relaxed one, whose options meet the thresholds; None if none."""
    for rule in ("design", "relaxed"):
        for m in rng.permutation(np.asarray(cand, np.int64)):
            drawn = _draw_options(table, int(m), cluster, rng, min_regret, min_distance, max_tries,
                                  relaxed=rule == "relaxed")
            if drawn is not None:
                return int(m), rule, None, drawn
    return None


def _hosts(table, eligible: dict[int, np.ndarray], seed: int, min_regret, min_distance) -> dict:
    """{cluster: {row: (rule, options)}}: the eligible environments that can host a test, each with its
    options drawn (:func:`_exact_draw`, a generator of its own seeded by ``seed`` and the row), under the
    design rule or else the relaxed one.  Graded tests are graded among these alone: an environment no
    test can be drawn in is no test's level."""
    hosts = {}
    for c, cand in eligible.items():
        hosts[c] = {}
        for m in (int(m) for m in cand):
            key = ("test host", m, c, seed, min_regret, min_distance)
            if key not in table.memo:
                table.memo[key] = (_exact_draw(table, m, c, np.random.default_rng([seed, m]), min_regret, min_distance)
                                   if _may_host_a_test(table, m, c, min_regret) else None)
            if table.memo[key] is not None:
                hosts[c][m] = table.memo[key]
    return hosts


def _exact_draw(table, env_index: int, cluster: int, rng, min_regret, min_distance):
    """(rule, (pick, regret, min distance)) for a test in ``env_index``, drawn uniformly among every option
    set that meets the thresholds (θ*, one of the cluster, two others, all pairwise >= min_distance), under
    the design rule or else the relaxed one; None when no set does.  Exact where :func:`_draw_options`
    samples: every set is looked at, through the distances among the alternatives far enough from θ*."""
    for rule in ("design", "relaxed"):
        regret, same, other = _alternatives(table, env_index, cluster, min_regret, relaxed=rule == "relaxed")
        if not len(same) or len(other) < 2:
            continue
        pool = np.unique(np.concatenate([same, other]))
        states = np.asarray(table.states(env_index, np.concatenate([[0], pool])), np.float64)
        # every option must lie min_distance from θ*'s: the pairs among those alone
        far = np.flatnonzero(table.domain.euclidean_distance(states[:1], states[1:]) >= min_distance)
        pool, states = pool[far], states[np.r_[0, far + 1]]
        d = table.domain.euclidean_distance(states[:, None], states[None])  # (1 + P, 1 + P), θ* first
        at = {int(t): i + 1 for i, t in enumerate(pool)}  # θ -> its row of d
        others = other[np.isin(other, pool)]
        sets = []  # (first, (k, 2) pairs of others that go with it)
        for first in same[np.isin(same, pool)].tolist():
            ok = others[others != first]
            ok = ok[d[at[first], [at[t] for t in ok.tolist()]] >= min_distance] if len(ok) else ok
            if len(ok) < 2:
                continue
            rows = np.array([at[t] for t in ok.tolist()])
            i, j = np.triu_indices(len(ok), 1)
            keep = d[rows[i], rows[j]] >= min_distance
            if keep.any():
                sets.append((first, np.stack([ok[i[keep]], ok[j[keep]]], axis=1)))
        if sets:
            counts = np.array([len(pairs) for _, pairs in sets], np.float64)
            first, pairs = sets[int(rng.choice(len(sets), p=counts / counts.sum()))]
            o1, o2 = (int(t) for t in pairs[int(rng.integers(len(pairs)))])
            pick = [0, first, o1, o2]
            rows = [0 if t == 0 else at[t] for t in pick]
            return rule, (pick, regret, float(d[np.ix_(rows, rows)][_PAIRS].min()))
    return None


def _graded_test(hosts: dict, pools, rng):
    """(row, rule, scale, options): an environment drawn uniformly among the pool's ``hosts`` (a cluster's
    {row: (rule, options)}), pool by pool (``[(scale, rows)]``), design-rule hosts before relaxed ones."""
    for scale, pool in pools:
        for rule in ("design", "relaxed"):
            rows = [m for m in pool if hosts[m][0] == rule]
            if rows:
                m = rows[int(rng.integers(len(rows)))]
                return m, rule, scale, hosts[m][1]
    return None


def _no_test(table, c: int, cand, grading, difficulty, min_regret: float, min_distance: float) -> str:
    """Why cluster c has no test (one line), with what to ask for instead where a difficulty was asked."""
    name = table.domain.cluster_names[c]
    options = (f"3 alternatives of its class's strategies (at least 1 of this one) with θ*-regret >= {min_regret:g} "
               f"that are pairwise >= {min_distance:g} apart")
    if grading is None:
        return f"no test environment for cluster '{name}': {len(cand)} unused environments show it, none has {options}"
    hosts = len(grading.rows[c])
    if not hosts:
        return (f"no test environment of {difficulty} difficulty for cluster '{name}': none of its {len(cand)} unused "
                f"environments has {options}, whatever the difficulty; ask for no difficulty, or lower "
                "--min-option-distance or --min-regret")
    return (f"no test environment of {difficulty} difficulty for cluster '{name}': of its {hosts} unused environments "
            f"with {options}, {grading.counts(c)}; ask for another difficulty, or none")
