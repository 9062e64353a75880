"""A table folder's recorded paths (docs/importing.md, "Recorded paths"): each trajectory as the robot's poses over
time, and the other agents' positions in each environment, for the top-down scene the platform draws and for the
distance between two trajectories that the Euclidean learner and the test set's options use.

The file is a NumPy ``.npz``; M environments, N objectives (θ* first), L time stamps, P numbers a pose, A agents::

    env_id   (M,) whole numbers     the data's environments, each once (any order)
    t        (L,) seconds           one clock for every path, strictly increasing, starting at 0
    robot    (M, N, L, P) numbers   objective k's trajectory in environment m: x and y first, then any other
                                    numbers of a pose (heading, speed), in table.toml's [paths] columns
    agents   (M, A, L, 2) numbers   optional: the other agents' x and y, the same under every objective
    obstacles (M, K, 4) numbers     optional: still rectangles [x from, y from, x to, y to] (walls, a box)

A path that arrives before the clock ends repeats its last pose (the robot waits where it arrived).  Every
refusal is one line naming the file, the array and the place in it.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .csvlines import read_npz, refuser

ARRAYS = ("env_id", "t", "robot", "agents", "obstacles")
DEFAULT_COLUMNS = ("x", "y")


@dataclass(frozen=True, eq=False)
class Paths:
    """Recorded paths, in the data's environment order."""

    t: np.ndarray  # (L,) float64 seconds from 0
    robot: np.ndarray  # (M, N, L, P) float64
    agents: np.ndarray | None  # (M, A, L, 2) float64
    obstacles: np.ndarray | None  # (M, K, 4) float64 [x0, y0, x1, y1], x0 < x1 and y0 < y1
    view: tuple[float, ...] | None  # (x0, x1, y0, y1) every scene shows, or None: each environment's own
    columns: tuple[str, ...]  # (P,) x, y, then the rest
    scale: np.ndarray  # (P,) float64: a column's unit in the distance (inf: not compared)
    unit: str


def read_paths(folder: Path, raw: dict, env_ids: np.ndarray, n_objectives: int) -> Paths:
    """The recorded paths table.toml's ``[paths]`` names, in the order of `env_ids` (the data's); a
    TableFolderError names the first mistake."""
    spec = raw["paths"]
    columns = tuple(spec.get("columns", DEFAULT_COLUMNS))
    scale = np.asarray(spec.get("scale", [1.0] * len(columns)), np.float64)
    if np.isnan(scale).any():
        refuser("table.toml")(f"paths.scale[{int(np.flatnonzero(np.isnan(scale))[0])}]: nan; a scale is a positive "
                              f"number (inf: the column is not compared)")
    if len(scale) != len(columns):
        refuser("table.toml")(f"paths.scale: {len(scale)} numbers, expected {len(columns)} (one per column: "
                              f"{', '.join(columns)})")
    path = folder / spec["file"]
    if not path.is_file():
        refuser("table.toml")(f"paths.file: no file {spec['file']!r} in {folder}")
    fail = refuser(path.name)
    arrays = _load(path, fail)
    order = _order(arrays["env_id"], env_ids, fail)
    m, n, p = len(env_ids), n_objectives, len(columns)
    t = arrays["t"]
    if t.ndim != 1 or len(t) < 2:
        fail(f"t: shape {t.shape}, expected (L,) with L >= 2: one clock for every path, in seconds")
    _finite(fail, "t", t, env_ids=None)
    if t[0] != 0 or np.any(np.diff(t) <= 0):
        bad = 0 if t[0] != 0 else int(np.flatnonzero(np.diff(t) <= 0)[0]) + 1
        fail(f"t[{bad}]: {t[bad]}; the clock starts at 0 and every time stamp is later than the one before")
    want = (m, n, len(t), p)
    robot = arrays["robot"]
    if robot.shape != want:
        fail(f"robot: shape {robot.shape}, expected {want} = (environments, objectives, time stamps, columns: "
             f"{', '.join(columns)})")
    _finite(fail, "robot", robot, arrays["env_id"])
    robot = np.asarray(robot, np.float64)[order]
    agents = arrays.get("agents")
    if agents is not None:
        if agents.ndim != 4 or agents.shape[0] != m or agents.shape[2:] != (len(t), 2):
            fail(f"agents: shape {agents.shape}, expected ({m}, A, {len(t)}, 2) = (environments, agents, time "
                 f"stamps, x and y)")
        _finite(fail, "agents", agents, arrays["env_id"])
        agents = np.asarray(agents, np.float64)[order]
    obstacles = arrays.get("obstacles")
    if obstacles is not None:
        if obstacles.ndim != 3 or obstacles.shape[0] != m or obstacles.shape[2] != 4:
            fail(f"obstacles: shape {obstacles.shape}, expected ({m}, K, 4) = (environments, obstacles, "
                 "[x from, y from, x to, y to])")
        _finite(fail, "obstacles", obstacles, arrays["env_id"])
        bad = np.argwhere((obstacles[..., 2] <= obstacles[..., 0]) | (obstacles[..., 3] <= obstacles[..., 1]))
        if len(bad):
            i, k = (int(x) for x in bad[0])
            fail(f"obstacles[{i}, {k}] (environment {arrays['env_id'][i]}): {obstacles[i, k].tolist()}; a rectangle "
                 "is [x from, y from, x to, y to], each 'to' above its 'from'")
        obstacles = np.asarray(obstacles, np.float64)[order]
    view = spec.get("view")
    if view is not None and not (np.all(np.isfinite(view)) and view[0] < view[1] and view[2] < view[3]):
        refuser("table.toml")(f"paths.view: {view}; four finite numbers, x from < x to, y from < y to")
    return Paths(np.asarray(t, np.float64), robot, agents, obstacles, None if view is None else tuple(view), columns,
                 scale, spec.get("unit", "m"))


def _load(path: Path, fail) -> dict:
    arrays = read_npz(path, ARRAYS, ARRAYS[:3], fail)
    for name, a in arrays.items():
        if a.dtype.kind not in ("iu" if name == "env_id" else "fiu"):
            fail(f"{name}: {a.dtype} values, expected {'whole numbers' if name == 'env_id' else 'numbers'}")
    return arrays


def _order(ids: np.ndarray, env_ids: np.ndarray, fail) -> np.ndarray:
    """(M,) the position in the file of each of the data's environments."""
    if ids.ndim != 1:
        fail(f"env_id: shape {ids.shape}, expected ({len(env_ids)},)")
    position = {}
    for i, e in enumerate(ids.tolist()):
        if e in position:
            fail(f"env_id[{i}]: environment {e} given twice (first at env_id[{position[e]}])")
        position[e] = i
    missing = [int(e) for e in env_ids if int(e) not in position]
    if missing:
        fail(f"env_id: environment {missing[0]} of the data has no paths" + (
            f" (and {len(missing) - 1} more)" if len(missing) > 1 else ""))
    if len(ids) != len(env_ids):
        extra = sorted(set(position) - {int(e) for e in env_ids})
        fail(f"env_id: environment {extra[0]} is not in the data")
    return np.array([position[int(e)] for e in env_ids], np.int64)


def _finite(fail, name: str, a: np.ndarray, env_ids) -> None:
    bad = np.argwhere(~np.isfinite(a)) if a.dtype.kind == "f" else ()
    if len(bad):
        where = tuple(int(x) for x in bad[0])
        env = f" (environment {env_ids[where[0]]})" if env_ids is not None else ""
        fail(f"{name}[{', '.join(map(str, where))}]{env}: {a[where]}; every number must be finite")
