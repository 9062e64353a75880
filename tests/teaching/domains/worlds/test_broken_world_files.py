"""A registry no file can break: a folder of broken world files (each kind of mistake a researcher makes,
from bytes that are not UTF-8 to a typo in a field's name) named in TEACHING_WORLDS leaves each file out
with its one line naming the file and the field, registers the good file beside them, and every other
domain's commands still run, with no traceback."""
from __future__ import annotations

import os
import subprocess
import sys

import pytest

from teaching.core.domain import domain_names, unregister
from teaching.domains import WORLD_ERRORS, register_world_files
from tests.teaching.domains.worlds import key_room

GOOD = key_room.PATH.read_text().replace('name = "key-room"', 'name = "key-room-ok"')

# file name -> (what is changed in the good file, the one line it is left out with)
BROKEN = {
    "nan-theta.toml": (("theta_star = [15,", "theta_star = [nan,"),
                       "theta_star: the weight of 'key' is nan: every weight must be a finite number"),
    "inf-theta.toml": (("-1.5, -1]", "-inf, -1]"),
                       "theta_star: the weight of 'sand' is -inf: every weight must be a finite number"),
    "typo-field.toml": (("max_moves = 20", "max_moves = 20\nmax_move = 30"),
                        "max_move: not a field of a world file (one of name, title, width, height, max_moves, "
                        "exit, cells, fixed, optional, object, starts, start_pool, features, theta_star, classes, "
                        "other, tests, min_option_distance, presets, texts, translations); did you mean "
                        "'max_moves'?"),
    "typo-pool.toml": (("max_moves = 20", 'max_moves = 20\nstart_pool = "reachble"'),
                       "start_pool: 'reachble': one of listed, reachable; did you mean 'reachable'?"),
    "typo-feature.toml": (('{ name = "steps", counts = "moves" }', '{ name = "steps", count = "moves" }'),
                          "features[3].count: not a field of this table (one of name, counts, cell, at, holding, "
                          "also); did you mean 'counts'?"),
    "string-theta.toml": (("theta_star = [15, -2, -1.5, -1]", 'theta_star = "15, -2, -1.5, -1"'),
                          "theta_star: expected a list, got '15, -2, -1.5, -1'"),
    "bool-theta.toml": (("theta_star = [15,", "theta_star = [true,"),
                        "theta_star[0]: expected a number, got True"),
    "fixed-not-a-table.toml": (("fixed = [", "fixed = [7, "), "fixed[0]: expected a table { at, kind }, got 7"),
    "kind-a-list.toml": (('{ at = [4, 3] }]', '{ at = [4, 3], kind = ["wall"] }]'),
                         "optional[4].kind: expected a text, got ['wall']"),
    "cells-not-a-table.toml": (('[cells.sand]\ncolour = "#e0c068"', '[cells]\nsand = 3'),
                               "cells.sand: expected a table { colour, label, passable }, got 3"),
    "preset-not-a-table.toml": (('tiny = { environments = "all", thetas = 60 }', "tiny = 60"),
                                "presets.tiny: expected a table { environments, thetas }, got 60"),
    "one-theta.toml": (("thetas = 60", "thetas = 1"),
                       "presets.tiny.thetas: 1: must be at least 2 (how many θ: θ* and at least one other)"),
    "nan-distance.toml": (("max_moves = 20", "max_moves = 20\nmin_option_distance = nan"),
                          "min_option_distance: nan: expected a finite number"),
    "tests-a-table.toml": (('tests = ["wade"]', 'tests = [{ name = "wade" }]'),
                           "tests[0]: expected a text, got {'name': 'wade'}"),
    "taken-name.toml": (('name = "key-room"', 'name = "gridworld"'), "name: 'gridworld' is already a domain's name"),
    "not-toml.toml": (("width = 7", "width = "), "not valid TOML: "),
}


@pytest.fixture(scope="module")
def worlds(tmp_path_factory):
    """The folder: the good file, every broken one, one not UTF-8 and one that cannot be read."""
    folder = tmp_path_factory.mktemp("worlds")
    text = key_room.PATH.read_text()
    (folder / "good.toml").write_text(GOOD)
    for name, ((old, new), _) in BROKEN.items():
        assert old in text, name
        (folder / name).write_text(text.replace(old, new))
    # Latin-1 where UTF-8 is expected: "Schlüsselraum" saved by an editor set to Windows-1252
    (folder / "latin-1.toml").write_bytes(text.replace("width", 'title = "Schlüsselraum"\nwidth', 1)
                                          .encode("latin-1"))
    (folder / "dangling.toml").symlink_to(folder / "moved-away.toml")
    return folder


EXPECTED = {**{name: line for name, (_, line) in BROKEN.items()},
            "latin-1.toml": "line 5: byte 0xfc is not UTF-8 text (save the file as UTF-8)",
            "dangling.toml": "cannot be read: No such file or directory"}


def test_each_broken_file_is_left_out_with_one_line_naming_it_and_its_field(worlds):
    assert len(EXPECTED) >= 10
    before = len(WORLD_ERRORS)
    try:
        assert register_world_files(str(worlds)) == ["key-room-ok"]
        assert "key-room-ok" in domain_names()
    finally:
        unregister("key-room-ok")
    errors = WORLD_ERRORS[before:]
    assert len(errors) == len(EXPECTED), errors
    by_file = {line.split(": ", 1)[0]: line.split(": ", 1)[1] for line in errors}
    assert set(by_file) == set(EXPECTED)
    for name, line in EXPECTED.items():
        assert "\n" not in by_file[name]
        if name == "not-toml.toml":  # the rest is tomllib's own words
            assert by_file[name].startswith(line), by_file[name]
        else:
            assert by_file[name] == line, name


def test_every_other_domain_still_runs_from_the_command_line(worlds, tiny_table, gridworld_tiny_table):
    env = {**os.environ, "TEACHING_WORLDS": str(worlds)}

    def run(*args):
        done = subprocess.run([sys.executable, "-m", "teaching", *args], env=env, capture_output=True, text=True,
                              timeout=600)
        assert done.returncode == 0 and "Traceback" not in done.stderr, (args, done.stdout, done.stderr)
        return done

    for table in (tiny_table, gridworld_tiny_table):
        run("info", str(table))
    checked = run("check-domain", "gridworld")
    assert "gridworld: all 7 checks pass" in checked.stdout
    # the good file beside the broken ones is a domain of its own
    assert "key-room-ok: all 7 checks pass" in run("check-domain", "key-room-ok").stdout
    refused = [line for line in checked.stderr.splitlines() if line.startswith("world file not registered: ")]
    assert len(refused) == len(EXPECTED), checked.stderr
