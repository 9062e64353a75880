"""A built trajectory table written out as a table folder (docs/importing.md): an example of the format made
from a robot the project already has, and one half of the round trip that shows the format loses nothing.

The features, θs and distances go out as they are stored (float64 weights written with Python's shortest
round-tripping repr, arrays in a .npz), so reading the folder back gives the table's own bytes.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from ..core.table import TrajectoryTable

DATA = "features.npz"
SCHEMA_LINE = "#:schema https://github.com/robot-teaching/robot-teaching/teaching/importing/table.schema.json"


def export_table(table: TrajectoryTable, out) -> Path:
    """Write `table` as a folder at `out` (which must not exist yet, or be empty); returns it."""
    out = Path(out)
    if out.exists() and any(out.iterdir()):
        raise FileExistsError(f"{out} is not empty: a table folder is written into a new folder")
    out.mkdir(parents=True, exist_ok=True)
    domain = table.domain
    n_clusters = len(domain.cluster_names) - 1
    strategy = np.asarray(table.strategy, np.int8).copy()
    strategy[strategy == n_clusters] = -1  # the platform's "no strategy" is the format's -1
    arrays = {"env_id": np.asarray(table.env_ids), "features": np.asarray(table.features),
              "env_class": np.asarray(domain.environment_class(np.asarray(table.env_ids)), np.int8),
              "strategy": strategy, "distance": np.asarray(table.d_euclid)}
    np.savez(out / DATA, **arrays)
    (out / "table.toml").write_text(_description(table), encoding="utf-8")
    return out


def _description(table: TrajectoryTable) -> str:
    domain = table.domain
    lines = [SCHEMA_LINE, f"name = {_value(domain.name)}", f"title = {_value(domain.name)}",
             f"data = {_value(DATA)}", f"min_option_distance = {_value(float(domain.min_option_distance))}",
             f"theta_star = {_value(table.thetas[0])}", "candidates = ["]
    lines += [f"  {_value(theta)}," for theta in table.thetas[1:]]
    lines += ["]", f"classes = {_value(list(domain.class_names))}", ""]
    for name, scale in zip(domain.feature_names, table.normalisers, strict=True):
        lines += ["[[features]]", f"name = {_value(name)}", 'unit = "1"',
                  f"description = {_value(f'the {domain.name} domain feature {name!r}')}",
                  f"scale = {_value(float(scale))}", ""]
    tested = set(domain.test_clusters)
    for c, name in enumerate(domain.cluster_names[:-1]):
        lines += ["[[strategies]]", f"name = {_value(name)}",
                  f"class = {_value(domain.class_names[int(domain.class_of_cluster[c])])}",
                  f"tested = {_value(c in tested)}", ""]
    return "\n".join(lines)


def _value(v) -> str:
    """A TOML value: strings as JSON writes them (the escapes TOML's basic strings share), floats by the
    shortest repr that reads back to the same float, lists of them."""
    if isinstance(v, bool | np.bool_):
        return "true" if v else "false"
    if isinstance(v, str):
        return json.dumps(v, ensure_ascii=False)
    if isinstance(v, np.ndarray | list | tuple):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    f = float(v)
    if math.isnan(f) or math.isinf(f):
        return ("-" if f < 0 else "") + ("nan" if math.isnan(f) else "inf")
    return repr(f)
