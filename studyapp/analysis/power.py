"""Planning a study's size: participants per condition needed to detect an effect (docs/decisions.md,
"Sample sizes by bisection").

The paper reports its comparisons as Welch t-tests between two conditions' mean scores, so
the effects here are two-sample effects (Cohen's d) and the sample sizes come from
statsmodels' ``TTestIndPower`` (two-sided, equal groups).

The paper gives p values and the total number of participants, not per-condition sizes or
standard deviations, so its effects are recovered from p assuming equal groups of the average
size: d = t * sqrt(1/n1 + 1/n2) with t the two-sided critical value of Student's t with
n1 + n2 - 2 degrees of freedom at that p (Welch's df is at most that; with equal groups and
similar spreads they agree).  These are estimates of the published effects, with the
uncertainty of a single small study: treat them as a lower bound on what to plan for.

Inputs are bounded (``input_problems``; the ``power`` command and the dashboard's form use the
same bounds and messages): α in [0.0001, 0.5], power above α (at d -> 0 a test's power *is* α,
so no n reaches a power at or below it) and at most 0.999, Cohen's d in [0.05, 5], each finite.
The sample size is the smallest whole n >= 2 whose power (statsmodels' ``TTestIndPower.power``)
reaches the target, found by bisection: statsmodels' ``solve_power`` returns NaN when 2 per
group already exceed the target (large d, large α) and, at α = .001 and power .99, an n whose
power is short of the target, so it is not used.  Both come from SciPy's noncentral t giving NaN
for a tail that is all but 0 or 1 (SciPy 1.17): ``_power`` then takes that tail from its complement.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from scipy import stats
from statsmodels.stats.power import TTestIndPower


@dataclass(frozen=True)
class PaperEffect:
    comparison: str
    p: float   # the reported two-sided Welch p
    n1: int    # participants per group assumed (see the module docstring)
    n2: int
    where: str

    @property
    def d(self) -> float:
        return effect_from_p(self.p, self.n1, self.n2)


# "User Study": 161 non-filtered participants over six conditions (about 27 each);
# "User Study on Coverage": 53 non-filtered over four conditions (about 13 each).
PAPER_EFFECTS = (
    PaperEffect("approx* vs exact", 0.025, 27, 27, "User Study: 161 participants over 6 conditions"),
    PaperEffect("coverage-approx* vs random", 0.049, 13, 13, "User Study on Coverage: 53 over 4 conditions"),
    PaperEffect("coverage-random vs random", 0.159, 13, 13, "User Study on Coverage (not significant)"),
)


def effect_from_p(p: float, n1: int, n2: int) -> float:
    """Cohen's d of a two-sided two-sample t-test with this p value and group sizes."""
    if not 0 < p < 1 or n1 < 2 or n2 < 2:
        raise ValueError(f"need 0 < p < 1 and groups of at least 2, got p={p}, n1={n1}, n2={n2}")
    t = stats.t.isf(p / 2, n1 + n2 - 2)
    return float(t * math.sqrt(1 / n1 + 1 / n2))


# The bounds of the inputs (see the module docstring); the dashboard's form reads them too.
ALPHA_MIN, ALPHA_MAX = 0.0001, 0.5
POWER_MAX = 0.999
D_MIN, D_MAX = 0.05, 5.0
N_MIN = 2            # a t-test needs a variance in each group
N_MAX = 10_000_000   # far above the largest n inside the bounds (38,990 at the corner: d .05, alpha .0001, power .999)


def alpha_problem(alpha) -> str | None:
    if not (isinstance(alpha, (int, float)) and ALPHA_MIN <= alpha <= ALPHA_MAX):
        return f"alpha must be a number from {ALPHA_MIN:g} to {ALPHA_MAX:g} (two-sided), got {alpha!r}"
    return None


def power_problem(power, alpha) -> str | None:
    floor = alpha if alpha_problem(alpha) is None else 0.0  # a bad alpha has its own message
    if not (isinstance(power, (int, float)) and floor < power <= POWER_MAX):
        above = f"alpha ({alpha:g})" if floor else "alpha"
        return (f"power must be above {above} and at most {POWER_MAX:g}, got {power!r}: a test's power "
                "at a vanishing effect is alpha itself, so no number of participants reaches less")
    return None


def effect_problem(d) -> str | None:
    if not (isinstance(d, (int, float)) and D_MIN <= d <= D_MAX):
        return f"an effect size (Cohen's d) must be a number from {D_MIN:g} to {D_MAX:g}, got {d!r}"
    return None


def input_problems(*, alpha, power=None, d=None) -> list[str]:
    """What is wrong with these inputs, one message each (empty: the sample size can be found)."""
    found = [alpha_problem(alpha), power_problem(power, alpha) if power is not None else None,
             effect_problem(d) if d is not None else None]
    return [m for m in found if m]


def _check(**inputs) -> None:
    problems = input_problems(**inputs)
    if problems:
        raise ValueError("; ".join(problems))


def participants_needed(d: float, *, alpha: float = 0.05, power: float = 0.8) -> int:
    """Participants per condition (equal groups) for a two-sided t-test to detect |d| with this power:
    the smallest n >= 2 whose power reaches it."""
    _check(alpha=alpha, power=power, d=d)

    def reaches(n: int) -> bool:
        return _power(d, n, alpha) >= power

    if reaches(N_MIN):
        return N_MIN
    low, high = N_MIN, 2 * N_MIN  # power grows with n: reaches(low) is False, find a high that reaches
    while not reaches(high):
        low, high = high, 2 * high
        if high > N_MAX:
            raise ValueError(f"more than {N_MAX:,} participants per condition would be needed")
    while high - low > 1:
        mid = (low + high) // 2
        low, high = (low, mid) if reaches(mid) else (mid, high)
    return high


def _power(d: float, n: int, alpha: float) -> float:
    """statsmodels' two-sided power of n per group.  Where it is NaN (SciPy's noncentral t answers
    NaN for some tails that are all but 0 or 1, e.g. d = 1, alpha = 1e-4, n = 50), the same two
    tails, P(T > crit) + P(T < -crit) with T ~ nct(2n - 2, d sqrt(n / 2)), each from whichever of
    SciPy's sf and 1 - cdf is finite."""
    p = float(TTestIndPower().power(effect_size=d, nobs1=n, alpha=alpha, ratio=1.0, alternative="two-sided"))
    if math.isfinite(p):
        return p
    df, nc = 2 * n - 2, d * math.sqrt(n / 2)
    crit = float(stats.t.isf(alpha / 2, df))
    return _tail_above(crit, df, nc) + _tail_above(crit, df, -nc)  # P(T < -c | nc) = P(T > c | -nc)


def _tail_above(t: float, df: int, nc: float) -> float:
    p = float(stats.nct.sf(t, df, nc))
    return p if math.isfinite(p) else 1.0 - float(stats.nct.cdf(t, df, nc))


def power_with(d: float, n_per_condition: int, *, alpha: float = 0.05) -> float:
    """The power of a two-sided t-test between two conditions of n participants each."""
    _check(alpha=alpha, d=d)
    if not (isinstance(n_per_condition, int) and n_per_condition >= N_MIN):
        raise ValueError(f"a t-test needs at least {N_MIN} participants per condition, got {n_per_condition!r}")
    return _power(d, n_per_condition, alpha)


def cohens_d(mean_a: float, sd_a: float, mean_b: float, sd_b: float) -> float | None:
    """Cohen's d of two equal groups, (mean_a - mean_b) / sqrt((sd_a² + sd_b²) / 2); None when neither
    group varies (a model that predicts every participant's score exactly)."""
    pooled = math.sqrt((sd_a ** 2 + sd_b ** 2) / 2)
    return (mean_a - mean_b) / pooled if pooled > 0 else None


def power_table(*, alpha: float = 0.05, power: float = 0.8, n_per_condition: int | None = None,
                effects: dict[str, float] | None = None, predicted: list[dict] | None = None) -> list[dict]:
    """One row per effect (the paper's, then the researcher's `effects`, name -> d, then the `predicted`
    rows, each {comparison, d, source} with d possibly None or of any size): d, the participants per
    condition needed, and the power at `n_per_condition` if given.  A predicted |d| below the smallest
    effect planned for (D_MIN) needs no number: its row's "needed" and power are None; one above D_MAX
    is planned as D_MAX (2 per condition suffice for either)."""
    rows = [{"comparison": e.comparison, "d": e.d, "source": f"p = {e.p:g} with {e.n1} + {e.n2} ({e.where})"}
            for e in PAPER_EFFECTS]
    rows += [{"comparison": name, "d": float(d), "source": "chosen by the researcher"}
             for name, d in (effects or {}).items()]
    rows += [dict(row, predicted=True) for row in predicted or []]
    for row in rows:
        d = row["d"]  # the paper's and the researcher's are checked (a ValueError names the bound)
        if row.get("predicted"):
            d = None if d is None else min(abs(d), D_MAX)
            if d is None or d < D_MIN:
                row["needed"], row["power_at_n"] = None, None
                continue
        row["needed"] = participants_needed(d, alpha=alpha, power=power)
        if n_per_condition:  # one per group has no variance: no t-test, no power
            row["power_at_n"] = power_with(d, n_per_condition, alpha=alpha) if n_per_condition >= N_MIN else 0.0
    return rows
