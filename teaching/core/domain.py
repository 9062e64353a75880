"""The one thing the teaching core knows about a robot: the :class:`Domain` interface.

The core (learners, selection, evaluation, test set, tables and their building) works on a
table of optimal trajectories and on the labels and distances a domain gives it; it never
looks inside a trajectory.  A domain is the robot and its world: which environments exist,
how an objective θ turns into an optimal trajectory there, which *strategy* a trajectory
shows, and how far apart two trajectories are.  ``teaching/domains/<name>/`` holds one each;
docs/domains.md walks through adding one.

Vocabulary (the paper's, made general):

* **environment** - one situation the robot acts in, named by a stable integer id
  0 .. n_environments - 1 (the id's meaning is the domain's, and must never change: tables,
  studies and answers store ids);
* **class** - a kind of environment (the paper's four); classes are indexed into ``class_names``;
* **cluster** - a strategy, the coverage unit of the paper: what a trajectory *does*.
  Clusters 0 .. C-1 each belong to one class (``class_of_cluster``); two clusters of one
  class are *siblings* (the alternatives a test's options contrast); label C marks a
  trajectory showing none of its class's strategies (``n_clusters(domain)``);
* **features** - φ(ξ) (D,), normalised; an objective θ (D,) scores a trajectory by θ·φ(ξ);
* **states** - what the Euclidean learner compares, (..., T+1, S) per trajectory, already in
  the units ``euclidean_distance`` scales.

A table stores, per (environment, θ), the trajectory's *encoding* (``trajectory_shape``,
``trajectory_dtype``: a control sequence, a sequence of moves, ...) from which
the domain rebuilds its states, plus φ, the cluster and the distance to θ*'s trajectory.
"""
from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol, runtime_checkable

import numpy as np

from .i18n import gettext_noop as _


@dataclass(frozen=True)
class LegendEntry:
    """One swatch of a page's legend: its label and the palette colours of its fill, edge and
    (optionally) hatch, so the swatch looks like what the canvas draws; or a letter the canvas writes on a
    cell, shown as that letter."""

    label: str
    fill: str
    edge: str
    hatch: str = ""
    letter: str = ""  # a letter the canvas writes on a cell (S, G, D): the swatch is that letter instead


@dataclass(frozen=True)
class ComprehensionQuestion:
    """One multiple-choice question of a comprehension check on the instructions: its text, the choices
    shown (in this order) and the indices of the right ones (one or more; all of them must be ticked)."""

    text: str
    choices: tuple[str, ...]
    right: tuple[int, ...]


# The questions a domain that writes none of its own asks: they hold for any robot whose instructions
# say that examples come first and questions about new situations after them.
GENERIC_COMPREHENSION = (
    ComprehensionQuestion(_("What will you see before the questions?"),
             (_("Nothing: the questions come first"), _("Short examples of what the robot does"),
              _("A written test")), (1,)),
    ComprehensionQuestion(_("What do the questions after the examples ask you?"),
             (_("Your own preferences"), _("How quickly you can answer"),
              _("What the robot would do in situations you have not seen")), (2,)),
)


@dataclass(frozen=True)
class ParticipantTexts:
    """What a study's pages tell participants about this robot (plain text, no markup).

    instructions: paragraphs; ``{n_training}``, ``{n_tests}``, ``{training_plural}`` and
    ``{tests_plural}`` are filled in per participant.  The attention check asks one question with
    checkboxes; it is passed when exactly ``attention_correct`` is ticked.  consent: the default
    consent text (paragraphs separated by blank lines) a study without its own approved text shows.
    Every page a participant or researcher reads takes the robot's words from here, never a
    domain's words written into the web side."""

    summary: str  # one sentence for a recruiting platform's preview: "you watch ... and answer ..."
    consent: str
    instructions: tuple[str, ...]
    attention_question: str
    attention_choices: tuple[tuple[str, str], ...]  # (value stored, label shown)
    attention_correct: frozenset[str]
    watch: str  # under a training example: what to watch
    question: str  # a test's question: which option matches the robot
    legend: tuple[LegendEntry, ...]
    # what one of a test's options is called (a trajectory, in the robot's own word): researcher pages
    # and the data dictionary use it too
    option: str = _("option")
    # a test or check submitted without a choice
    choice_required: str = _("Please choose the option that matches the robot.")
    # a study's title when its researcher gives none (the demo's)
    title: str = _("What does the robot prefer?")
    # the comprehension check a study may ask after the instructions (Study.comprehension_check), unless the
    # study gives its own questions: each about what the instructions say, in the robot's words
    comprehension: tuple[ComprehensionQuestion, ...] = GENERIC_COMPREHENSION


# --- the interface, in three declared parts and an optional fourth ------------------------------
# A newcomer reads here what a domain must provide; teaching.core.checkdomain refuses a domain that lacks a
# member of a part, naming it.  Every member the project uses is declared in one part (a test scans the
# code for others); only shows_the_way probes for the optional part.


@runtime_checkable
class WorldPart(Protocol):
    """The numbers the core needs about the robot's world: its environments, their classes, the
    strategies (clusters), the features and θ*.  Shapes: D features, C clusters."""

    name: str  # registry key; stored in every table's meta.json
    n_environments: int  # environment ids are 0 .. n_environments - 1
    class_names: tuple[str, ...]  # (n_classes,) environment classes, the last one the uninformative "other"
    cluster_names: tuple[str, ...]  # (C + 1,): the C strategy clusters, then the name of "no strategy"
    class_of_cluster: np.ndarray  # (C,) int: the class each cluster belongs to
    test_clusters: tuple[int, ...]  # the clusters the test set covers, one test environment each
    feature_names: tuple[str, ...]  # (D,) what θ weighs, in order
    # lower-case words that are this robot's own (its world, classes and features) and that no module of
    # the core may use: a feature named with a plain English word ("turns") need not be one of them
    vocabulary: frozenset[str]
    theta_star: np.ndarray  # (D,) the default objective the robot teaches
    min_option_distance: float  # test options at least this far apart by default (euclidean_distance's units)

    def parse_theta_star(self, values) -> tuple[float, ...]:
        """θ* from D numbers (a sequence or "v1,v2,..."), checked for this domain's signs and
        length; ValueError with a one-line message otherwise."""
        ...

    def environment_class(self, env_ids: np.ndarray) -> np.ndarray:
        """(n,) ids -> (n,) int8 class index into ``class_names``."""
        ...

    def stratified_sample(self, n: int, seed: int = 0) -> np.ndarray:
        """(n,) sorted int64 ids: a seeded sample with a share for every class."""
        ...


@runtime_checkable
class PlannerPart(Protocol):
    """How a table of optimal trajectories is built and read back: the planner, the stored encoding,
    the states the Euclidean learner compares, and what decides a table's bytes.  Shapes: n
    environments, N objectives, D features, T+1 states of S numbers."""

    trajectory_shape: tuple[int, ...]  # one stored trajectory's encoding, per (environment, θ)
    trajectory_dtype: np.dtype
    code_root: Path  # the package whose source decides a table's bytes (with teaching/core)
    # code_root first, then every shared package outside it whose source also decides them (BaseDomain:
    # code_root and extra_code_roots); the code fingerprint covers them all
    code_roots: tuple[Path, ...]
    presets: tuple  # its teaching.core.build.Preset objects (names unique across domains)
    # (S,) the unit of each state column in euclidean_distance (inf: a column it does not compare): what a
    # table written out as a folder (teaching.importing.export) records with its paths
    state_scale: tuple

    def fingerprint(self) -> str:
        """16 hex digits over the world's constants: a table built under others is refused."""
        ...

    def default_normalisers(self) -> np.ndarray:
        """(D,) float64 feature scales (part of a table's identity)."""
        ...

    def planner_identity(self) -> dict:
        """What decides the planner's output (version, settings): part of a chunk's key."""
        ...

    def plan_chunk(self, env_ids: np.ndarray, thetas: np.ndarray, normalisers: np.ndarray) -> dict:
        """Optimal trajectories of every (environment, θ): env_ids (n,), thetas (N, D) with
        θ* = thetas[0].  Returns controls (n, N, *trajectory_shape) trajectory_dtype, features
        (n, N, D) float64 normalised, strategy (n, N) int8 cluster (C = none), d_euclid (n, N)
        float32 distance of each trajectory to θ*'s."""
        ...

    def states(self, controls: np.ndarray) -> np.ndarray:
        """Stored encodings (..., *trajectory_shape) -> states (..., T+1, S) float64."""
        ...

    def euclidean_distance(self, states_a: np.ndarray, states_b: np.ndarray) -> np.ndarray:
        """(..., T+1, S) x (..., T+1, S) -> (...) the Euclidean learner's distance, in scaled
        state units, broadcast over the leading axes."""
        ...


@runtime_checkable
class PagesPart(Protocol):
    """What people see of the robot: the study's pages (docs/domains.md "The web side": the scene that
    draws an environment, its texts and colours) and the researcher's contact sheet."""

    texts: ParticipantTexts
    palette: Mapping[str, str]  # colour name -> CSS colour: the page's --scene-<name>, the canvas, the sheet
    page_keys: tuple[str, ...]  # what a participant's page may carry of a stored scene payload
    # the scene that draws it: static/studyapp/scenes/<scene>.js and .css (its name, unless domains
    # share one, as every grid world from a file shares "world")
    scene: str
    # language -> one of its texts -> its translation, for texts no catalog of the web side holds (a
    # domain's data, written by a researcher); BaseDomain: none, every text is in the catalogs
    translations: Mapping[str, Mapping[str, str]]
    translations_source: str  # where those translations are written, for a message asking for more ("")
    # a text filled in from the domain's data -> (the marked template, {name: value}), so that the web side
    # translates the template and fills it in (BaseDomain: none)
    formatted_texts: Mapping[str, tuple[str, Mapping[str, str]]]

    def scene_payload(self, env_id: int) -> dict:
        """JSON of environment `env_id` that static/studyapp/scenes/<scene>.js draws (with page_keys
        among its keys; other keys are for researchers only and never reach a participant's page)."""
        ...

    def path_rows(self, states: np.ndarray) -> list:
        """One trajectory's states (T+1, S) -> the JSON rows the scene animates, every payload's dt s."""
        ...

    def page_scene(self, payload: dict) -> dict:
        """The page_keys of a stored payload: what a participant's page may carry of it."""
        ...

    def caption(self, payload: dict) -> tuple[str, str] | None:
        """(label, value) a page shows above this environment's canvas, e.g. what the robot is asked
        to do there; None: nothing beyond texts.watch."""
        ...

    def study_view(self, scenes: list[tuple[dict, list]]) -> dict:
        """Values every canvas of one study shares, from all its (page scene, path rows): a common
        scale, say, so the same motion looks the same in training and at test; {} if none."""
        ...

    def render_sheet(self, *, table, conditions: dict, tests: list | None, out, no_tests: str | None, caption: str,
                     columns: int, dpi: int) -> int:
        """Draw the contact sheet (teaching.core.sheet: rows, layout) of these examples and tests to
        the PNG `out`; returns the panels drawn."""
        ...


@runtime_checkable
class Domain(WorldPart, PlannerPart, PagesPart, Protocol):
    """A robot and its world, as the teaching core and the study's pages use them: the three parts
    above, every member required (teaching.core.base.BaseDomain gives the defaults)."""


@runtime_checkable
class ShowWayPart(Protocol):
    """Optional: a domain whose participants can *show* the robot's way (teaching.core.showtests: a
    "show the way" test, scored under θ*).  A domain has all of it or none of it."""

    def score_shown(self, env_id: int, actions) -> dict:
        """A way a participant showed in environment `env_id` (the scene's action names) replayed and
        scored under θ*: at least counts, reward, optimum, regret (≥ 0, θ*'s units), regret_normalised,
        optimal and its rows as path_rows gives them.  ValueError (one line) for a way the world does not
        allow, whoever sends it."""
        ...

    def show_rules(self, env_id: int) -> dict:
        """What the "show the way" page needs to offer exactly the actions the world allows there
        (JSON: blocked cells, how a way ends, at most how many actions, the object's name)."""
        ...


@runtime_checkable
class RecordingsPart(Protocol):
    """Optional: a robot whose pages may show recordings its lab made (teaching.importing: a table imported
    with videos) instead of drawing each trajectory from its path_rows.  A domain has all of it or none of it."""

    def stimulus(self, env_id: int, theta_index: int, states: np.ndarray):
        """What the page shows of objective `theta_index`'s trajectory `states` in environment `env_id`:
        ``{"video": name}``, an opaque name media_file serves, or the path_rows the scene animates."""
        ...

    def media_file(self, name: str) -> Path | None:
        """The file of the recording `name` a stimulus named; None for any name that is not one of them."""
        ...


REQUIRED_PARTS = (WorldPart, PlannerPart, PagesPart)
OPTIONAL_PARTS = (ShowWayPart, RecordingsPart)


def part_members(part: type) -> tuple[str, ...]:
    """The members `part` declares itself (its data members, then its methods), in order."""
    own = vars(part)
    methods = (k for k, v in own.items() if not k.startswith("_") and callable(v))
    return (*own.get("__annotations__", {}), *methods)


def missing_members(domain) -> dict[type, tuple[str, ...]]:
    """part -> the members of it `domain` lacks, for each required part that lacks any, and for an optional
    part the domain has some but not all of."""
    out = {}
    for part in (*REQUIRED_PARTS, *OPTIONAL_PARTS):
        names = part_members(part)
        lacks = tuple(n for n in names if not hasattr(domain, n))
        if lacks and (part in REQUIRED_PARTS or len(lacks) < len(names)):
            out[part] = lacks
    return out


def has_part(domain, part: type) -> bool:
    """Whether `domain` has every member of the optional `part` (all of it or none; its members are methods)."""
    return all(callable(getattr(domain, n, None)) for n in part_members(part))


def shows_the_way(domain) -> bool:
    """Whether `domain` has the optional ShowWayPart: participants can show its way."""
    return has_part(domain, ShowWayPart)


def n_clusters(domain: Domain) -> int:
    """C: the real strategy clusters (label C is "no strategy")."""
    return len(domain.class_of_cluster)


def siblings(domain: Domain, cluster: int) -> np.ndarray:
    """The other clusters of `cluster`'s class: the strategies a test contrasts it with."""
    same = np.flatnonzero(np.asarray(domain.class_of_cluster) == domain.class_of_cluster[cluster])
    return same[same != cluster]


# --- the registry -------------------------------------------------------------------------
# Domains plug in by name (healthchecks' TRANSPORTS): teaching/domains registers the built-in
# ones with a loader, so a domain's modules (and its compiled kernels) load only when used.
_LOADERS: dict[str, Callable[[], Domain]] = {}
_LOADED: dict[str, Domain] = {}
_DEFAULT: list[str] = []


def register(name: str, loader: Callable[[], Domain], default: bool = False) -> None:
    """Make `name` available to :func:`get_domain`; `loader()` returns the Domain on first use.
    default: the domain of tables and presets that name none (those built before domains).  Registering
    a name again replaces its domain, in its place among :func:`domain_names`."""
    _LOADERS[name] = loader
    _LOADED.pop(name, None)
    if default:
        _DEFAULT[:] = [name]


def unregister(name: str) -> None:
    """Forget `name` (a domain a test registered for itself), so later code sees only the others."""
    _LOADERS.pop(name, None)
    _LOADED.pop(name, None)
    if _DEFAULT == [name]:
        _DEFAULT.clear()


def domain_names() -> tuple[str, ...]:
    return tuple(_LOADERS)


def default_domain_name() -> str:
    if not _DEFAULT:
        raise LookupError("no default domain is registered (import teaching.domains)")
    return _DEFAULT[0]


def get_domain(name: str | None = None) -> Domain:
    """The registered domain `name` (None: the default one).  ValueError for an unknown name."""
    name = default_domain_name() if name is None else name
    if name not in _LOADED:
        try:
            loader = _LOADERS[name]
        except KeyError:
            known = ", ".join(_LOADERS) or "(none registered)"
            raise ValueError(f"unknown domain {name!r}; choose one of {known}") from None
        domain = loader()
        if domain.name != name:
            raise ValueError(f"domain registered as {name!r} calls itself {domain.name!r}")
        _LOADED[name] = domain
    return _LOADED[name]


# A table may carry its own robot (one made by `python -m teaching import-table`): loading it registers that
# robot first.  teaching.domains sets the reader (teaching.importing.registry), so the core names no such module.
_CARRIED_READER: list[Callable[[Path, dict], None]] = []


def set_carried_reader(reader: Callable[[Path, dict], None]) -> None:
    """reader(table directory, its meta.json) registers the robot such a table carries, if it carries one."""
    _CARRIED_READER[:] = [reader]


def register_carried(path: Path, meta: dict) -> None:
    """Register the robot the table at `path` carries, if any (ValueError, one line, if it cannot be)."""
    for reader in _CARRIED_READER:
        reader(path, meta)

