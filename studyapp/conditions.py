"""Conditions of the user study and their factors (model, distance, determinism, coverage).

Names, aliases and constants shared by the rest of the analysis; see the input-table schema and
the analysis choices in :mod:`studyapp.analysis.stats`.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from teaching.api import APPROX_STAR, CONDITIONS, get_domain

if TYPE_CHECKING:  # the worker and the participant pages import this module, and pandas costs 0.3 s
    import pandas as pd

APPROX_STAR_DEFAULT = APPROX_STAR  # the analysis' default is the selectors' (teaching.core.selection)
COVERAGE_APPROX = "coverage-approx*"
COVERAGE_RANDOM = "coverage-random"
PAPER_CONDITIONS = CONDITIONS  # the teaching selectors' names, in the paper's order
APPROX_CONDITIONS = ("det-reward", "det-euclidean", "det-strategy", "prob-reward", "prob-euclidean")
DETERMINISM = {"det": "deterministic", "prob": "probabilistic"}
DISTANCES = ("reward", "euclidean", "strategy")

MIN_PER_GROUP = 2      # Welch's t and every ANOVA cell need a variance
MIN_PEARSON = 4        # Fisher-z CI needs n > 3
# A spread (SD, residual RMS) this small relative to the scores' own size is rounding, not variance:
# identical scores leave ~1e-16 of floating-point noise, which an F or t would divide by.
SPREAD_RTOL = 1e-9


def negligible_spread(spread: float, values) -> bool:
    """Whether `spread` is zero up to rounding, relative to the size of `values` (an array of scores)."""
    scale = float(np.sqrt(np.mean(np.square(np.asarray(values, float))))) if len(values) else 0.0
    return not spread > SPREAD_RTOL * scale


@dataclass(frozen=True)
class Clusters:
    """A study's strategy clusters, as its domain names and groups them (Domain.cluster_names,
    Domain.class_of_cluster): what the examples-per-cluster grid, its figure and the helpful-examples
    correlation count in.  names: C + 1 (the last is "no strategy"); class_of_cluster: (C,)."""

    names: tuple[str, ...]
    class_of_cluster: tuple[int, ...]

    @classmethod
    def of(cls, domain) -> Clusters:
        return cls(tuple(domain.cluster_names), tuple(int(k) for k in domain.class_of_cluster))

    @property
    def n(self) -> int:
        return len(self.class_of_cluster)

    def name(self, c) -> str:
        return self.names[int(c)] if 0 <= int(c) < len(self.names) else str(c)

    def siblings(self, c) -> tuple[int, ...]:
        """The other clusters of `c`'s class: the strategies a test in cluster `c` contrasts it with."""
        c = int(c)
        if not 0 <= c < self.n:
            return ()
        return tuple(k for k, cls in enumerate(self.class_of_cluster) if cls == self.class_of_cluster[c] and k != c)

    def class_starts(self) -> list[int]:
        """The clusters that begin a new class, after the first: where a grid draws a class boundary."""
        return [k for k in range(1, self.n) if self.class_of_cluster[k] != self.class_of_cluster[k - 1]]


def default_clusters() -> Clusters:
    """The default domain's clusters: those of tables of responses made by hand, which name no domain."""
    return Clusters.of(get_domain())


ALIASES = {
    "det-euclid": "det-euclidean", "prob-euclid": "prob-euclidean", "strategy": "det-strategy",
    "prob-strategy": "det-strategy", "coverage-approx": COVERAGE_APPROX, "coverage-approx-star": COVERAGE_APPROX,
}


def canonical(condition) -> str:
    """The analysis' name of a condition, as the teaching selectors spell it; short spellings a
    researcher may type ("det-euclid", "prob-euclid", "strategy") and "_" for "-" are accepted."""
    name = str(condition).strip().lower().replace("_", "-")
    return ALIASES.get(name, name) if name in ALIASES or name in PAPER_CONDITIONS else str(condition)


class ConditionError(ValueError):
    """Condition names (of a study, or named for a comparison) that cannot be used as they are;
    the message names them."""


def aliased_pairs(names) -> list[tuple[str, str, str]]:
    """(first, other, canonical) for each name in `names` that is another spelling of an earlier
    one: "det-euclid" after "det-euclidean", "prob-strategy" after "det-strategy" (the same learner,
    so the same sequence), "Exact" after "exact".  Repeats of one exact name are not aliases."""
    first: dict[str, str] = {}
    pairs = []
    for name in names:
        c = canonical(name)
        if first.setdefault(c, name) != name:
            pairs.append((first[c], name, c))
    return pairs


def check_distinct_conditions(names) -> None:
    """A ConditionError naming every pair of `names` that denote one condition: the analysis keys
    groups by the canonical name, so two of them would be merged into one group (their
    participants pooled, their training sequences counted together)."""
    pairs = aliased_pairs(names)
    if pairs:
        raise ConditionError("; ".join(f"conditions {a!r} and {b!r} are one condition ({c})" for a, b, c in pairs)
                             + ": a study may name each condition once; keep one of the names")


def canonicalize(df: pd.DataFrame) -> pd.DataFrame:
    """`df` with its conditions under their canonical names; a ConditionError if two of its names
    are one condition (they would become one group)."""
    if "condition" in df.columns and len(df):
        check_distinct_conditions(df["condition"].dropna().unique())
        df = df.copy()
        df["condition"] = df["condition"].map(canonical)
    return df


def condition_factors(condition: str, approx_star: str = APPROX_STAR_DEFAULT) -> dict:
    """Factors of a condition from its name (the paper's nine names; anything else is "other")."""
    out = {"model": "other", "distance": np.nan, "determinism": np.nan, "coverage": False}
    name = condition
    if condition.startswith("coverage-"):
        out["coverage"] = True
        name = condition[len("coverage-"):]
        if name == "approx*":
            name = approx_star
    if name == "exact":
        out["model"] = "exact"
    elif name == "random":
        out["model"] = "random"
    else:
        det, _, dist = name.partition("-")
        if det in DETERMINISM and dist in DISTANCES:
            out.update(model="approximate", distance=dist, determinism=DETERMINISM[det])
    return out


def label(condition: str, approx_star: str = APPROX_STAR_DEFAULT) -> str:
    return f"approx* ({condition})" if condition == approx_star else condition

