"""A built trajectory table written out as a table folder (docs/importing.md): an example of the format made
from a robot the project already has, and one half of the round trip that shows the format loses nothing.

The features and θs go out as they are stored (float64 weights written with Python's shortest
round-tripping repr, arrays in a .npz), so reading the folder back gives the table's own bytes.  So do the
trajectories, as recorded paths: every trajectory's states (``Domain.states``) on a clock of one second a step,
with the domain's ``state_scale``, so that the distance between two of them reads back as the domain's own
where it is the padded distance of teaching.core.pathdistance (the grid domains').
"""
from __future__ import annotations

import json
import math
import zipfile
from pathlib import Path

import numpy as np

from ..core.table import TrajectoryTable

DATA = "features.npz"
PATHS = "paths.npz"
ENVS_A_BLOCK = 256  # environments whose states are worked out and written at once (bounded memory)
SCHEMA_LINE = "#:schema https://github.com/robot-teaching/robot-teaching/teaching/importing/table.schema.json"


def export_table(table: TrajectoryTable, out, name: str | None = None) -> Path:
    """Write `table` as a folder at `out` (which must not exist yet, or be empty); returns it.  name: the robot's
    name in the folder (default: the domain's, with "-export": a table imported back must not take the name of
    the domain it came from)."""
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
              "strategy": strategy}  # no distances: the paths' are worked out from them
    np.savez(out / DATA, **arrays)
    _write_paths(table, out / PATHS)
    (out / "table.toml").write_text(_description(table, name or f"{domain.name}-export"), encoding="utf-8")
    return out


def _write_paths(table: TrajectoryTable, path: Path) -> None:
    """paths.npz: env_id, t (L,) and robot (M, N, L, S), the states written a block of environments at a time
    into the zip, so a table of any size is written in bounded memory."""
    m, n = table.strategy.shape
    first = np.asarray(table.states(slice(0, 1), slice(None)), np.float64)  # (1, N, L, S)
    shape = (m, n, *first.shape[2:])
    with zipfile.ZipFile(path, "w", zipfile.ZIP_STORED, allowZip64=True) as zf:
        _put(zf, "env_id", np.asarray(table.env_ids, np.int64))
        _put(zf, "t", np.arange(shape[2], dtype=np.float64))
        with zf.open("robot.npy", "w", force_zip64=True) as f:
            np.lib.format.write_array_header_2_0(f, {"descr": np.lib.format.dtype_to_descr(first.dtype),
                                                     "fortran_order": False, "shape": shape})
            for start in range(0, m, ENVS_A_BLOCK):
                block = np.asarray(table.states(slice(start, start + ENVS_A_BLOCK), slice(None)), np.float64)
                f.write(np.ascontiguousarray(block).tobytes())


def _put(zf: zipfile.ZipFile, name: str, a: np.ndarray) -> None:
    with zf.open(f"{name}.npy", "w", force_zip64=True) as f:
        np.lib.format.write_array(f, a, allow_pickle=False)


def _description(table: TrajectoryTable, name: str) -> str:
    domain = table.domain
    lines = [SCHEMA_LINE, f"name = {_value(name)}", f"title = {_value(domain.name)}",
             f"data = {_value(DATA)}", f"min_option_distance = {_value(float(domain.min_option_distance))}",
             f"theta_star = {_value(table.thetas[0])}", "candidates = ["]
    lines += [f"  {_value(theta)}," for theta in table.thetas[1:]]
    lines += ["]", f"classes = {_value(list(domain.class_names))}", ""]
    columns = ["x", "y"] + [f"s{i}" for i in range(2, len(domain.state_scale))]
    lines += ["[paths]", f"file = {_value(PATHS)}", 'unit = "1"', f"columns = {_value(columns)}",
              f"scale = {_value([float(v) for v in domain.state_scale])}", ""]
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
