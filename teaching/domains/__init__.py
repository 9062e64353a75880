"""The robots the platform can teach about: one package each, registered by name.

A domain implements :class:`teaching.core.domain.Domain`; registering it here (with a loader, so
its modules load only when it is used) is all the core and the web side need.  docs/domains.md.
"""
from __future__ import annotations

from importlib import import_module
from pathlib import Path

from ..core.domain import register

# the grid worlds shipped as files (docs/gridworlds.md)
WORLDS = Path(__file__).resolve().parent / "worlds"


def _loader(module: str):
    return lambda: import_module(f"{__name__}.{module}.domain").DOMAIN


# the paper's car is the default: tables and presets from before domains existed name no domain
register("driving", _loader("driving"), default=True)
register("gridworld", _loader("gridworld"))
