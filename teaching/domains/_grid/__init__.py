"""Building blocks of a grid-world domain: a robot that moves one cell at a time on a small grid,
every feature a count of cells entered, so its optimal paths are exact (docs/domains.md).

* :mod:`.cells` - a path as the table stores it (cell indices ``row * width + col``), its states
  ([col, row] per move), the padded Euclidean distance, breadth-first shortest paths;
* :mod:`.domain` - :class:`GridDomain`, a :class:`~teaching.core.base.BaseDomain` whose table
  stores paths and whose planner takes, for each environment, the domain's *front* (every
  non-dominated φ with one path each) and lets each θ choose through ``reward()``;
* :mod:`.worldfile`, :mod:`.fileworld`, :mod:`.filedomain` - a grid world described by one TOML
  file (docs/gridworlds.md): the file parsed and checked, its exact planner (a front per way an
  episode ends, over states (cell, where the object is)), and the domain it makes.

Not a domain itself (nothing registers it).  A domain built on it lists this package in its
``code_roots`` (GridDomain does), so the code fingerprint of its tables covers it; other domains'
workers never see an edit here.
"""
from __future__ import annotations

from pathlib import Path

ROOT = Path(__file__).resolve().parent
