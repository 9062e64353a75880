"""The core knows no robot: teaching/core imports nothing from teaching/domains and names no
domain's concepts; domains plug in through the registry and the Domain interface."""
from __future__ import annotations

import ast
import io
import re
import subprocess
import sys
import tokenize
from pathlib import Path

import numpy as np
import pytest

import teaching
from teaching.core import domain as domain_module
from teaching.core.build import PRESETS, Preset, code_fingerprint, get_preset
from teaching.core.domain import Domain, domain_names, get_domain, n_clusters, siblings
from teaching.core.table import TableError, TrajectoryTable
from teaching.domains.driving.domain import DOMAIN as DRIVING

PACKAGE = Path(teaching.__file__).resolve().parent
CORE = PACKAGE / "core"


def domain_words() -> set[str]:
    """Words that belong to one robot: each registered domain's name and the vocabulary it declares
    (Domain.vocabulary), not its raw feature names: a feature may be called by a plain word."""
    words = set()
    for name in domain_names():
        d = get_domain(name)
        words.add(d.name)
        words.update(d.vocabulary)
    return words


MODULE_PATH = re.compile(r"^\.*(teaching\.)?domains(\.\w+)*$")  # a string importlib could load


def core_modules() -> list[Path]:
    return sorted(p for p in CORE.rglob("*.py") if "__pycache__" not in p.parts)


def test_the_core_imports_nothing_from_the_domains():
    offenders = []
    for path in core_modules():
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom):
                # teaching/core/x.py: level 1 is teaching.core, level 2 teaching, ...
                module = node.module or ""
                if node.level >= 2 or module.startswith("teaching") and not module.startswith("teaching.core"):
                    offenders.append(f"{path.name}:{node.lineno} from {'.' * node.level}{module}")
            elif isinstance(node, ast.Import):
                offenders += [f"{path.name}:{node.lineno} import {a.name}" for a in node.names
                              if a.name.startswith("teaching") and not a.name.startswith("teaching.core")]
            elif isinstance(node, ast.Constant) and isinstance(node.value, str) and MODULE_PATH.match(node.value):
                offenders.append(f"{path.name}:{node.lineno} names a module of teaching.domains: {node.value!r}")
    assert not offenders, offenders


def test_the_core_names_no_domain_concept():
    """Identifiers, strings, docstrings and comments: a reader of teaching/core learns no robot."""
    words = domain_words()
    assert {"driving", "merging", "closeness", "lane", "gridworld", "mud"} <= words  # the list is really built
    hits = []
    for path in core_modules():
        for tok in tokenize.generate_tokens(io.StringIO(path.read_text()).readline):
            if tok.type in (tokenize.NAME, tokenize.STRING, tokenize.COMMENT):
                for word in re.findall(r"[A-Za-z]+", tok.string):
                    for part in re.findall(r"[a-z]+|[A-Z][a-z]*", word):  # snake_case and CamelCase parts
                        if part.lower() in words:
                            hits.append(f"{path.name}:{tok.start[0]} {part!r} in {tok.string[:60]!r}")
    assert not hits, hits


def test_the_check_would_catch_a_domain_word():
    source = 'x = 1  # the other car\n'
    toks = [t.string for t in tokenize.generate_tokens(io.StringIO(source).readline) if t.type == tokenize.COMMENT]
    assert any(w in domain_words() for t in toks for w in re.findall(r"[a-z]+", t))


@pytest.mark.parametrize("name", domain_names())
def test_every_domain_declares_its_vocabulary(name):
    """Lower-case single words (the check splits identifiers into such parts), the robot's own."""
    vocabulary = get_domain(name).vocabulary
    assert isinstance(vocabulary, frozenset) and vocabulary, name
    assert all(re.fullmatch(r"[a-z]+", w) for w in vocabulary), sorted(vocabulary)


def test_a_feature_named_by_a_plain_word_does_not_fail_the_check(monkeypatch):
    """A domain whose feature is called "turns" passes while the core says "θ turns into": only the
    words a domain declares are forbidden (its vocabulary), not its feature names."""
    d = get_domain("gridworld")
    monkeypatch.setattr(type(d), "feature_names", ("turns", *d.feature_names[1:]))
    assert "turns" not in domain_words()
    assert "θ turns into" in CORE.joinpath("domain.py").read_text()
    monkeypatch.setattr(type(d), "vocabulary", d.vocabulary | {"turns"})
    assert "turns" in domain_words()  # declared, it would be caught


def test_the_core_loads_without_any_domain():
    """A fresh interpreter importing only teaching.core.* (no teaching/__init__'s registrations
    reach the domains' modules) loads no module of teaching.domains."""
    code = ("import sys, importlib\n"
            "for m in ('domain', 'table', 'build', 'learners', 'selection', 'evaluation', 'testset', 'candidates'):\n"
            "    importlib.import_module('teaching.core.' + m)\n"
            "loaded = sorted(m for m in sys.modules if m.startswith('teaching.domains.'))\n"
            "print(loaded)\n")
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120,
                         cwd=PACKAGE.parent)
    assert run.returncode == 0, run.stderr[-2000:]
    assert run.stdout.strip() == "[]"


def test_driving_implements_the_interface():
    d = get_domain("driving")
    assert d is DRIVING and isinstance(d, Domain)
    assert get_domain() is d  # the default: tables and presets from before domains
    assert d.n_environments == 21216 and n_clusters(d) == 8
    assert len(d.cluster_names) == n_clusters(d) + 1  # + "none"
    assert len(d.feature_names) == len(d.theta_star) == len(d.default_normalisers()) == 5
    assert d.test_clusters == (0, 1, 2, 3, 4, 5)
    assert [int(siblings(d, c)[0]) for c in range(8)] == [1, 0, 3, 2, 5, 4, 7, 6]
    ids = d.stratified_sample(8, seed=0)
    assert sorted(d.environment_class(ids).tolist()) == [0, 0, 1, 1, 2, 2, 3, 3]
    states = d.states(np.zeros((2, *d.trajectory_shape), d.trajectory_dtype))
    assert states.shape[0] == 2 and d.euclidean_distance(states[0], states[1]) == 0
    assert {p.name for p in d.presets} == {"tiny", "demo", "paper"} <= set(PRESETS)


def test_unknown_domains_and_presets_are_refused_with_a_message():
    with pytest.raises(ValueError, match=r"unknown domain 'boat'; choose one of .*driving"):
        get_domain("boat")
    with pytest.raises(ValueError, match="unknown domain 'boat'"):
        Preset("x", n_envs=4, n_thetas=2, domain="boat")
    with pytest.raises(ValueError, match="unknown preset"):
        get_preset("nope")


def test_a_preset_names_its_domain_and_keeps_its_identity():
    p = Preset("x", n_envs=8, n_thetas=3)
    assert p.domain == "driving" and p.theta_star == tuple(DRIVING.theta_star)
    # a job spec stored before domains (no "domain" key) still makes the same preset
    legacy = {k: v for k, v in vars(p).items() if k != "domain"}
    assert Preset(**legacy) == p
    with pytest.raises(ValueError, match=r"needs one weight per feature \(5\)"):
        Preset("x", n_envs=8, n_thetas=3, theta_star=(-1.0, -1.0))


def test_a_registered_domain_plugs_in_and_a_foreign_table_is_refused(tmp_path, monkeypatch):
    """A second domain registers by name; a table says which domain it is, and a table whose world
    fingerprint is not its domain's is refused on load."""
    class Renamed:  # the car under another name and world: enough to exercise the registry
        name = "car-copy"

        def __getattr__(self, attr):
            return getattr(DRIVING, attr)

        def fingerprint(self):
            return "0" * 16

    monkeypatch.setattr(domain_module, "_LOADERS", dict(domain_module._LOADERS))
    monkeypatch.setattr(domain_module, "_LOADED", dict(domain_module._LOADED))
    domain_module.register("car-copy", Renamed)
    assert "car-copy" in domain_names() and get_domain("car-copy").name == "car-copy"
    table = TrajectoryTable(thetas=np.array([DRIVING.theta_star]), env_ids=np.array([0]),
                            controls=np.zeros((1, 1, *DRIVING.trajectory_shape), np.float32),
                            features=np.zeros((1, 1, 5)), strategy=np.zeros((1, 1), np.int8),
                            d_euclid=np.zeros((1, 1), np.float32), normalisers=np.ones(5),
                            meta={"domain": "car-copy", "preset": "x"})
    table.save(tmp_path / "t")
    loaded = TrajectoryTable.load(tmp_path / "t")
    assert loaded.meta["domain"] == "car-copy" and loaded.meta["world"] == "0" * 16
    meta = (tmp_path / "t" / "meta.json").read_text()
    (tmp_path / "t" / "meta.json").write_text(meta.replace('"car-copy"', '"driving"'))
    with pytest.raises(TableError, match="other world constants"):
        TrajectoryTable.load(tmp_path / "t")
    (tmp_path / "t" / "meta.json").write_text(meta.replace('"car-copy"', '"boat"'))
    with pytest.raises(TableError, match="unknown domain 'boat'"):
        TrajectoryTable.load(tmp_path / "t")


def test_the_code_fingerprint_is_per_domain(tmp_path):
    """An edit to one domain's package changes its fingerprint only; an edit to the core changes all."""
    core, one, two = (tmp_path / n for n in ("core", "one", "two"))
    for d in (core, one, two):
        d.mkdir()
        (d / "a.py").write_text(f"NAME = {d.name!r}\n")
    before = code_fingerprint(roots=(core, one)), code_fingerprint(roots=(core, two))
    (two / "a.py").write_text("NAME = 'edited'\n")
    assert code_fingerprint(roots=(core, one)) == before[0] != code_fingerprint(roots=(core, two))
    (core / "a.py").write_text("NAME = 'core edited'\n")
    assert code_fingerprint(roots=(core, one)) != before[0]
    assert code_fingerprint("driving") == code_fingerprint(roots=(CORE, DRIVING.code_root))
