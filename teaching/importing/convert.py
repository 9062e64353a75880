"""A checked table folder made into the platform's table (``python -m teaching import-table DIR --out TABLE``).

The table is the layout of teaching.core.table (meta.json with its content hash, the arrays), so teach, the
contact sheet, every selector, the designer, studies, exports, analysis, fitting and the closed loop read it as
they read a built one.  Beside the arrays, ``robot/`` holds what the core would otherwise ask a planner's domain
(teaching.importing.robot): ``robot.json``, the agents' paths and the videos under their SHA-256 (names that
say nothing of an environment or an objective).

The table is written into a hidden folder beside `out` and renamed into place once whole, so a refused or
interrupted import leaves nothing at `out`.  Memory: the folder's arrays once, and blocks of environments for
the distances; the features array is saved from the one the folder was read into.
"""
from __future__ import annotations

import json
import shutil
import tempfile
from pathlib import Path

import numpy as np

from ..core.domain import domain_names, register, unregister
from ..core.table import TrajectoryTable
from .csvlines import TableFolderError
from .folder import TableFolder, read_folder
from .registry import forget, register_table
from .robot import AGENTS, DESCRIPTION, FORMAT, MEDIA, OBSTACLES, ROBOT, VIDEOS, ImportedDomain

SAMPLER = "imported"  # a table's "sampler": its θs were the researcher's, not drawn
BLOCK = 512  # environments whose distances are worked out at once
MARGIN = 0.08  # of an environment's larger span, around its paths and obstacles where the table gives no view


def import_table(source, out) -> TrajectoryTable:
    """The folder `source`, checked, written as a table at `out` (new, or an empty folder); returns it.
    TableFolderError (one line) for a folder that cannot be imported; nothing is written then."""
    folder = read_folder(source)
    if folder.name in domain_names():
        raise TableFolderError(f"table.toml: name: {folder.name!r} is already a robot's name here "
                               f"({', '.join(domain_names())}): give yours another")
    out = Path(out)
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        raise TableFolderError(f"{out}: not empty: a table is imported into a new folder")
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.importing-", dir=out.parent))
    try:
        _write_robot(folder, tmp / ROBOT)
        domain = ImportedDomain(tmp)
        register(folder.name, lambda: domain)
        try:
            table = _table(folder, domain)
            digest = table.save(tmp)
        finally:
            unregister(folder.name)
        if out.exists():
            out.rmdir()
        tmp.rename(out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    forget(folder.name)
    register_table(out)
    return TrajectoryTable.load(out, verify=False, expected_hash=digest)  # hashed as it was written


def _table(folder: TableFolder, domain: ImportedDomain) -> TrajectoryTable:
    m, n, _ = folder.phi.shape
    controls = folder.paths.robot if folder.paths is not None else folder.phi
    n_clusters = len(folder.strategies)
    strategy = np.full((m, n), n_clusters, np.int8) if folder.strategy is None else \
        np.where(folder.strategy < 0, n_clusters, folder.strategy).astype(np.int8)
    distance = folder.distance if folder.distance is not None else _distances(domain, controls)
    meta = {"domain": folder.name, "preset": folder.name, "sampler": SAMPLER, "seed": 0,
            "imported": {"folder": str(folder.path.resolve()), "keep_suboptimal": folder.keep_suboptimal,
                         "optimality": folder.optimality.describe()}}
    return TrajectoryTable(thetas=folder.thetas, env_ids=folder.env_ids, controls=controls, features=folder.phi,
                           strategy=strategy, d_euclid=np.asarray(distance, np.float32),
                           normalisers=domain.default_normalisers(), meta=meta)


def _distances(domain: ImportedDomain, controls: np.ndarray) -> np.ndarray:
    """(M, N) float32: each trajectory's distance to θ*'s in its environment, a block of environments at a time."""
    out = np.empty(controls.shape[:2], np.float32)
    for start in range(0, len(out), BLOCK):
        states = domain.states(controls[start:start + BLOCK])  # (b, N, L, S)
        out[start:start + BLOCK] = domain.euclidean_distance(states, states[:, :1])
    return out


def _write_robot(folder: TableFolder, robot: Path) -> None:
    """robot/: robot.json, the agents' paths, the obstacles and the videos, each video under its SHA-256."""
    robot.mkdir()
    spec = {"format": FORMAT, "name": folder.name, "title": folder.title,
            "features": [{"name": f.name, "unit": f.unit, "description": f.description, "scale": f.scale}
                         for f in folder.features],
            "theta_star": [float(v) for v in folder.thetas[0]],
            "classes": list(folder.classes) or ["all"],
            "strategies": [{"name": s.name, "class": folder.classes.index(s.cls), "tested": s.tested}
                           for s in folder.strategies],
            "min_option_distance": folder.min_option_distance,
            "env_ids": folder.env_ids.tolist(),
            "env_class": [0] * len(folder.env_ids) if folder.env_class is None else folder.env_class.tolist(),
            "texts": folder.texts, "paths": None, "videos": None,
            "keep_suboptimal": folder.keep_suboptimal}
    p = folder.paths
    if p is not None:
        xy = p.robot[..., :2]
        lo, hi = xy.min(axis=(1, 2)), xy.max(axis=(1, 2))  # (M, 2) over every objective's path
        if p.agents is not None:
            lo, hi = np.minimum(lo, p.agents.min(axis=(1, 2))), np.maximum(hi, p.agents.max(axis=(1, 2)))
            np.save(robot / AGENTS, p.agents)
        if p.obstacles is not None:
            lo = np.minimum(lo, p.obstacles[..., :2].min(axis=1))
            hi = np.maximum(hi, p.obstacles[..., 2:].max(axis=1))
            np.save(robot / OBSTACLES, p.obstacles)
        pad = MARGIN * np.maximum((hi - lo).max(axis=1), 1e-9)  # (M,): room around what moves
        bounds = np.stack([lo[:, 0] - pad, hi[:, 0] + pad, lo[:, 1] - pad, hi[:, 1] + pad], axis=1)
        if p.view is not None:
            bounds[:] = p.view  # the researcher's, as given
        spec["paths"] = {"t": p.t.tolist(), "columns": list(p.columns), "unit": p.unit,
                         "scale": [float(v) for v in p.scale], "bounds": bounds.tolist()}
    if folder.stimuli is not None:
        (robot / MEDIA).mkdir()
        names = []
        for file, digest in zip(folder.stimuli.files, folder.stimuli.sha256, strict=True):
            name = digest + Path(file).suffix.lower()
            shutil.copyfile(folder.path / file, robot / MEDIA / name)
            names.append(name)
        spec["videos"] = names
        spec["video_seconds"] = [round(s, 3) for s in folder.stimuli.seconds]
        np.save(robot / VIDEOS, folder.stimuli.which)
    (robot / DESCRIPTION).write_text(json.dumps(spec, indent=1, allow_nan=True), encoding="utf-8")

