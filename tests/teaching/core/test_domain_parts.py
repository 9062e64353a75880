"""The Domain interface in declared parts: each part small enough to read, together the whole interface,
every member the project reaches on a domain declared in one of them, and every registered domain whole."""
from __future__ import annotations

import ast
from pathlib import Path

import pytest

from teaching.core.base import BaseDomain
from teaching.core.domain import (
    OPTIONAL_PARTS,
    REQUIRED_PARTS,
    Domain,
    ShowWayPart,
    domain_names,
    get_domain,
    missing_members,
    part_members,
    shows_the_way,
)

ROOT = Path(__file__).resolve().parents[3]
# Where the project uses a domain: the core, its commands and the web side (a domain's own package reaches
# into itself, which is its business).
USERS = ("teaching/core", "teaching/api.py", "teaching/teach.py", "teaching/__main__.py", "studyapp", "precompute")
# Names a domain goes by in that code, and the calls that return one.
DOMAIN_NAMES = frozenset({"domain", "robot"})
DOMAIN_CALLS = frozenset({"get_domain", "study_domain"})
DECLARED = frozenset(m for part in (*REQUIRED_PARTS, *OPTIONAL_PARTS) for m in part_members(part))


def _called(node) -> str | None:
    return getattr(node.func, "id", getattr(node.func, "attr", None)) if isinstance(node, ast.Call) else None


def members_reached(source: str) -> dict[str, list[int]]:
    """member -> the lines where `source` reaches it on a domain: `domain.x`, `<anything>.domain.x`,
    `get_domain(...).x`, `d.x` where `d = get_domain(...)`, and getattr/hasattr(domain, "x")."""
    tree = ast.parse(source)
    names = set(DOMAIN_NAMES) | {t.id for node in ast.walk(tree) if isinstance(node, ast.Assign)
                                 and _called(node.value) in DOMAIN_CALLS for t in node.targets
                                 if isinstance(t, ast.Name)}

    def is_domain(node) -> bool:
        return ((isinstance(node, ast.Name) and node.id in names) or _called(node) in DOMAIN_CALLS
                or (isinstance(node, ast.Attribute) and node.attr == "domain"))

    out: dict[str, list[int]] = {}
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and is_domain(node.value):
            out.setdefault(node.attr, []).append(node.lineno)
        elif (_called(node) in ("getattr", "hasattr") and isinstance(node.func, ast.Name) and len(node.args) > 1
              and is_domain(node.args[0]) and isinstance(node.args[1], ast.Constant)):
            out.setdefault(node.args[1].value, []).append(node.lineno)
    return out


def test_each_part_is_under_15_members_and_together_they_are_the_domain():
    sizes = {part.__name__: len(part_members(part)) for part in (*REQUIRED_PARTS, *OPTIONAL_PARTS)}
    assert all(0 < n < 15 for n in sizes.values()), sizes
    every = [m for part in (*REQUIRED_PARTS, *OPTIONAL_PARTS) for m in part_members(part)]
    assert len(every) == len(set(every))  # no member in two parts
    assert part_members(Domain) == ()  # Domain declares nothing beyond its parts
    assert set(Domain.__mro__) >= set(REQUIRED_PARTS) and ShowWayPart not in Domain.__mro__


def test_the_scan_finds_a_member_reached_in_each_way():
    """The check below is only as good as its scan: each way of reaching a domain's member is found."""
    found = members_reached(
        "def f(study, table):\n"
        "    domain.alpha\n"
        "    table.domain.beta\n"
        "    get_domain('x').gamma\n"
        "    d = study_domain(study)\n"
        "    d.delta\n"
        "    getattr(domain, 'epsilon', None)\n"
        "    hasattr(robot, 'zeta')\n"
        "    other.eta\n")
    assert set(found) == {"alpha", "beta", "gamma", "delta", "epsilon", "zeta"}


def test_every_member_the_project_reaches_on_a_domain_is_declared():
    files = [p for u in USERS for p in ([ROOT / u] if u.endswith(".py") else sorted((ROOT / u).rglob("*.py")))]
    undeclared = {f"{path.relative_to(ROOT)}:{line} .{member}"
                  for path in files for member, lines in members_reached(path.read_text()).items()
                  if member not in DECLARED for line in lines}
    assert not undeclared, sorted(undeclared)
    assert len(files) > 100  # the scan read the project, not an empty folder


@pytest.mark.parametrize("name", domain_names())
def test_every_registered_domain_has_every_part(name):
    domain = get_domain(name)
    assert missing_members(domain) == {}
    assert isinstance(domain, Domain)
    # a grid world from a file lets participants show the way; the car and the yard do not
    assert shows_the_way(domain) == isinstance(domain, ShowWayPart) == (name not in ("driving", "gridworld"))


def test_base_domain_gives_the_defaults_a_page_may_leave_out():
    """A domain that writes no translations and fills no text from its data still has those members."""
    assert {"translations", "translations_source", "formatted_texts", "code_roots", "caption", "study_view",
            "page_scene", "scene"} <= {m for m in DECLARED if hasattr(BaseDomain, m)}
