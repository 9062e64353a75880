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

from .cells import shortest_moves
from .worldtexts import check_texts, check_translations, did_you_mean

MOVES = ((0, 1), (-1, 0), (1, 0), (0, -1))  # (d_row, d_col): right, up, down, left, the tie order
HELD = "held"  # an object's place in a start state when the robot starts holding it
START_POOLS = ("listed", "reachable")  # a variant's starts: the file's, or every state they reach
COUNTS = ("moves", "enter", "reach", "deliver")  # what a feature counts (docs/gridworlds.md)
TERMINAL_COUNTS = ("reach", "deliver")  # features that end an episode, counted at most once
ACTIONS = ("pickup", "drop")  # actions besides the moves that a "moves" feature may also count
_OPS = {"=": np.equal, "==": np.equal, "!=": np.not_equal, ">": np.greater, ">=": np.greater_equal,
        "<": np.less, "<=": np.less_equal}
_CONDITION = re.compile(r"^\s*([A-Za-z_][\w-]*)\s*(==|!=|>=|<=|=|>|<)\s*(-?\d+)\s*$")
# Every field a world file may give, by the table it sits in (docs/gridworlds.md, "The file, field by
# field"): any other is refused with a "did you mean", so that a typo ("max_move") is never ignored.  A
# start's table also takes the object's name (starts[i].<object>).
FIELDS = {
    "": ("name", "title", "width", "height", "max_moves", "exit", "cells", "fixed", "optional", "object",
         "starts", "start_pool", "features", "theta_star", "classes", "other", "tests", "min_option_distance",
         "presets", "texts", "translations"),
    "cells": ("colour", "label", "passable"),
    "fixed": ("at", "kind"),
    "object": ("name", "at", "destination"),
    "starts": ("at",),
    "features": ("name", "counts", "cell", "at", "holding", "also"),
    "classes": ("name", "strategies"),
    "strategies": ("name", "when"),
    "presets": ("environments", "thetas"),
}


class WorldFileError(ValueError):
    """A world file that cannot be used (one line: the file, the field, what is wrong)."""


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


class _Reader:
    """Field access with the one-line errors: every message names the file and the field."""

    def __init__(self, name: str):
        self.name = name

    def fail(self, where: str, what: str):
        raise WorldFileError(f"{self.name}: {where}: {what}")

    def get(self, table: dict, key: str, where: str, kind, default=...):
        if key not in table:
            if default is ...:
                self.fail(f"{where}{key}", "missing")
            return default
        value = table[key]
        if kind is float and isinstance(value, int) and not isinstance(value, bool):
            value = float(value)
        if not isinstance(value, kind) or (kind in (int, float) and isinstance(value, bool)):
            self.fail(f"{where}{key}", f"expected {getattr(kind, '__name__', kind)}, got {repr(value)[:80]}")
        if kind is float and not math.isfinite(value):
            self.fail(f"{where}{key}", f"{value}: expected a finite number")
        return value

    def table(self, value, where: str, fields) -> dict:
        """`value` checked to be a table whose keys are all among `fields`."""
        if not isinstance(value, dict):
            self.fail(where, f"expected a table {{ {', '.join(fields)} }}, got {repr(value)[:80]}")
        for key in value:
            if key not in fields:
                self.fail(f"{where}.{key}" if where else key,
                          f"not a field of {'a world file' if not where else 'this table'} "
                          f"(one of {', '.join(fields)}){did_you_mean(key, fields)}")
        return value

    def tables(self, raw: dict, key: str, fields, default=...) -> list[dict]:
        """raw[key] checked to be a list of tables whose keys are all among `fields`."""
        items = self.get(raw, key, "", list, default)
        return [self.table(item, f"{key}[{i}]", fields) for i, item in enumerate(items)]


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
    """A world from the file's parsed TOML (a dict); `source` names it in error messages."""
    r = _Reader(source)
    r.table(raw, "", FIELDS[""])
    name = r.get(raw, "name", "", str)
    if not re.fullmatch(r"[a-z][a-z0-9-]*", name):
        r.fail("name", f"{name!r} is not a lower-case name (letters, digits, '-')")
    width, height = r.get(raw, "width", "", int), r.get(raw, "height", "", int)
    if not (1 <= width and 1 <= height and width * height <= 127):
        r.fail("width", f"a grid of {width} x {height} cells: it must have 1 to 127 cells")
    max_moves = r.get(raw, "max_moves", "", int)
    if not 1 <= max_moves <= 200:
        r.fail("max_moves", f"{max_moves}: must lie in 1..200")

    def cell(value, where) -> tuple[int, int]:
        if not (isinstance(value, list) and len(value) == 2
                and all(isinstance(v, int) and not isinstance(v, bool) for v in value)):
            r.fail(where, f"a cell is [x, y], got {repr(value)[:80]}")
        x, y = value
        if not (1 <= x <= width and 1 <= y <= height):
            r.fail(where, f"cell [{x}, {y}] lies outside the {width} x {height} grid")
        return height - y, x - 1  # (row, col), row 0 at the top

    kinds = {}
    for kname, spec in r.get(raw, "cells", "", dict, {}).items():
        where = f"cells.{kname}."
        if kname == "wall" or not re.fullmatch(r"[a-z]+(-[a-z]+)*", kname):
            r.fail(f"cells.{kname}", "a kind is named in lower-case words joined by '-', and not 'wall' (built in)")
        r.table(spec, f"cells.{kname}", FIELDS["cells"])
        colour = r.get(spec, "colour", where, str)
        if not re.fullmatch(r"#[0-9a-fA-F]{6}", colour):
            r.fail(where + "colour", f"{colour!r} is not a colour written #rrggbb")
        kinds[kname] = CellKind(kname, colour, r.get(spec, "label", where, str, kname),
                                r.get(spec, "passable", where, bool, True))

    def kind_of(item, where):
        value = r.get(item, "kind", where + ".", str, "wall")
        if value != "wall" and value not in kinds:
            r.fail(where + ".kind", f"unknown cell kind {value!r} (declared: wall, {', '.join(kinds) or 'none'})")
        return value

    fixed = {}
    for i, item in enumerate(r.tables(raw, "fixed", FIELDS["fixed"], [])):
        fixed[cell(item.get("at"), f"fixed[{i}].at")] = kind_of(item, f"fixed[{i}]")
    optional = tuple((cell(item.get("at"), f"optional[{i}].at"), kind_of(item, f"optional[{i}]"))
                     for i, item in enumerate(r.tables(raw, "optional", FIELDS["fixed"], [])))
    if len(optional) > 12:
        r.fail("optional", f"{len(optional)} optional cells: at most 12 (4,096 variants)")

    obj = obj_at = destination = None
    if "object" in raw:
        spec = r.table(raw["object"], "object", FIELDS["object"])
        obj = r.get(spec, "name", "object.", str)
        if obj in FIELDS["starts"]:
            r.fail("object.name", f"{obj!r} is a start's own field: name the object otherwise")
        obj_at = cell(spec.get("at"), "object.at")
        destination = cell(spec["destination"], "object.destination") if "destination" in spec else None

    starts = []
    for i, item in enumerate(r.tables(raw, "starts", (*FIELDS["starts"], *([obj] if obj else [])))):
        at = cell(item.get("at"), f"starts[{i}].at")
        place = None
        if obj is not None:
            value = item.get(obj, "at")
            place = HELD if value == HELD else obj_at if value == "at" else cell(value, f"starts[{i}].{obj}")
        starts.append((at, place))
    if not starts:
        r.fail("starts", "at least one start is needed")
    start_pool = r.get(raw, "start_pool", "", str, "listed")
    if start_pool not in START_POOLS:
        r.fail("start_pool", f"{start_pool!r}: one of {', '.join(START_POOLS)}{did_you_mean(start_pool, START_POOLS)}")

    features = tuple(_feature(r, item, i, cell, kinds, obj, destination)
                     for i, item in enumerate(r.tables(raw, "features", FIELDS["features"])))
    names = [f.name for f in features]
    if len(set(names)) != len(names) or not names:
        r.fail("features", f"feature names must be present and distinct, got {names}")
    theta = r.get(raw, "theta_star", "", list)
    if len(theta) != len(features) or not all(isinstance(v, (int, float)) and not isinstance(v, bool)
                                              for v in theta):
        r.fail("theta_star", f"needs one number per feature ({len(features)}), got {repr(theta)[:80]}")
    theta = tuple(float(v) for v in theta)
    for f, w in zip(features, theta, strict=True):
        if not math.isfinite(w):
            r.fail("theta_star", f"the weight of {f.name!r} is {w}: every weight must be a finite number")
        if w == 0:
            r.fail("theta_star", f"the weight of {f.name!r} is 0: every weight needs a sign")
        if not f.terminal and w > 0:
            r.fail("theta_star", f"the weight of {f.name!r} is positive: a count that can grow without end "
                   "would make the reward unbounded (only 'reach' and 'deliver' features may be rewards)")
    if not any(f.terminal for f in features) and not raw.get("exit", False):
        r.fail("features", "no feature ends an episode ('reach' or 'deliver') and exit is off: no trajectory ends")

    classes, seen = [], {}
    for i, item in enumerate(r.tables(raw, "classes", FIELDS["classes"])):
        cname = r.get(item, "name", f"classes[{i}].", str)
        strategies = []
        for j, s in enumerate(r.get(item, "strategies", f"classes[{i}].", list)):
            where = f"classes[{i}].strategies[{j}]"
            r.table(s, where, FIELDS["strategies"])
            sname = r.get(s, "name", where + ".", str)
            conds = []
            for part in r.get(s, "when", where + ".", str).split(" and "):
                m = _CONDITION.match(part)
                if not m or m[1] not in names:
                    r.fail(where + ".when", f"{part.strip()!r} is not 'feature op number' over {', '.join(names)}")
                conds.append((names.index(m[1]), m[2], int(m[3])))
            strategies.append(Strategy(sname, tuple(conds)))
            seen[sname] = True
        if len(strategies) < 2:
            r.fail(f"classes[{i}].strategies", "a class needs at least two strategies to contrast")
        classes.append(WorldClass(cname, tuple(strategies)))
    tests = tuple(r.get(raw, "tests", "", list, list(seen)))
    for t in tests:
        if not isinstance(t, str) or t not in seen:
            r.fail("tests", f"{repr(t)[:80]} is not a strategy of a class")

    presets = {}
    for suffix, spec in r.get(raw, "presets", "", dict, {"tiny": {"environments": 48, "thetas": 24}}).items():
        r.table(spec, f"presets.{suffix}", FIELDS["presets"])
        envs = spec.get("environments", "all")
        if not (envs == "all" or (isinstance(envs, int) and not isinstance(envs, bool) and envs > 0)):
            r.fail(f"presets.{suffix}.environments", f"a positive number or \"all\", got {repr(envs)[:80]}")
        thetas = r.get(spec, "thetas", f"presets.{suffix}.", int)
        if thetas < 2:
            r.fail(f"presets.{suffix}.thetas", f"{thetas}: a table needs θ* and at least one other θ")
        presets[suffix] = (None if envs == "all" else envs, thetas)
    min_option_distance = r.get(raw, "min_option_distance", "", float, 0.3)
    if min_option_distance < 0:
        r.fail("min_option_distance", f"{min_option_distance}: a distance is 0 or more")
    texts = check_texts(r, r.get(raw, "texts", "", dict, {}))
    world = World(name=name, title=r.get(raw, "title", "", str, name), width=width, height=height,
                  max_moves=max_moves, kinds=kinds, fixed=fixed, optional=optional, obj=obj, obj_at=obj_at,
                  destination=destination, starts=tuple(starts), exit=r.get(raw, "exit", "", bool, False),
                  features=features, theta_star=theta, classes=tuple(classes),
                  other=r.get(raw, "other", "", str, "other"), tests=tests, presets=presets,
                  min_option_distance=min_option_distance, start_pool=start_pool, texts=texts, source=source)
    _check_reachable(world, r)
    translations = check_translations(r, r.get(raw, "translations", "", dict, {}), world)
    return replace(world, translations=translations) if translations else world


def _check_reachable(w: World, r: _Reader) -> None:
    """One line for a goal, object or destination no start reaches even with every optional cell off."""
    open_ = ~w.blocked(0)
    targets = [(f"features[{i}].at", f.at) for i, f in enumerate(w.features) if f.counts == "reach"]
    if w.obj is not None:
        targets += [("object.at", w.obj_at)] + ([("object.destination", w.destination)] if w.destination else [])
    for where, cell in targets:
        if all(shortest_moves(open_, s, cell, MOVES) == np.inf for s, _ in w.starts):
            r.fail(where, f"cell [{cell[1] + 1}, {w.height - cell[0]}] cannot be reached from any start")


def _feature(r: _Reader, item: dict, i: int, cell, kinds, obj, destination) -> Feature:
    where = f"features[{i}]."
    name, counts = r.get(item, "name", where, str), r.get(item, "counts", where, str)
    if counts not in COUNTS:
        r.fail(where + "counts", f"{counts!r}: one of {', '.join(COUNTS)}")
    kind = at = None
    if counts == "enter":
        kind = r.get(item, "cell", where, str)
        if kind not in kinds:
            r.fail(where + "cell", f"unknown cell kind {kind!r} (declared: {', '.join(kinds) or 'none'})")
    if counts == "reach":
        at = cell(item.get("at"), where + "at")
    if counts == "deliver" and destination is None:
        r.fail(where + "counts", "'deliver' needs an object with a destination ([object] destination)")
    holding = r.get(item, "holding", where, bool, None)
    if holding is not None and obj is None:
        r.fail(where + "holding", "the world has no object to hold")
    also = tuple(r.get(item, "also", where, list, []))
    if any(a not in ACTIONS for a in also) or (also and counts != "moves"):
        r.fail(where + "also", f"{list(also)}: only a 'moves' feature may also count {', '.join(ACTIONS)}")
    return Feature(name, counts, kind, at, holding, also)
