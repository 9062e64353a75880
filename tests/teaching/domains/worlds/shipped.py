"""The shipped worlds (teaching/domains/worlds/*.toml, registered by default), with their tiny presets'
tables and show-the-way teach outputs built once per run."""
from __future__ import annotations

import contextlib

from teaching.core.build import build_table
from teaching.core.domain import get_domain
from teaching.domains import WORLDS
from teaching.domains._grid.filedomain import world_domain
from teaching.teach import main as teach_main
from tests.conftest import built_once

NAMES = ["taxi", "two-goal", "skateboard"]


@contextlib.contextmanager
def shipped(name: str):
    """The shipped world's registered domain, checked to be the file's (a context, so that a test reads
    as the block that uses the world)."""
    domain = get_domain(name)
    assert domain.fingerprint() == world_domain(WORLDS / f"{name}.toml").fingerprint()
    yield domain


def tiny_table(tmp_path_factory, domain):
    """Its tiny preset's table, built once per run (call it while registered)."""
    preset = next(p for p in domain.presets if p.name == f"{domain.name}-tiny")
    return built_once(tmp_path_factory, f"{preset.name}-table", lambda out: build_table(preset, out))


def teach_show(tmp_path_factory, domain):
    """(table, `teach --tests show` output) of its tiny preset, built once per run (call it while
    registered): the study-app tests build their studies from the same output."""
    table_dir = tiny_table(tmp_path_factory, domain)

    def teach(out):
        assert teach_main(["--table", str(table_dir), "--out", str(out), "--no-progress", "--tests", "show"]) == 0

    return table_dir, built_once(tmp_path_factory, f"{domain.name}-tiny-teach-show", teach)
