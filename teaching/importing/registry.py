"""Imported tables' robots in the domain registry, by name, so the command line, the site and the workers all find
them as they find a built-in robot.

A table made by ``import-table`` carries its robot (teaching.importing.robot).  Loading the table registers it
(teaching.core.table asks :func:`register_table` through the hook teaching.domains sets); the site and the
workers, which look a study's robot up by name before they load its table, register every table that
``TEACHING_TABLES`` names (tables and folders of them, separated by ``os.pathsep``) when teaching.domains is
imported.  A table with a mistake is one line, logged and kept in TABLE_ERRORS; it never stops another robot.
"""
from __future__ import annotations

import json
import logging
import os
from pathlib import Path

from ..core.domain import domain_names, get_domain, register
from .robot import DESCRIPTION, ROBOT, ImportedDomain, ImportedRobotError

# the table directory each imported robot's name was registered from (a second table may not take the name)
_SOURCES: dict[str, Path] = {}
# tables TEACHING_TABLES names that were not registered: their one line each
TABLE_ERRORS: list[str] = []


def carries_robot(meta: dict) -> bool:
    """Whether a table's meta.json says it carries its own robot (an imported table)."""
    return bool(meta.get("imported"))


def register_table(path, meta: dict | None = None) -> str:
    """Register the robot the imported table at `path` carries (once; again from the same table is a no-op) and
    return its name; ImportedRobotError (one line) if it is not an imported table or its name is taken.
    meta: its meta.json, where the caller has read it already."""
    path = Path(path).resolve()
    if meta is None:
        try:
            meta = json.loads((path / "meta.json").read_text(encoding="utf-8"))
        except (OSError, ValueError) as exc:
            raise ImportedRobotError(f"{path}: not a table (meta.json: {exc})") from None
    if not carries_robot(meta) or not (path / ROBOT / DESCRIPTION).is_file():
        raise ImportedRobotError(f"{path}: not a table made by import-table (it carries no {ROBOT}/{DESCRIPTION})")
    name = meta.get("domain")
    if _SOURCES.get(name) == path:
        return name
    domain = ImportedDomain(path)
    if name in _SOURCES and get_domain(name).fingerprint() == domain.fingerprint():
        return name  # a copy of the same robot's table
    if name in domain_names():
        where = f"the imported table at {_SOURCES[name]}" if name in _SOURCES else "a built-in robot"
        raise ImportedRobotError(f"{path}: its robot {name!r} has the name of {where}: import it under another name")
    if domain.name != name:
        raise ImportedRobotError(f"{path}: meta.json names the robot {name!r}, {ROBOT}/{DESCRIPTION} {domain.name!r}")
    register(name, lambda: domain)
    _SOURCES[name] = path
    return name


def read_carried(path: Path, meta: dict) -> None:
    """The core's hook (teaching.core.domain.set_carried_reader): register the robot of an imported table."""
    if carries_robot(meta):
        register_table(path, meta)


def forget(name: str) -> None:
    """Let `name` be registered from another table (the caller unregisters the domain)."""
    _SOURCES.pop(name, None)


def register_tables(spec: str) -> list[str]:
    """Register every imported table `spec` names (tables, and folders whose sub-folders are tables, separated by
    os.pathsep); returns their names.  A folder's other tables (built ones) are passed over; a named table that
    cannot be registered is one line in TABLE_ERRORS."""
    names = []
    log = logging.getLogger(__name__)
    for part in (p for p in spec.split(os.pathsep) if p):
        root = Path(part)
        tables = [root] if (root / "meta.json").exists() else sorted(p for p in root.glob("*") if (p / ROBOT).is_dir())
        for table in tables:
            try:
                names.append(register_table(table))
            except ImportedRobotError as exc:
                TABLE_ERRORS.append(str(exc))
                log.warning("imported table not registered: %s", exc)
    return names
