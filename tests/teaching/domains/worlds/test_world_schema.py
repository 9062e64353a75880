"""A world file's fields are declared once, in world.schema.json: the schema is a schema an editor reads,
the shipped files name it and meet it, the docs' table lists exactly its fields, and each mistake it finds
is one line in the file's words (never the validator's own)."""
from __future__ import annotations

import re
import tomllib
from pathlib import Path

import pytest
from jsonschema import Draft7Validator

from teaching.core.schemacheck import field_name
from teaching.domains._grid.worldfile import WorldFileError, load_world
from teaching.domains._grid.worldschema import SCHEMA, SCHEMA_PATH
from tests.teaching.domains.worlds import key_room

ROOT = Path(__file__).resolve().parents[4]
SHIPPED = sorted((ROOT / "teaching" / "domains" / "worlds").glob("*.toml")) + [key_room.PATH]


def test_the_schema_is_a_draft_7_schema_with_a_description_for_every_top_level_field():
    Draft7Validator.check_schema(SCHEMA)
    assert SCHEMA["$schema"] == "http://json-schema.org/draft-07/schema#"
    missing = [k for k, v in SCHEMA["properties"].items() if "description" not in v and "$ref" not in v]
    assert missing == []


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.name)
def test_each_shipped_file_names_the_schema_on_its_first_line_and_meets_it(path):
    first = path.read_text().splitlines()[0]
    assert first.startswith("#:schema ")
    assert (path.parent / first.split(" ", 1)[1]).resolve() == SCHEMA_PATH.resolve()
    assert list(Draft7Validator(SCHEMA).iter_errors(tomllib.loads(path.read_text()))) == []


def test_the_docs_table_lists_exactly_the_schemas_fields():
    text = (ROOT / "docs" / "gridworlds.md").read_text()
    table = text.split("## The file, field by field", 1)[1].split("\n\n")[2]
    documented = set()
    for row in table.splitlines()[2:]:
        for name in re.findall(r"`\[?([a-z_]+)", row.split("|")[1]):
            documented.add(name)
    assert documented == set(SCHEMA["properties"])


@pytest.mark.parametrize("change, line", [
    (("width = 7", "width = 7.5"), "width: expected a whole number, got 7.5"),
    (("[cells.sand]", "[cells.wall]"), "cells.wall: expected a kind named in lower-case words joined by '-', and not "
                                       "'wall' (built in), got 'wall'"),
    (("max_moves = 20", "max_moves = 0"), "max_moves: 0: must lie in 1..200 (actions a stored trajectory holds"),
    (('counts = "moves"', 'counts = "mooves"'), "features[3].counts: 'mooves': one of moves, enter, reach, deliver; "
                                               "did you mean 'moves'?"),
    (("at = [4, 3]", "at = [4]"), "optional[4].at: expected a cell [x, y], got [4]"),
    (("at = [4, 3]", "at = [9, 3]"), "optional[4].at: cell [9, 3] lies outside the 7 x 5 grid"),
    (('kind = "puddle"', 'kind = "lava"'), "kind: unknown cell kind 'lava' (declared: wall, puddle, sand)"),
    (("name = \"key-room\"", "name = \"Key Room\""), "name: expected a lower-case name (letters, digits, '-'), "
                                                     "got 'Key Room'"),
    (("{ at = [1, 3] }", "{ at = [1, 3], key = [2, 2] }"), "starts[0].key: not a field of this table (one of at)"),
])
def test_a_mistake_is_one_line_in_the_files_words(tmp_path, change, line):
    text = key_room.PATH.read_text()
    assert change[0] in text
    path = tmp_path / "world.toml"
    path.write_text(text.replace(change[0], change[1], 1))
    with pytest.raises(WorldFileError) as err:
        load_world(path)
    message = str(err.value)
    assert message.startswith("world.toml: ") and line in message and "\n" not in message
    for validator_words in ("is not valid under", "Additional properties", "is a required property", "does not match"):
        assert validator_words not in message


def test_field_names_are_written_as_the_file_writes_them():
    assert field_name(["features", 3, "counts"]) == "features[3].counts"
    assert field_name(["translations", "de", "fetch the key"]) == 'translations.de."fetch the key"'
