"""A study spec as JSON Schema, made from the declarations in studyapp/researcher/specschema.py, never written by hand.

``manage.py spec_schema`` writes it to ``studyapp/spec.schema.json``; a spec that names it (``"$schema":
"<path to>/spec.schema.json"``) is checked by a researcher's editor as it is typed: each field's type,
choices, bounds and help, and the required ones.  It says what each field is by itself; what needs the table
or the other fields (environment ids of the table, a time limit longer than the study) is said by
``create_study``, in its one line.  Keys the spec does not declare are ignored by the app, so the schema
allows them too.
"""
from __future__ import annotations

from . import specrules as rules
from . import specschema
from .specrules import SELECTOR_SPELLINGS, Field

SLUG = "^[-a-zA-Z0-9_]+$"  # Django's slug_re, which the slug rule applies
# the JSON shape of a value of each rule (the rules of specrules and specschema a JSON spec uses)
SHAPES = {
    rules.string: {"type": "string"},
    rules.slug: {"type": "string", "pattern": SLUG},
    rules.condition_name: {"anyOf": [{"type": "string", "pattern": SLUG}, {"enum": list(SELECTOR_SPELLINGS)}]},
    rules.boolean: {"type": "boolean"},
    rules.whole: {"type": "integer"},
    rules.number: {"type": "number"},
    rules.questions: {"type": ["array", "string"]},
    rules.obj: {"type": "object"},
    rules.numbers: {"type": "array", "items": {"type": "number"}, "minItems": 1},
    rules.ids: {"type": "array", "items": {"type": "integer"}},
    rules.tests: {"type": "array", "items": {"type": "object"}},
    rules.loop: {"type": "object"},
    rules.selector: {"type": "string"},
    specschema.target: {"type": "integer", "minimum": 1, "maximum": specschema.MAX_TARGET},
}


def field_schema(f: Field) -> dict:
    """One field's JSON Schema: its rule's shape, its choices, bounds, length, default and help."""
    if f.kind is specschema.spec_conditions:
        shape = {"type": "array", "minItems": 1, "items": _object(specschema.CONDITION_FIELDS)}
    elif f.kind is rules.choice:
        shape = {"enum": f.values()}
    elif f.kind in SHAPES:
        shape = dict(SHAPES[f.kind])
    else:
        raise ValueError(f"field {f.name!r}: its rule {f.kind.__name__} has no JSON shape in specjson.SHAPES")
    bounds = {"minimum": f.minimum, "maximum": f.maximum, "maxLength": f.max_length}
    shape.update({k: v for k, v in bounds.items() if v is not None})
    if f.default is not None:
        shape["default"] = f.default
    if not f.required:  # a field left out may also be given as null or empty (specschema._empty)
        shape = {"anyOf": [shape, {"type": "null"}]} if "enum" in shape or "anyOf" in shape else \
            {**shape, "type": [*_types(shape), "null"]} if "type" in shape else shape
    return {"description": f.help, **shape} if f.help else shape


def _types(shape: dict) -> list[str]:
    kind = shape["type"]
    return list(kind) if isinstance(kind, list) else [kind]


def _object(fields: dict[str, Field]) -> dict:
    return {"type": "object", "required": [n for n, f in fields.items() if f.required],
            "properties": {n: field_schema(f) for n, f in fields.items()}}


def spec_schema() -> dict:
    """The JSON Schema (draft 7) of a study spec: the study's fields and the spec's own."""
    body = _object({**specschema.STUDY_FIELDS, **specschema.SPEC_FIELDS})
    body["properties"]["$schema"] = {"type": "string", "description": "Where this schema is (for editors)."}
    return {"$schema": "http://json-schema.org/draft-07/schema#", "title": "a study spec",
            "description": "A study spec for `python manage.py create_study spec.json` (docs/study.md, \"A spec's "
                           "fields\"). Made from studyapp/researcher/specschema.py by `python manage.py spec_schema`.",
            **body}
