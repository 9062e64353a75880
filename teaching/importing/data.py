"""A table folder's data file, read into arrays and checked: a NumPy ``.npz`` or a CSV in long form
(docs/importing.md, "The data file").  Every refusal is one line naming the file, where in it (an array and
its index, or a CSV line and column) and what is wrong.

What comes back, M environments, N objectives (θ* first), D features::

    env_ids    (M,) int64         as the file gives them, in its order
    features   (M, N, D) float64  the features of objective j's trajectory in environment m
    env_class  (M,) int8          index into table.toml's classes (absent: None)
    strategy   (M, N) int8        index into table.toml's strategies, -1 for none (absent: None)
    distance   (M, N) float32     how far objective j's trajectory is from θ*'s (absent: None)
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .csvlines import PairLines, read_csv, read_npz, refuser

OPTIONAL = ("env_class", "strategy", "distance")
ARRAYS = ("env_id", "features", *OPTIONAL)


@dataclass(frozen=True)
class Expected:
    """What table.toml says the data must hold."""

    feature_names: tuple[str, ...]
    n_objectives: int
    n_classes: int  # 0: table.toml lists no classes
    n_strategies: int  # 0: none listed

    def shape(self, name: str, m: int) -> tuple[int, ...]:
        return {"env_id": (m,), "features": (m, self.n_objectives, len(self.feature_names)), "env_class": (m,),
                "strategy": (m, self.n_objectives), "distance": (m, self.n_objectives)}[name]


_MEANING = {"env_id": "(environments,)", "features": "(environments, objectives: θ* and the candidates, features)",
            "env_class": "(environments,)", "strategy": "(environments, objectives)",
            "distance": "(environments, objectives)"}


def read_data(path: Path, expected: Expected) -> dict:
    """The arrays of `path` (a .npz or a .csv), checked against `expected` and among themselves; a
    TableFolderError names the first mistake."""
    arrays = _read_npz(path, expected) if path.suffix == ".npz" else _read_csv(path, expected)
    _check_values(path.name, arrays, expected)
    return arrays


# --- .npz ---------------------------------------------------------------------------------------------------------
def _read_npz(path: Path, expected: Expected) -> dict:
    fail = refuser(path.name)
    arrays = read_npz(path, ARRAYS, ("env_id", "features"), fail)
    m = len(arrays["env_id"]) if arrays["env_id"].ndim == 1 else -1
    for name, a in arrays.items():
        if a.shape != expected.shape(name, max(m, 0)):
            fail(f"{name}: shape {a.shape}, expected {expected.shape(name, max(m, 0))} = {_MEANING[name]}")
        kind = "f" if name in ("features", "distance") else "i"
        if a.dtype.kind not in ("iu" if kind == "i" else "fiu"):
            fail(f"{name}: {a.dtype} values, expected {'whole numbers' if kind == 'i' else 'numbers'}")
    # asarray, not astype: a float64 array of a paper-sized table (800 MB) is not copied
    return {"env_ids": np.asarray(arrays["env_id"], np.int64), "features": np.asarray(arrays["features"], np.float64),
            **{name: arrays.get(name) for name in OPTIONAL}}


# --- .csv ---------------------------------------------------------------------------------------------------------
def _read_csv(path: Path, expected: Expected) -> dict:
    """One row per (environment, objective): env_id, objective, one column per feature, and the optional
    env_class, strategy and distance."""
    fail = refuser(path.name)
    required = ("env_id", "objective", *expected.feature_names)
    header, lines = read_csv(path, (*required, *OPTIONAL), required, fail)
    rows = [_parse_row(cells, expected, line, fail) for line, cells in lines]
    return _assemble(rows, header, expected, fail)


def _parse_row(cells: dict[str, str], expected: Expected, line: int, fail) -> tuple:
    def number(name: str, whole: bool):
        text = cells[name]
        try:
            return int(text) if whole else float(text)
        except ValueError:
            fail(f"line {line}, column {name}: {text!r} is not {'a whole number' if whole else 'a number'}")

    k = number("objective", True)
    if not 0 <= k < expected.n_objectives:
        fail(f"line {line}, column objective: {k}; 0 is θ*, 1..{expected.n_objectives - 1} the candidates")
    phi = [number(name, False) for name in expected.feature_names]
    extra = {name: number(name, name != "distance") for name in OPTIONAL if name in cells}
    return number("env_id", True), k, phi, extra, line


def _assemble(rows: list[tuple], header: list[str], expected: Expected, fail) -> dict:
    """The rows as arrays: every (environment, objective) pair exactly once, an environment's class the same
    on each of its rows."""
    order: dict[int, int] = {}
    for env, *_ in rows:
        order.setdefault(env, len(order))
    m, n = len(order), expected.n_objectives
    out = {"env_ids": np.fromiter(order, np.int64, m), "features": np.zeros((m, n, len(expected.feature_names)))}
    out.update({name: (np.zeros(m, np.int64) if name == "env_class" else np.zeros((m, n)))
                if name in header else None for name in OPTIONAL})
    pairs = PairLines(out["env_ids"], n, fail, said="given", what="line")
    classed = np.zeros(m, np.int64)  # the line that gave each environment's class
    for env, k, phi, extra, line in rows:
        i = order[env]
        pairs.take(i, k, line)
        out["features"][i, k] = phi
        for name, value in extra.items():
            if name != "env_class":
                out[name][i, k] = value
            elif classed[i] and value != out[name][i]:
                fail(f"line {line}, column env_class: {value}, but line {classed[i]} gave environment {env} "
                     f"class {out[name][i]}")
            else:
                out[name][i], classed[i] = value, line
    pairs.check_complete()
    if out["strategy"] is not None:
        out["strategy"] = out["strategy"].astype(np.int64)
    return out


# --- what both hold -----------------------------------------------------------------------------------------------
def _check_values(file: str, a: dict, expected: Expected) -> None:
    """Finite features, each environment once, indices within table.toml's lists, distances at least 0; the
    arrays in the platform's dtypes."""
    fail = refuser(file)
    names = expected.feature_names
    bad = np.argwhere(~np.isfinite(a["features"]))
    if len(bad):
        i, k, d = bad[0]
        fail(f"features[{i}, {k}, {d}] (environment {a['env_ids'][i]}, objective {k}, feature {names[d]}): "
             f"{a['features'][i, k, d]}; every feature must be a finite number")
    ids, first = np.unique(a["env_ids"], return_index=True)
    if len(ids) < len(a["env_ids"]):
        dup = np.setdiff1d(np.arange(len(a["env_ids"])), first)[0]
        fail(f"env_id[{dup}]: environment {a['env_ids'][dup]} given twice (first at env_id[{_first(a, dup)}])")
    _check_index(fail, a, "env_class", expected.n_classes, "classes", low=0)
    _check_index(fail, a, "strategy", expected.n_strategies, "strategies", low=-1)
    if a["distance"] is not None:
        d = np.asarray(a["distance"], np.float64)
        wrong = np.argwhere(~(np.isfinite(d) & (d >= 0)))
        if len(wrong):
            i, k = wrong[0]
            fail(f"distance[{i}, {k}] (environment {a['env_ids'][i]}, objective {k}): {d[i, k]}; a distance is a "
                 f"finite number, at least 0")
        a["distance"] = np.asarray(a["distance"], np.float32)
    for name in ("env_class", "strategy"):
        if a[name] is not None:
            a[name] = np.asarray(a[name], np.int8)


def _check_index(fail, a: dict, name: str, n: int, listed: str, low: int) -> None:
    if a[name] is None:
        return
    if n == 0:
        fail(f"{name}: table.toml lists no {listed} for it to index")
    wrong = np.argwhere((a[name] < low) | (a[name] >= n))
    if len(wrong):
        where = tuple(int(x) for x in wrong[0])
        fail(f"{name}[{', '.join(map(str, where))}] (environment {a['env_ids'][where[0]]}): {a[name][where]}; "
             f"expected {low}..{n - 1}, a position in table.toml's {listed}" + (" (-1: none)" if low < 0 else ""))


def _first(a: dict, dup: int) -> int:
    return int(np.flatnonzero(a["env_ids"] == a["env_ids"][dup])[0])
