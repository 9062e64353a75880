"""A file a researcher writes, checked against its JSON Schema (draft 7), and its first mistake as one line in
the file's own words: the field as the file writes it (``features[3].counts``, ``translations.de."key"``) and
what is wrong, with a "did you mean" for a near miss.

World files (teaching/domains/_grid/world.schema.json) and imported tables' ``table.toml``
(teaching/importing/table.schema.json) are both checked this way.  A schema's own ``title`` names the kind
of file; a field's ``title`` what its value must be, and its ``description`` why, for the refusal to quote.
"""
from __future__ import annotations

import difflib
import json
import re

from jsonschema import Draft7Validator
from jsonschema.exceptions import ValidationError, best_match

# what a value of each JSON type is called in a refusal
_TYPES = {"string": "a text", "integer": "a whole number", "number": "a number", "boolean": "true or false",
          "array": "a list", "object": "a table"}
# keywords whose refusal is the schema's title for the value: "expected <title>, got <value>"
_TITLED = {"type", "pattern", "anyOf", "not", "const", "minItems", "maxItems"}


def did_you_mean(name: str, known) -> str:
    """'; did you mean ...' for a name close to one of `known` (a typo), else ''."""
    close = difflib.get_close_matches(name, list(known), n=1)
    return f"; did you mean {close[0]!r}?" if close else ""


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


def first_mistake(validator: Draft7Validator, raw: dict) -> tuple[str, str] | None:
    """(field, what is wrong) of the most telling mistake of `raw` (a parsed file) against the validator's
    schema, or None when it matches."""
    error = best_match(validator.iter_errors(raw))
    return None if error is None else refusal(error, validator.schema.get("title", "this file"))


def _got(value) -> str:
    return repr(value)[:80]


def refusal(error: ValidationError, document: str = "this file") -> tuple[str, str]:
    """(field, what is wrong) of one schema error, in the words of the file's fields; `document` is what
    the whole file is called ("a world file")."""
    where, schema, value, keyword = list(error.absolute_path), error.schema, error.instance, error.validator
    if keyword == "additionalProperties":
        known = list(schema.get("properties", {}))
        extra = next(k for k in value if k not in known)
        table = document if not where else "this table"
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
