"""A world file's fields, declared once: ``world.schema.json`` (JSON Schema, draft 7: what editors' TOML
support reads), and the one-line refusal of a file that does not match it.

The schema holds each field's type, choices, bounds and whether it may be left out, with a description a
researcher's editor shows as they type (docs/gridworlds.md, "Checked as you type").  A file is checked
against it before anything is read from it; what one field says of another (a cell inside the grid, a kind
that is declared, one weight per feature) is worldfile's to check, after.  Every refusal is a
:class:`WorldFileError`: one line naming the file, the field and what is wrong.
"""
from __future__ import annotations

import json
from pathlib import Path

from jsonschema import Draft7Validator

from ...core.schemacheck import first_mistake

SCHEMA_PATH = Path(__file__).with_name("world.schema.json")
SCHEMA = json.loads(SCHEMA_PATH.read_text(encoding="utf-8"))
_VALIDATOR = Draft7Validator(SCHEMA)


class WorldFileError(ValueError):
    """A world file that cannot be used (one line: the file, the field, what is wrong)."""


class _Reader:
    """The refusals of one file: every message names the file and the field."""

    def __init__(self, name: str):
        self.name = name

    def fail(self, where: str, what: str):
        raise WorldFileError(f"{self.name}: {where}: {what}")


def check_shape(raw: dict, r: _Reader) -> None:
    """`raw` (a parsed file) against the schema: WorldFileError naming the first mistake's field."""
    mistake = first_mistake(_VALIDATOR, raw)
    if mistake is not None:
        r.fail(*mistake)
