"""The robots the platform can teach about: one package each, registered by name.

A domain implements :class:`teaching.core.domain.Domain`; registering it here (with a loader, so
its modules load only when it is used) is all the core and the web side need.  docs/domains.md.

Grid worlds from a file (docs/gridworlds.md): the ones shipped in ``worlds/`` (Lee, Admoni & Simmons'
three) register as the built-in domains do, by name, loading on first use; those ``TEACHING_WORLDS`` names
(world files and folders of them separated by ``os.pathsep``) are read and checked once on import, so a
researcher's broken file is one line at once, and the command line, the web app and the workers all see
the same worlds.

Tables imported from a lab's own files (docs/importing.md) carry their robot: loading one registers it, and the
tables that ``TEACHING_TABLES`` names (tables and folders of them) are registered on import, for the site and
the workers, which look a study's robot up by name (teaching.importing.registry).
"""
from __future__ import annotations

import logging
import os
from importlib import import_module
from pathlib import Path

from ..core.domain import domain_names, register, set_carried_reader, unregister

# the grid worlds shipped as files (docs/gridworlds.md)
WORLDS = Path(__file__).resolve().parent / "worlds"


def _loader(module: str):
    return lambda: import_module(f"{__name__}.{module}.domain").DOMAIN


# the paper's car is the default: tables and presets from before domains existed name no domain
register("driving", _loader("driving"), default=True)
register("gridworld", _loader("gridworld"))


def _shipped_world(path: Path):
    def load():
        from ._grid.filedomain import world_domain  # noqa: PLC0415

        domain = world_domain(path)
        if domain.name != path.stem:  # a shipped file is registered under its file's name before it is read
            raise ValueError(f"{path.name}: name: {domain.name!r} is not the file's name {path.stem!r}")
        return domain

    return load


for _path in sorted(WORLDS.glob("*.toml")):
    register(_path.stem, _shipped_world(_path))


# world files named in TEACHING_WORLDS that were not registered: their one-line WorldFileError each
WORLD_ERRORS: list[str] = []
# a file named twice (TEACHING_WORLDS naming worlds/, say) registers once
_REGISTERED_FILES: set[Path] = {p.resolve() for p in WORLDS.glob("*.toml")}


def register_world_files(spec: str) -> list[str]:
    """Register every world file `spec` names (files and folders of ``*.toml``, separated by
    os.pathsep) under its ``name``; returns the names.  Each is read and checked now (a small file); one
    with a mistake is left out, its one line logged and kept in WORLD_ERRORS, so a broken file never
    stops the other domains, the command line or the site."""
    parts = [p for p in spec.split(os.pathsep) if p]
    if not parts:
        return []  # the world-file modules load only where world files are named
    from ._grid.worldfile import WorldFileError  # noqa: PLC0415

    log = logging.getLogger(__name__)
    names = []
    for part in parts:
        root = Path(part)
        for path in sorted(root.glob("*.toml")) if root.is_dir() else [root]:
            if path.resolve() in _REGISTERED_FILES:
                continue
            try:
                names.append(_register_world(path))
                continue
            except WorldFileError as exc:
                error = str(exc)
            except Exception as exc:  # no file may stop the other domains
                error = f"{path.name}: not a usable world file: {type(exc).__name__}: {exc}".splitlines()[0]
                log.debug("world file %s", path, exc_info=True)
            WORLD_ERRORS.append(error)
            log.warning("world file not registered: %s", error)
    return names


def _register_world(path: Path) -> str:
    """Register the world file at `path` and return its name; WorldFileError (one line) for a mistake, any
    other exception for a file the checks let through but the domain cannot take (nothing registered)."""
    from ._grid.filedomain import FileGridDomain  # noqa: PLC0415
    from ._grid.worldfile import WorldFileError, load_world  # noqa: PLC0415

    world = load_world(path)
    if world.name in domain_names():
        raise WorldFileError(f"{path.name}: name: {world.name!r} is already a domain's name")
    domain = FileGridDomain(world)
    register(world.name, lambda: domain)
    _REGISTERED_FILES.add(path.resolve())
    try:
        # made now, not on first use: a domain that cannot list its presets fails here, once, instead of
        # in every command that lists the domains' presets
        domain.presets  # noqa: B018
    except BaseException:
        unregister(world.name)
        _REGISTERED_FILES.discard(path.resolve())
        raise
    return world.name


register_world_files(os.environ.get("TEACHING_WORLDS", ""))


def _read_carried(path: Path, meta: dict) -> None:
    from ..importing.registry import read_carried  # noqa: PLC0415  (loaded only for an imported table)

    read_carried(path, meta)


set_carried_reader(_read_carried)
if os.environ.get("TEACHING_TABLES"):
    from ..importing.registry import register_tables

    register_tables(os.environ["TEACHING_TABLES"])

