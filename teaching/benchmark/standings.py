"""Ranking the selectors of one table for one learner, with ties where the seeds cannot tell them apart.

A selector's score is the learner's P(θ*) at the end of its sequence, one value per seed.  Two selectors are
compared by a paired test over the seeds they share (the same seed drives both selections' randomness and nothing
else differs): Student's paired t.  Two degenerate cases are decided without it: equal under every seed, to within
EQUAL (p = 1: the page shows P(θ*) to three decimals, and a difference it cannot show is not ranked), and differing
by the same amount under every seed (p = 0, the difference has no doubt in it; t is infinite).  Every pair of one
(table, learner) is a family, Holm-corrected (statsmodels).

The ranking: selectors in order of their mean, best first; a selector shares the rank of the tie group above it
unless it is significantly worse (adjusted p < ALPHA) than that group's leader, else it opens a new group whose
rank is its place (standard competition ranking: 1, 1, 3).  So a tie always means "not told apart from the best
of its group", whatever lies further down.
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
from scipy import stats
from statsmodels.stats.multitest import multipletests

ALPHA = 0.05  # the family-wise error rate of one (table, learner)'s comparisons
EQUAL = 5e-4  # of a probability: half the last of the three decimals the leaderboard shows


@dataclass(frozen=True)
class Standing:
    selector: str
    rank: int  # 1 = best; tied selectors share one
    tied: bool  # whether another selector holds the same rank
    mean: float  # mean final P(θ*) over seeds
    seeds: int


def finals_by_seed(results: list[dict], learner: str) -> dict[str, dict[int, float]]:
    """selector -> {seed: final P(θ*)} of one learner's cells (a refused selector, or an empty sequence, is left
    out: it has no score)."""
    found: dict[str, dict[int, float]] = {}
    for r in results:
        cell = r["cell"]
        if cell["learner"] == learner and "error" not in r and r["p_theta_star"]:
            found.setdefault(cell["selector"], {})[int(cell["seed"])] = float(r["p_theta_star"][-1])
    return found


def paired_p(a: np.ndarray, b: np.ndarray) -> float:
    """Two-sided p of the paired difference a - b (equal-length arrays, one entry per seed)."""
    d = np.asarray(a, np.float64) - np.asarray(b, np.float64)
    if np.all(np.abs(d) < EQUAL):
        return 1.0
    if np.ptp(d) == 0 or d.size < 2:
        return 0.0 if d.size >= 2 else 1.0  # one seed tells nothing; many alike, everything
    return float(stats.ttest_rel(a, b).pvalue)


def holm(pvalues: list[float]) -> list[float]:
    """Holm's step-down adjusted p-values, in the order given."""
    if not pvalues:
        return []
    return multipletests(pvalues, alpha=ALPHA, method="holm")[1].tolist()


def adjusted_pairs(scores: dict[str, dict[int, float]]) -> dict[frozenset, float]:
    """Holm-adjusted p of every pair of selectors, over the seeds each pair shares."""
    pairs = list(itertools.combinations(sorted(scores), 2))
    raw = []
    for a, b in pairs:
        seeds = sorted(scores[a].keys() & scores[b].keys())
        raw.append(paired_p(np.array([scores[a][s] for s in seeds]), np.array([scores[b][s] for s in seeds])))
    return {frozenset(p): q for p, q in zip(pairs, holm(raw), strict=True)}


def rank(scores: dict[str, dict[int, float]]) -> list[Standing]:
    """The standings of `scores` (selector -> {seed: final P(θ*)}), best first, as the module says."""
    means = {s: float(np.mean(list(v.values()))) for s, v in scores.items() if v}
    order = sorted(means, key=lambda s: (-means[s], s))
    adjusted = adjusted_pairs({s: scores[s] for s in order})
    ranks, leader = {}, None
    for place, name in enumerate(order, 1):
        if leader is None or adjusted[frozenset((leader, name))] < ALPHA:
            leader, group_rank = name, place
        ranks[name] = group_rank
    counts = {r: list(ranks.values()).count(r) for r in set(ranks.values())}
    return [Standing(s, ranks[s], counts[ranks[s]] > 1, means[s], len(scores[s])) for s in order]


def rank_label(standing: Standing) -> str:
    """"1", or "=2" for a rank shared with another selector."""
    return f"={standing.rank}" if standing.tied else str(standing.rank)
