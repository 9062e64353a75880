"""A world file's fields, declared once: ``world.schema.json`` (JSON Schema, draft 7: what editors' TOML
support reads), and the one-line refusal of a file that does not match it.

The schema holds each field's type, choices, bounds and whether it may be left out, with a description a
researcher's editor shows as they type (docs/gridworlds.md, "Checked as you type").  A file is checked
against it before anything is read from it; what one field says of another (a cell inside the grid, a kind
that is declared, one weight per feature) is worldfile's to check, after.  Every refusal is a
:class:`WorldFileError`: one line naming the file, the field and what is wrong.
"""
from __future__ import annotations

import difflib
import json
import re
from pathlib import Path

from jsonschema import Draft7Validator
from jsonschema.exceptions import ValidationError, best_match

SCHEMA_PATH = Path(__file__).with_name("world.schema.json")
SCHEMA = json.loads(SCHEMA_PATH.read_text(encoding="utf-8"))
_VALIDATOR = Draft7Validator(SCHEMA)
# what a value of each JSON type is called in a refusal
_TYPES = {"string": "a text", "integer": "a whole number", "number": "a number", "boolean": "true or false",
          "array": "a list", "object": "a table"}
# keywords whose refusal is the schema's title for the value: "expected <title>, got <value>"
_TITLED = {"type", "pattern", "anyOf", "not", "const", "minItems", "maxItems"}


class WorldFileError(ValueError):
    """A world file that cannot be used (one line: the file, the field, what is wrong)."""


def did_you_mean(name: str, known) -> str:
    """'; did you mean ...' for a name close to one of `known` (a typo), else ''."""
    close = difflib.get_close_matches(name, list(known), n=1)
    return f"; did you mean {close[0]!r}?" if close else ""


class _Reader:
    """The refusals of one file: every message names the file and the field."""

    def __init__(self, name: str):
        self.name = name

    def fail(self, where: str, what: str):
        raise WorldFileError(f"{self.name}: {where}: {what}")


def toml_key(key: str) -> str:
    """`key` as a TOML file writes it: bare (letters, digits, '_', '-'), else quoted."""
    return key if re.fullmatch(r"[A-Za-z0-9_-]+", key) else json.dumps(key, ensure_ascii=False)


def field_name(path) -> str:
    """A path into the file (keys and list positions) as its fields are written: features[3].counts,
    translations.de."fetch the key"."""
    out = ""
    for part in path:
        out += f"[{part}]" if isinstance(part, int) else (f".{toml_key(part)}" if out else toml_key(part))
    return out


def check_shape(raw: dict, r: _Reader) -> None:
    """`raw` (a parsed file) against the schema: WorldFileError naming the first mistake's field."""
    error = best_match(_VALIDATOR.iter_errors(raw))
    if error is not None:
        r.fail(*refusal(error))


def _got(value) -> str:
    return repr(value)[:80]


def refusal(error: ValidationError) -> tuple[str, str]:
    """(field, what is wrong) of one schema error, in the words of the file's fields."""
    where, schema, value, keyword = list(error.absolute_path), error.schema, error.instance, error.validator
    if keyword == "additionalProperties":
        known = list(schema.get("properties", {}))
        extra = next(k for k in value if k not in known)
        table = "a world file" if not where else "this table"
        return (field_name([*where, extra]),
                f"not a field of {table} (one of {', '.join(known)}){did_you_mean(extra, known)}")
    if keyword == "required":
        return field_name([*where, next(k for k in error.validator_value if k not in value)]), "missing"
    if "propertyNames" in error.absolute_schema_path:  # a key itself is wrong: the error's value is the key
        return field_name([*where, value]), f"expected {schema['title']}, got {_got(value)}"
    if keyword == "enum":
        choices = [str(c) for c in error.validator_value]
        return field_name(where), f"{_got(value)}: one of {', '.join(choices)}{did_you_mean(str(value), choices)}"
    if keyword in ("minimum", "maximum"):
        low, high = schema.get("minimum"), schema.get("maximum")
        bound = f"must lie in {low}..{high}" if low is not None and high is not None else (
            f"must be at least {low}" if keyword == "minimum" else f"must be at most {high}")
        about = f" ({schema['description']})" if "description" in schema else ""
        return field_name(where), f"{value}: {bound}{about}"
    if keyword in ("minItems", "maxItems") and "title" not in schema:
        n = error.validator_value
        bound = f"at least {n} needed" if keyword == "minItems" else f"at most {n}"
        about = f" ({schema['description']})" if "description" in schema else ""
        return field_name(where), f"{len(value)} given, {bound}{about}"
    if keyword in _TITLED and "title" in schema:
        return field_name(where), f"expected {schema['title']}, got {_got(value)}"
    if keyword == "type":
        kind = _TYPES.get(error.validator_value, error.validator_value)
        fields = list(schema.get("properties", {}))
        if kind == "a table" and fields:
            kind = f"a table {{ {', '.join(fields)} }}"
        return field_name(where), f"expected {kind}, got {_got(value)}"
    return field_name(where), error.message  # a keyword this file's schema does not use yet
