"""Planning a study's size: participants per condition needed to detect an effect (issue 13).

The paper reports its comparisons as Welch t-tests between two conditions' mean scores, so
the effects here are two-sample effects (Cohen's d) and the sample sizes come from
statsmodels' ``TTestIndPower`` (two-sided, equal groups).

The paper gives p values and the total number of participants, not per-condition sizes or
standard deviations, so its effects are recovered from p assuming equal groups of the average
size: d = t * sqrt(1/n1 + 1/n2) with t the two-sided critical value of Student's t with
n1 + n2 - 2 degrees of freedom at that p (Welch's df is at most that; with equal groups and
similar spreads they agree).  These are estimates of the published effects, with the
uncertainty of a single small study: treat them as a lower bound on what to plan for.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
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


def participants_needed(d: float, *, alpha: float = 0.05, power: float = 0.8) -> int:
    """Participants per condition (equal groups) for a two-sided t-test to detect |d| with this power."""
    _check(alpha=alpha, power=power)
    if not d > 0:
        raise ValueError(f"the effect size must be positive, got {d}")
    return math.ceil(TTestIndPower().solve_power(effect_size=d, alpha=alpha, power=power, ratio=1.0,
                                                 alternative="two-sided"))


def power_with(d: float, n_per_condition: int, *, alpha: float = 0.05) -> float:
    """The power of a two-sided t-test between two conditions of n participants each."""
    _check(alpha=alpha, power=0.5)
    return float(TTestIndPower().power(effect_size=d, nobs1=n_per_condition, alpha=alpha, ratio=1.0,
                                       alternative="two-sided"))


def power_table(*, alpha: float = 0.05, power: float = 0.8, n_per_condition: int | None = None,
                effects: dict[str, float] | None = None) -> list[dict]:
    """One row per effect (the paper's, then the researcher's `effects`, name -> d): d, the
    participants per condition needed, and the power at `n_per_condition` if given."""
    rows = [{"comparison": e.comparison, "d": e.d, "source": f"p = {e.p:g} with {e.n1} + {e.n2} ({e.where})"}
            for e in PAPER_EFFECTS]
    rows += [{"comparison": name, "d": float(d), "source": "chosen by the researcher"}
             for name, d in (effects or {}).items()]
    for row in rows:
        row["needed"] = participants_needed(row["d"], alpha=alpha, power=power)
        if n_per_condition:
            row["power_at_n"] = power_with(row["d"], n_per_condition, alpha=alpha)
    return rows


def _check(*, alpha: float, power: float) -> None:
    if not (0 < alpha < 1 and 0 < power < 1 and np.isfinite(alpha) and np.isfinite(power)):
        raise ValueError(f"alpha and power must lie strictly between 0 and 1, got alpha={alpha}, power={power}")
