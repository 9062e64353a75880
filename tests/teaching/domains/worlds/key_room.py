"""A grid world written only as a file (key-room.toml, beside this module), as a researcher new to
the platform would write one, registered only by the tests that use it (:func:`registered`)."""
from __future__ import annotations

import contextlib
from pathlib import Path

from teaching.core.build import build_table
from teaching.core.domain import register, unregister
from teaching.domains._grid.filedomain import world_domain
from teaching.teach import main as teach_main
from tests.conftest import built_once

PATH = Path(__file__).resolve().parent / "key-room.toml"
DOMAIN = world_domain(PATH)


@contextlib.contextmanager
def registered():
    """The key room registered for the duration, then forgotten, so loops over domain_names()
    elsewhere never meet it."""
    register(DOMAIN.name, lambda: DOMAIN)
    try:
        yield DOMAIN
    finally:
        unregister(DOMAIN.name)


def built(tmp_path_factory) -> tuple[Path, Path]:
    """(table, teach output) of its tiny preset, built once per run (call it while registered)."""
    preset = DOMAIN.presets[0]
    table = built_once(tmp_path_factory, f"{preset.name}-table", lambda out: build_table(preset, out))

    def teach(out):
        assert teach_main(["--table", str(table), "--out", str(out), "--no-progress"]) == 0

    return table, built_once(tmp_path_factory, f"{preset.name}-teach", teach)
