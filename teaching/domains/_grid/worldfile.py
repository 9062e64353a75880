"""A grid world described by one TOML file, parsed and checked: :func:`load_world` -> :class:`World`.

docs/gridworlds.md documents the file field by field.  Coordinates in the file are (x, y) cells,
1-based, x to the right and y *up* (as the grid worlds of Lee, Admoni & Simmons 2021 write them);
inside, a cell is (row, col) with row 0 at the top, as every grid domain stores it.

Every mistake raises :class:`WorldFileError` with one line that names the file and the field.
"""
from __future__ import annotations

import math
import re
import tomllib
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from ...core.schemacheck import did_you_mean
from .cells import shortest_moves
from .worldschema import WorldFileError, _Reader, check_shape
from .worldtexts import check_texts, check_translations

__all__ = ["HELD", "MOVES", "World", "WorldFileError", "load_world", "parse_world"]

MOVES = ((0, 1), (-1, 0), (1, 0), (0, -1))  # (d_row, d_col): right, up, down, left, the tie order
HELD = "held"  # an object's place in a start state when the robot starts holding it
START_POOLS = ("listed", "reachable")  # a variant's starts: the file's, or every state they reach
COUNTS = ("moves", "enter", "reach", "deliver")  # what a feature counts (docs/gridworlds.md)
TERMINAL_COUNTS = ("reach", "deliver")  # features that end an episode, counted at most once
ACTIONS = ("pickup", "drop")  # actions besides the moves that a "moves" feature may also count
_OPS = {"=": np.equal, "==": np.equal, "!=": np.not_equal, ">": np.greater, ">=": np.greater_equal,
        "<": np.less, "<=": np.less_equal}
_CONDITION = re.compile(r"^\s*([A-Za-z_][\w-]*)\s*(==|!=|>=|<=|=|>|<)\s*(-?\d+)\s*$")
MAX_CELLS = 127  # a cell and whether the object is held fit one int16 code (GridDomain's encoding)
DEFAULT_PRESETS = {"tiny": {"environments": 48, "thetas": 24}}


@dataclass(frozen=True)
class CellKind:
    name: str
    colour: str
    label: str
    passable: bool = True


@dataclass(frozen=True)
class Feature:
    """One count of φ.  counts: "moves" (every move, or only while holding or not holding the object:
    ``holding``; pick-ups and drops too, held or not, where ``also`` names them), "enter" (moves into a cell of
    kind ``cell``), "reach" (arriving at ``at`` ends the episode) or "deliver" (dropping the object
    at its destination ends the episode)."""

    name: str
    counts: str
    cell: str | None = None
    at: tuple[int, int] | None = None  # (row, col)
    holding: bool | None = None
    also: tuple[str, ...] = ()

    @property
    def terminal(self) -> bool:
        return self.counts in TERMINAL_COUNTS


@dataclass(frozen=True)
class Strategy:
    """A strategy: the trajectories whose counts meet every condition (feature index, op, value)."""

    name: str
    conditions: tuple[tuple[int, str, int], ...]

    def holds(self, phi: np.ndarray) -> np.ndarray:
        """phi (..., D) counts -> (...) bool."""
        phi = np.asarray(phi)
        ok = np.ones(phi.shape[:-1], bool)
        for f, op, v in self.conditions:
            ok &= _OPS[op](phi[..., f], v)
        return ok


@dataclass(frozen=True)
class WorldClass:
    name: str
    strategies: tuple[Strategy, ...]


@dataclass(frozen=True)
class World:
    """A parsed world file (docs/gridworlds.md).  Cells are (row, col), row 0 at the top."""

    name: str
    title: str
    width: int
    height: int
    max_moves: int
    kinds: dict[str, CellKind]
    fixed: dict[tuple[int, int], str]  # cell -> kind ("wall" or a declared kind)
    optional: tuple[tuple[tuple[int, int], str], ...]  # bit i of a variant switches optional[i] on
    obj: str | None  # the one object that can be picked up and dropped, if any
    obj_at: tuple[int, int] | None
    destination: tuple[int, int] | None  # where dropping the object delivers it
    starts: tuple[tuple[tuple[int, int], object], ...]  # (robot cell, object cell | HELD | None)
    exit: bool  # an exit action ends an episode anywhere, adding nothing
    features: tuple[Feature, ...]
    theta_star: tuple[float, ...]
    classes: tuple[WorldClass, ...]
    other: str  # the uninformative class's one strategy
    tests: tuple[str, ...]  # strategy names the test set covers
    presets: dict[str, tuple[int | None, int]]  # suffix -> (environments or None for all, thetas)
    min_option_distance: float
    start_pool: str = "listed"  # one of START_POOLS (teaching.domains._grid.fileworld.start_pool)
    # [texts], checked: strings, the instructions a tuple of paragraphs, the comprehension check a tuple of
    # (question, choices, right choices' 0-based positions)
    texts: dict = field(default_factory=dict)
    # language -> the file's own English participant texts (participant_texts) -> their translation
    translations: dict[str, dict[str, str]] = field(default_factory=dict)
    source: str = ""

    @property
    def feature_names(self) -> tuple[str, ...]:
        return tuple(f.name for f in self.features)

    @property
    def n_variants(self) -> int:
        return 2 ** len(self.optional)

    def cells(self, variant: int) -> np.ndarray:
        """(height, width) object array of kind names ("" free, "wall", ...) of variant `variant`."""
        grid = np.full((self.height, self.width), "", object)
        for cell, kind in self.fixed.items():
            grid[cell] = kind
        for i, (cell, kind) in enumerate(self.optional):
            if variant >> i & 1:
                grid[cell] = kind
        return grid

    @property
    def participant_texts(self) -> tuple[str, ...]:
        """Every text of the file's own that a participant may read, once each: the title (filled into the
        default texts), the cell kinds' labels and the object's name (the legend) and every string of
        [texts].  A translation is keyed by one of them."""
        t = self.texts
        texts = [self.title, *(k.label for k in self.kinds.values()), *([self.obj] if self.obj else []),
                 *(t[k] for k in ("summary", "consent") if k in t), *t.get("instructions", ()),
                 *(t[k] for k in ("attention_question", "watch", "question", "title") if k in t),
                 *(text for question, choices, _ in t.get("comprehension", ()) for text in (question, *choices))]
        return tuple(dict.fromkeys(texts))

    def blocked(self, variant: int) -> np.ndarray:
        """(height, width) bool: cells the robot cannot enter in variant `variant`."""
        kinds = self.cells(variant)
        closed = {"wall"} | {k for k, v in self.kinds.items() if not v.passable}
        return np.isin(kinds, list(closed))


def load_world(path) -> World:
    """Parse and check the world file at `path`; WorldFileError (one line) on any mistake."""
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as e:
        raise WorldFileError(f"{path.name}: cannot be read: {e.strerror}") from None
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as e:
        line = data.count(b"\n", 0, e.start) + 1
        raise WorldFileError(f"{path.name}: line {line}: byte {data[e.start]:#04x} is not UTF-8 text "
                             "(save the file as UTF-8)") from None
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise WorldFileError(f"{path.name}: not valid TOML: {e}") from None
    return parse_world(raw, path.name)


def parse_world(raw: dict, source: str = "world") -> World:
    """A world from the file's parsed TOML (a dict); `source` names it in error messages.  Its fields' shapes
    are the schema's (worldschema); each step below checks what one field says of another."""
    r = _Reader(source)
    check_shape(raw, r)
    grid = _Grid(r, raw["width"], raw["height"])
    kinds = {k: CellKind(k, spec["colour"], spec.get("label", k), spec.get("passable", True))
             for k, spec in raw.get("cells", {}).items()}
    fixed = {grid.cell(item["at"], f"fixed[{i}].at"): _kind_of(r, item, f"fixed[{i}]", kinds)
             for i, item in enumerate(raw.get("fixed", []))}
    optional = tuple((grid.cell(item["at"], f"optional[{i}].at"), _kind_of(r, item, f"optional[{i}]", kinds))
                     for i, item in enumerate(raw.get("optional", [])))
    spec = raw.get("object", {})
    obj = spec.get("name")
    obj_at = grid.cell(spec["at"], "object.at") if obj else None
    destination = grid.cell(spec["destination"], "object.destination") if "destination" in spec else None
    features = tuple(_feature(r, item, i, grid, kinds, obj, destination) for i, item in enumerate(raw["features"]))
    theta = _theta(r, raw["theta_star"], features, raw.get("exit", False))
    classes = _classes(r, raw["classes"], [f.name for f in features])
    world = World(name=raw["name"], title=raw.get("title", raw["name"]), width=grid.width, height=grid.height,
                  max_moves=raw["max_moves"], kinds=kinds, fixed=fixed, optional=optional, obj=obj, obj_at=obj_at,
                  destination=destination, starts=_starts(r, raw["starts"], grid, obj, obj_at),
                  exit=raw.get("exit", False), features=features, theta_star=theta, classes=classes,
                  other=raw.get("other", "other"), tests=_tests(r, raw, classes), presets=_presets(raw),
                  min_option_distance=_distance(r, raw), start_pool=raw.get("start_pool", "listed"),
                  texts=check_texts(r, raw.get("texts", {})), source=source)
    _check_reachable(world, r)
    translations = check_translations(r, raw.get("translations", {}), world.participant_texts,
                                      world.texts.get("instructions", ()))
    return replace(world, translations=translations) if translations else world


class _Grid:
    """The grid's size, and a file's [x, y] cells (1-based, y up) read as (row, col) inside it."""

    def __init__(self, r: _Reader, width: int, height: int):
        if width * height > MAX_CELLS:
            r.fail("width", f"a grid of {width} x {height} cells: it must have 1 to {MAX_CELLS} cells")
        self.r, self.width, self.height = r, width, height

    def cell(self, value, where: str) -> tuple[int, int]:
        x, y = value
        if not (x <= self.width and y <= self.height):
            self.r.fail(where, f"cell [{x}, {y}] lies outside the {self.width} x {self.height} grid")
        return self.height - y, x - 1  # (row, col), row 0 at the top


def _kind_of(r: _Reader, item: dict, where: str, kinds: dict) -> str:
    value = item.get("kind", "wall")
    if value != "wall" and value not in kinds:
        r.fail(where + ".kind", f"unknown cell kind {value!r} (declared: wall, {', '.join(kinds) or 'none'})")
    return value


def _starts(r: _Reader, items: list, grid: _Grid, obj: str | None, obj_at) -> tuple:
    """(robot cell, object cell | HELD | None) of each start; the object's field is named as the object."""
    starts = []
    for i, item in enumerate(items):
        fields = ("at", *([obj] if obj else []))
        for key in item:
            if key not in fields:
                r.fail(f"starts[{i}].{key}", f"not a field of this table (one of {', '.join(fields)})"
                       f"{did_you_mean(key, fields)}")
        place = None
        if obj is not None:
            value = item.get(obj, "at")
            place = HELD if value == HELD else obj_at if value == "at" else grid.cell(value, f"starts[{i}].{obj}")
        starts.append((grid.cell(item["at"], f"starts[{i}].at"), place))
    return tuple(starts)


def _theta(r: _Reader, theta: list, features: tuple, exit_: bool) -> tuple[float, ...]:
    """θ*: one finite weight with a sign per feature, rewards only where a feature ends the episode."""
    names = [f.name for f in features]
    if len(set(names)) != len(names):
        r.fail("features", f"feature names must be distinct, got {names}")
    if len(theta) != len(features):
        r.fail("theta_star", f"needs one number per feature ({len(features)}), got {_short(theta)}")
    for f, w in zip(features, theta, strict=True):
        if not math.isfinite(w):
            r.fail("theta_star", f"the weight of {f.name!r} is {w}: every weight must be a finite number")
        if w == 0:
            r.fail("theta_star", f"the weight of {f.name!r} is 0: every weight needs a sign")
        if not f.terminal and w > 0:
            r.fail("theta_star", f"the weight of {f.name!r} is positive: a count that can grow without end "
                   "would make the reward unbounded (only 'reach' and 'deliver' features may be rewards)")
    if not any(f.terminal for f in features) and not exit_:
        r.fail("features", "no feature ends an episode ('reach' or 'deliver') and exit is off: no trajectory ends")
    return tuple(float(v) for v in theta)


def _short(value) -> str:
    return repr(value)[:80]


def _classes(r: _Reader, items: list, names: list[str]) -> tuple[WorldClass, ...]:
    """Each class's strategies, their conditions read as (feature index, op, value)."""
    classes = []
    for i, item in enumerate(items):
        strategies = []
        for j, s in enumerate(item["strategies"]):
            conds = []
            for part in s["when"].split(" and "):
                m = _CONDITION.match(part)
                if not m or m[1] not in names:
                    r.fail(f"classes[{i}].strategies[{j}].when",
                           f"{part.strip()!r} is not 'feature op number' over {', '.join(names)}")
                conds.append((names.index(m[1]), m[2], int(m[3])))
            strategies.append(Strategy(s["name"], tuple(conds)))
        classes.append(WorldClass(item["name"], tuple(strategies)))
    return tuple(classes)


def _tests(r: _Reader, raw: dict, classes: tuple) -> tuple[str, ...]:
    """The strategies the test set covers (default: every one), each a strategy of a class."""
    seen = [s.name for c in classes for s in c.strategies]
    tests = tuple(raw.get("tests", dict.fromkeys(seen)))
    for t in tests:
        if t not in seen:
            r.fail("tests", f"{t!r} is not a strategy of a class{did_you_mean(t, seen)}")
    return tests


def _presets(raw: dict) -> dict[str, tuple[int | None, int]]:
    """suffix -> (environments, None for all; thetas)."""
    return {suffix: (None if spec.get("environments", "all") == "all" else spec["environments"], spec["thetas"])
            for suffix, spec in raw.get("presets", DEFAULT_PRESETS).items()}


def _distance(r: _Reader, raw: dict) -> float:
    distance = float(raw.get("min_option_distance", 0.3))
    if not math.isfinite(distance):
        r.fail("min_option_distance", f"{distance}: expected a finite number")
    return distance


def _check_reachable(w: World, r: _Reader) -> None:
    """One line for a goal, object or destination no start reaches even with every optional cell off."""
    open_ = ~w.blocked(0)
    targets = [(f"features[{i}].at", f.at) for i, f in enumerate(w.features) if f.counts == "reach"]
    if w.obj is not None:
        targets += [("object.at", w.obj_at)] + ([("object.destination", w.destination)] if w.destination else [])
    for where, cell in targets:
        if all(shortest_moves(open_, s, cell, MOVES) == np.inf for s, _ in w.starts):
            r.fail(where, f"cell [{cell[1] + 1}, {w.height - cell[0]}] cannot be reached from any start")


def _feature(r: _Reader, item: dict, i: int, grid: _Grid, kinds: dict, obj, destination) -> Feature:
    """One feature: what it counts, and the field that count needs."""
    where, counts = f"features[{i}].", item["counts"]
    kind = item.get("cell") if counts == "enter" else None
    if counts == "enter" and kind not in kinds:
        r.fail(where + "cell", f"unknown cell kind {kind!r} (declared: {', '.join(kinds) or 'none'})")
    if counts == "reach" and "at" not in item:
        r.fail(where + "at", "missing: a 'reach' feature ends the episode at a cell")
    if counts == "deliver" and destination is None:
        r.fail(where + "counts", "'deliver' needs an object with a destination ([object] destination)")
    holding = item.get("holding")
    if holding is not None and obj is None:
        r.fail(where + "holding", "the world has no object to hold")
    also = tuple(item.get("also", ()))
    if also and counts != "moves":
        r.fail(where + "also", f"{list(also)}: only a 'moves' feature may also count {', '.join(ACTIONS)}")
    at = grid.cell(item["at"], where + "at") if counts == "reach" else None
    return Feature(item["name"], counts, kind, at, holding, also)
