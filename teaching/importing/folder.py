"""A table folder (docs/importing.md) read and checked: its ``table.toml`` against the format's JSON Schema
(``table.schema.json``), then what one field says of another, then the data file, then the check that matters
for the science: that every trajectory is the best of its environment under its own objective
(:mod:`teaching.importing.optimality`).  The first mistake is a :class:`TableFolderError`, one line naming the
file, the field or the place in the data, and what is wrong.  Reading writes nothing.
"""
from __future__ import annotations

import json
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from jsonschema import Draft7Validator

from ..core.schemacheck import did_you_mean, first_mistake
from .csvlines import TableFolderError, refuser
from .data import Expected, read_data
from .optimality import Optimality, optimality
from .paths import Paths, read_paths
from .stimuli import Stimuli, read_stimuli

SCHEMA_PATH = Path(__file__).with_name("table.schema.json")
SCHEMA = json.loads(SCHEMA_PATH.read_text(encoding="utf-8"))
_VALIDATOR = Draft7Validator(SCHEMA)
DESCRIPTION = "table.toml"
MIN_OPTION_DISTANCE = 0.5  # the driving world's default: options at least this far apart
_fail = refuser(DESCRIPTION)


@dataclass(frozen=True)
class Feature:
    name: str
    unit: str
    description: str
    scale: float = 1.0


@dataclass(frozen=True)
class Strategy:
    name: str
    cls: str  # one of the table's classes
    tested: bool = True


@dataclass(frozen=True, eq=False)
class TableFolder:
    """A checked table folder.  M environments, N objectives (θ* first), D features."""

    path: Path
    name: str
    title: str
    features: tuple[Feature, ...]
    thetas: np.ndarray  # (N, D) float64: thetas[0] is θ*, thetas[k] is table.toml's candidates[k - 1]
    env_ids: np.ndarray  # (M,) int64
    phi: np.ndarray  # (M, N, D) float64: the features of objective k's trajectory in environment m
    classes: tuple[str, ...]
    env_class: np.ndarray | None  # (M,) int8 into classes
    strategies: tuple[Strategy, ...]
    strategy: np.ndarray | None  # (M, N) int8 into strategies, -1 none
    distance: np.ndarray | None  # (M, N) float32 from θ*'s trajectory
    min_option_distance: float
    keep_suboptimal: bool
    optimality: Optimality
    stimuli: Stimuli | None  # the videos, when table.toml names a manifest
    paths: Paths | None  # the recorded paths, when table.toml names them
    texts: dict  # table.toml's [texts]: what the pages tell participants ({}: the generic texts)

    @property
    def feature_names(self) -> tuple[str, ...]:
        return tuple(f.name for f in self.features)


def read_folder(path) -> TableFolder:
    """The folder at `path`, checked; TableFolderError naming the first mistake."""
    path = Path(path)
    raw = _read_toml(path)
    names = [f["name"] for f in raw["features"]]
    thetas = _thetas(raw, len(names))
    classes = tuple(raw.get("classes", ()))
    strategies = _strategies(raw, classes)
    data = path / raw["data"]
    if not data.is_file():
        _fail(f"data: no file {raw['data']!r} in {path}")
    arrays = read_data(data, Expected(tuple(names), len(thetas), len(classes), len(strategies)))
    report = optimality(arrays["features"], thetas, arrays["env_ids"])
    keep = raw.get("keep_suboptimal", False)
    if not report.optimal and not keep:
        raise TableFolderError(f"{data.name}: {report.describe()}; the learner models assume an optimal robot: "
                               f"mend the data, or set keep_suboptimal = true in {DESCRIPTION} to keep it")
    stimuli = None
    if "stimuli" in raw:
        if not (path / raw["stimuli"]).is_file():
            _fail(f"stimuli: no file {raw['stimuli']!r} in {path}")
        stimuli = read_stimuli(path, raw["stimuli"], arrays["env_ids"], len(thetas))
    paths = read_paths(path, raw, arrays["env_ids"], len(thetas)) if "paths" in raw else None
    if paths is not None and arrays["distance"] is not None:
        raise TableFolderError(f"{data.name}: distance: given with recorded paths, whose distances are worked out "
                               "from the paths (docs/importing.md): leave one out")
    return TableFolder(
        path=path, name=raw["name"], title=raw.get("title", raw["name"]),
        features=tuple(Feature(f["name"], f["unit"], f["description"], float(f.get("scale", 1.0)))
                       for f in raw["features"]),
        thetas=thetas, env_ids=arrays["env_ids"], phi=arrays["features"], classes=classes,
        env_class=arrays["env_class"], strategies=strategies, strategy=arrays["strategy"],
        distance=arrays["distance"], min_option_distance=float(raw.get("min_option_distance", MIN_OPTION_DISTANCE)),
        keep_suboptimal=keep, optimality=report, stimuli=stimuli, paths=paths, texts=dict(raw.get("texts", {})))


def _read_toml(path: Path) -> dict:
    if not path.is_dir():
        raise TableFolderError(f"{path}: not a folder")
    try:
        raw = tomllib.loads((path / DESCRIPTION).read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise TableFolderError(f"{path}: no {DESCRIPTION} (docs/importing.md says what it holds)") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        _fail(f"not TOML: {exc}")
    mistake = first_mistake(_VALIDATOR, raw)
    if mistake is not None:
        _fail(": ".join(mistake))
    seen: set[str] = set()
    for i, f in enumerate(raw["features"]):
        if f["name"] in seen:
            _fail(f"features[{i}].name: {f['name']!r} named twice")
        seen.add(f["name"])
    return raw


def _thetas(raw: dict, d: int) -> np.ndarray:
    """(N, D): θ* then the candidates, each one weight per feature and no two alike."""
    weights = [("theta_star", raw["theta_star"])] + [(f"candidates[{i}]", c) for i, c in enumerate(raw["candidates"])]
    first: dict[tuple, str] = {}
    for where, w in weights:
        if len(w) != d:
            _fail(f"{where}: {len(w)} weights, expected {d} (one per feature)")
        for j, x in enumerate(w):
            if not np.isfinite(x):
                _fail(f"{where}[{j}]: {x}; every weight is a finite number")
        key = tuple(float(x) for x in w)
        if key in first:
            _fail(f"{where}: the same objective as {first[key]}")
        first[key] = where
    return np.array([w for _, w in weights], dtype=np.float64)


def _strategies(raw: dict, classes: tuple[str, ...]) -> tuple[Strategy, ...]:
    out = []
    for i, s in enumerate(raw.get("strategies", ())):
        if s["class"] not in classes:
            known = f"one of the classes ({', '.join(classes)})" if classes else "a class, and table.toml lists none"
            _fail(f"strategies[{i}].class: {s['class']!r} is not {known}{did_you_mean(s['class'], classes)}")
        out.append(Strategy(s["name"], s["class"], s.get("tested", True)))
    return tuple(out)
