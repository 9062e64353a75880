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
"""
from __future__ import annotations

import numpy as np

from .domain import siblings

MIN_REGRET = 1e-3  # θ*-reward units; on the demo table |θ*·φ(ξ^θ*)| has median 0.039 (see docs/teaching.md)
# option sets drawn per environment: 50 missed sets that exist (on one demo table no
# environment of one cluster passed in 50, one 0.87 apart passed in 200)
MAX_TRIES = 200


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


def _draw_options(table, env_index: int, cluster: int, rng, min_regret, min_distance, max_tries,
                  relaxed: bool = False):
    """[θ*, same-cluster θ, other-cluster θ, other-cluster θ] or None when rejected; relaxed: the last
    two from either cluster of the class."""
    regret = theta_star_regret(table, env_index)
    strat = np.asarray(table.strategy[env_index])
    same = _distinct(table, env_index, np.flatnonzero((strat == cluster) & (regret >= min_regret)))
    wanted = np.isin(strat, siblings(table.domain, cluster)) | ((strat == cluster) if relaxed else False)
    other = _distinct(table, env_index, np.flatnonzero(wanted & (regret >= min_regret)))
    if len(same) < 1 or len(other) < 2 + relaxed:
        return None
    pool = np.concatenate([[0], same, other])
    dist = pairwise_distance(table.domain, np.asarray(table.states(env_index, pool), np.float64))
    pos = {int(t): i for i, t in enumerate(pool)}
    for _ in range(max_tries):
        first = int(rng.choice(same))
        rest = other[other != first]
        if len(rest) < 2:
            return None
        pick = [0, first, *map(int, rng.choice(rest, size=2, replace=False))]
        idx = [pos[t] for t in pick]
        d = dist[np.ix_(idx, idx)][np.triu_indices(4, 1)]
        if d.min() >= min_distance:
            return pick, regret, float(d.min())
    return None


def select_test_set(table, training_env_ids: list[list[int]], seed: int = 0, min_regret: float = MIN_REGRET,
                    min_distance: float | None = None, max_tries: int = MAX_TRIES,
                    skip_missing: bool = False) -> list[dict]:
    """One test environment per cluster of the domain's test_clusters, disjoint from every training sequence.

    Returns, in cluster order, dicts with env_id, env_index, cluster,
    cluster_name, env_class, min_option_distance and options: 4 dicts
    {theta_index, is_theta_star, cluster, regret} in a seeded random order.
    Raises TestSetError when some cluster has no acceptable environment, unless ``skip_missing``
    (closed-loop check questions: as many clusters as the environments left over allow).
    """
    rng = np.random.default_rng(seed)
    domain = table.domain
    if min_distance is None:
        min_distance = domain.min_option_distance
    used = {int(e) for seq in training_env_ids for e in seq}
    env_ids = np.asarray(table.env_ids)
    star_cluster = np.asarray(table.strategy[:, 0])
    env_class = np.asarray(table.env_class)
    free = ~np.isin(env_ids, list(used))
    out = []
    for c in domain.test_clusters:
        cand = np.flatnonzero(free & (star_cluster == c) & (env_class == domain.class_of_cluster[c]))
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
                f"no test environment for cluster '{domain.cluster_names[c]}': {len(cand)} unused environments "
                f"show it, none has 3 alternatives of its class's strategies (at least 1 of this one) with "
                f"θ*-regret >= {min_regret:g} that are pairwise >= {min_distance:g} apart")
        pick, regret, dmin = drawn
        strat = table.strategy[m]
        options = [{"theta_index": t, "is_theta_star": t == 0, "cluster": int(strat[t]),
                    "regret": float(regret[t])} for t in pick]
        options = [options[i] for i in rng.permutation(4)]
        out.append({"env_id": int(env_ids[m]), "env_index": int(m), "cluster": c,
                    "cluster_name": domain.cluster_names[c],
                    "env_class": domain.class_names[domain.class_of_cluster[c]], "rule": rule,
                    "min_option_distance": dmin, "options": options})
    return out
