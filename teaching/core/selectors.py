"""The selector registry: every teaching algorithm a study's condition can come from, by name.

A selector turns a table (and the run's shared state: seed, settings, fitted learner models, the
random stream; :class:`~teaching.core.conditions.SelectionContext`) into a
:class:`~teaching.core.selection.Sequence` of table rows.  Each declares its name, its parameters
(with defaults and a check) and a ``select(ctx, **params)``; :func:`check_params` turns what a
caller passes into the full, checked set, with one-line errors naming the selector and the
parameter.  Learner models have the same shape of registry (:mod:`teaching.core.learners`).

The greedy, coverage and random selectors register themselves in :mod:`teaching.core.conditions`,
the example-based ones (SCOT, BEC scaffolding, HIGHLIGHTS) in :mod:`teaching.core.summaries`.
Those modules (BUILTIN_MODULES) are imported by the first lookup (:func:`selector_names`,
:func:`get_selector`, :func:`check_params`), so every built-in selector is there whichever module
a caller imported, and this module imports none of them at its top (they import it).
"""
from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType


@dataclass(frozen=True)
class Param:
    """One parameter of a selector: its default and a check that returns the value to use
    (a normalised copy) or raises ValueError with what was wrong (the selector is named by
    :func:`check_params`)."""

    default: object
    check: Callable[[object], object]
    doc: str = ""


@dataclass(frozen=True)
class Selector:
    """A teaching algorithm: ``select(ctx, **params) -> Sequence`` over the context's table.

    scored_by(params): the learner model whose P(θ*) the sequence reports after each example
    (a model name; the greedy ones report their own).
    """

    name: str
    select: Callable
    params: Mapping[str, Param] = field(default_factory=dict)
    scored_by: Callable[[dict], str] = lambda params: "exact"
    doc: str = ""

    def __post_init__(self):
        object.__setattr__(self, "params", MappingProxyType(dict(self.params)))


_REGISTRY: dict[str, Selector] = {}
# The modules whose import registers the built-in selectors, in the order they are listed.
BUILTIN_MODULES = ("teaching.core.conditions", "teaching.core.summaries")
_builtins_loaded = False


def _load_builtins() -> None:
    global _builtins_loaded
    if not _builtins_loaded:
        _builtins_loaded = True
        for module in BUILTIN_MODULES:
            importlib.import_module(module)


def register_selector(selector: Selector) -> Selector:
    """Make ``selector`` available by its name (a later registration under the same name replaces
    the earlier one, as :func:`teaching.core.learners.register_model` does)."""
    _REGISTRY[selector.name] = selector
    return selector


def selector_names() -> tuple[str, ...]:
    """Every registered selector, in registration order."""
    _load_builtins()
    return tuple(_REGISTRY)


def get_selector(name: str) -> Selector:
    _load_builtins()
    if name not in _REGISTRY:
        raise ValueError(f"unknown selector {name!r}; choose from {', '.join(_REGISTRY)}")
    return _REGISTRY[name]


def check_params(name: str, params: Mapping | None = None) -> dict:
    """Every parameter of selector ``name``: ``params``' values checked, defaults for the rest.
    Raises ValueError (one line, naming the selector and the parameter) for an unknown selector,
    an unknown parameter or a bad value."""
    selector = get_selector(name)
    params = dict(params or {})
    unknown = sorted(set(params) - set(selector.params))
    if unknown:
        takes = ", ".join(selector.params) or "no parameters"
        raise ValueError(f"selector {name!r}: unknown parameter {unknown[0]!r}; it takes {takes}")
    out = {}
    for key, param in selector.params.items():
        try:
            out[key] = param.check(params.get(key, param.default))
        except (TypeError, ValueError) as exc:
            raise ValueError(f"selector {name!r}: parameter {key!r}: {exc}") from None
    return out


def _value(text: str):
    """A parameter's value as typed: an int, else a float, else the text."""
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    return text


def parse_selector(spec: str) -> tuple[str, str, dict]:
    """``NAME`` or ``NAME:KEY=VALUE,KEY=VALUE`` (a command line's ``--selector``) -> (label, name,
    every parameter checked, defaults filled: :func:`check_params`).  The label names the sequence
    in a teach output: the name, then the parameters as given.  ValueError, one line, if malformed."""
    name, _, rest = str(spec).strip().partition(":")
    given = {}
    for item in filter(None, (i.strip() for i in rest.split(","))):
        key, eq, text = item.partition("=")
        if not eq or not key.strip() or not text.strip():
            raise ValueError(f"selector {name!r}: {item!r} is not KEY=VALUE (write NAME:KEY=VALUE,KEY=VALUE)")
        if key.strip() in given:
            raise ValueError(f"selector {name!r}: parameter {key.strip()!r} given twice")
        given[key.strip()] = _value(text.strip())
    params = check_params(name, given)
    label = name + (":" + ",".join(f"{k}={v}" for k, v in given.items()) if given else "")
    return label, name, params


# --- checks shared by the selectors' parameters ------------------------------------------------
def integer_at_least(lowest: int) -> Callable[[object], int]:
    """A check: an integer ≥ ``lowest`` (a bool or a float with a fraction is refused)."""
    def check(value) -> int:
        if isinstance(value, bool) or not float(value).is_integer() or int(value) < lowest:
            raise ValueError(f"must be an integer >= {lowest}, got {value!r}")
        return int(value)
    check.minimum = lowest  # declared, so a form can bound its field without running the check
    return check


def number_at_least(lowest: float) -> Callable[[object], float]:
    """A check: a finite number ≥ ``lowest``."""
    def check(value) -> float:
        if isinstance(value, bool):
            raise ValueError(f"must be a number >= {lowest:g}, got {value!r}")
        v = float(value)
        if not (v == v and abs(v) != float("inf")) or v < lowest:
            raise ValueError(f"must be a finite number >= {lowest:g}, got {value!r}")
        return v
    check.minimum = lowest
    return check


def one_of(choices: tuple[str, ...]) -> Callable[[object], str]:
    """A check: one of ``choices`` (a string)."""
    def check(value) -> str:
        if value not in choices:
            raise ValueError(f"must be one of {', '.join(choices)}, got {value!r}")
        return str(value)
    check.choices = tuple(choices)
    return check
