"""The defaults every domain would otherwise write again: :class:`BaseDomain`.

A domain subclasses it, sets the members of :class:`~teaching.core.domain.Domain` that are its own
(name, classes, clusters, features, presets, the planner, the page) and overrides only the methods
where it differs from these defaults:

* θ* is parsed as cost weights (every feature a cost, so every weight negative);
* features are counted in one unit: every normaliser is 1;
* the sample of a preset gives every class an equal share, for any number of classes;
* a page carries exactly the ``page_keys`` of a stored payload, drawn by the scene of the domain's
  name, with no caption above a canvas and nothing shared across a study's canvases;
* the code that decides a table's bytes is the domain's package (``code_root``) plus any shared
  packages it names in ``extra_code_roots`` (``code_roots``, which the code fingerprint reads).
"""
from __future__ import annotations

from collections.abc import Mapping
from functools import cached_property
from pathlib import Path
from types import MappingProxyType

import numpy as np


def parse_cost_weights(values, n: int) -> tuple[float, ...]:
    """θ* from n numbers (a sequence, or "v1,v2,..."), each finite and negative: for a domain whose
    features are all costs.  Raises ValueError with a one-line message."""
    if isinstance(values, str):
        parts = [v for v in values.replace(" ", "").split(",") if v]
        try:
            values = [float(v) for v in parts]
        except ValueError:
            raise ValueError(f"theta* must be {n} numbers separated by commas, got {values!r}") from None
    star = tuple(float(v) for v in values)
    if len(star) != n:
        raise ValueError(f"theta* needs one weight per feature ({n}), got {len(star)}")
    if not all(np.isfinite(v) and v < 0 for v in star):
        raise ValueError(f"every weight of theta* must be a negative number (the features are costs), got {list(star)}")
    return star


def stratified_sample(classes: np.ndarray, n_classes: int, n: int, seed: int = 0) -> np.ndarray:
    """Sorted int64 ids of a seeded sample of n of the environments whose classes are `classes`
    ((n_environments,) int, indices into a domain's class_names): an equal share per class (shares
    differ by at most one, the rounding of n's even split), fewer where a class has fewer members.

    The informative classes are over-represented relative to the whole set, on purpose: they are
    where teaching happens.  Each class draws its members in class order from one generator, so a
    sample is a function of (classes, n, seed) alone."""
    classes = np.asarray(classes)
    if n < n_classes or n > len(classes):
        raise ValueError(f"sample size must lie in [{n_classes}, {len(classes)}]")
    rng = np.random.default_rng(seed)
    picks = []
    for c, share in enumerate(np.diff(np.linspace(0, n, n_classes + 1).round().astype(int))):
        members = np.flatnonzero(classes == c)
        picks.append(rng.choice(members, size=min(share, len(members)), replace=False))
    return np.sort(np.concatenate(picks))


class BaseDomain:
    """Defaults of a :class:`~teaching.core.domain.Domain` (module docstring).  A subclass still
    sets the data members and implements environment_class, planner_identity, plan_chunk, states,
    euclidean_distance, fingerprint, scene_payload and path_rows (and render_sheet for a contact
    sheet)."""

    code_root: Path
    # shared packages outside code_root whose source also decides this domain's tables
    extra_code_roots: tuple[Path, ...] = ()
    # language -> its texts (ParticipantTexts) -> their translation, for texts the project's catalogs cannot
    # hold (a domain's data written by a researcher); none: the catalogs translate every text
    translations: Mapping[str, Mapping[str, str]] = MappingProxyType({})
    # where those translations are written, for a message asking for the missing ones ("": the catalogs)
    translations_source: str = ""
    # a text filled in from the domain's data -> (its marked template, the values): none, every text is fixed
    formatted_texts: Mapping[str, tuple[str, Mapping[str, str]]] = MappingProxyType({})

    @property
    def code_roots(self) -> tuple[Path, ...]:
        """Every package besides the core whose modules the code fingerprint covers."""
        return (Path(self.code_root), *map(Path, self.extra_code_roots))

    def parse_theta_star(self, values) -> tuple[float, ...]:
        return parse_cost_weights(values, len(self.feature_names))

    def default_normalisers(self) -> np.ndarray:
        return np.ones(len(self.feature_names))  # counts are already on one scale

    @cached_property
    def all_classes(self) -> np.ndarray:
        """(n_environments,) int8 class of every environment, computed once."""
        return np.asarray(self.environment_class(np.arange(self.n_environments)), np.int8)

    def stratified_sample(self, n: int, seed: int = 0) -> np.ndarray:
        return stratified_sample(self.all_classes, len(self.class_names), n, seed=seed)

    @property
    def scene(self) -> str:
        return self.name  # its own scenes/<name>.js

    def page_scene(self, payload: dict) -> dict:
        return {k: payload[k] for k in self.page_keys}

    def caption(self, payload: dict) -> tuple[str, str] | None:
        return None

    def study_view(self, scenes) -> dict:
        return {}

    def render_sheet(self, **kwargs) -> int:
        raise NotImplementedError(f"domain {self.name!r} draws no contact sheet (it needs render_sheet)")
