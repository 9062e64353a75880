"""The study spec's JSON Schema (studyapp/spec.schema.json), made from the fields declared in specschema: the
published file is current, a real spec meets it, and on each mistake a field can have by itself the schema
an editor checks and the app's own check (create_study's) agree."""
from __future__ import annotations

import json

import pytest
from django.core.management import call_command
from django.core.management.base import CommandError
from jsonschema import Draft7Validator

from studyapp.management.commands.spec_schema import PUBLISHED
from studyapp.researcher import specschema
from studyapp.researcher.specjson import field_schema, spec_schema
from studyapp.researcher.specrules import Field, SpecError
from studyapp.researcher.studies import table_spec
from tests.conftest import SMALL_SEQUENCES, TINY_TEST_SET

VALIDATOR = Draft7Validator(spec_schema())


def test_the_published_schema_is_the_one_the_declarations_make(capsys):
    call_command("spec_schema", "--check")
    assert "is current" in capsys.readouterr().out
    assert json.loads(PUBLISHED.read_text()) == spec_schema()
    Draft7Validator.check_schema(spec_schema())


def test_a_stale_schema_is_caught(tmp_path, monkeypatch):
    stale = tmp_path / "spec.schema.json"
    stale.write_text("{}\n")
    monkeypatch.setattr("studyapp.management.commands.spec_schema.PUBLISHED", stale)
    with pytest.raises(CommandError, match="out of date"):
        call_command("spec_schema", "--check")


def test_every_declared_field_is_in_it_with_its_help():
    props = spec_schema()["properties"]
    for name, f in {**specschema.STUDY_FIELDS, **specschema.SPEC_FIELDS}.items():
        assert props[name]["description"] == f.help
    assert set(spec_schema()["required"]) == {"slug", "conditions", "table", "test_set"}


def test_a_rule_without_a_json_shape_is_refused_with_its_name():
    def odd(f, v, found, where):
        return v

    with pytest.raises(ValueError, match="its rule odd has no JSON shape"):
        field_schema(Field("odd_field", odd, "An odd field."))


@pytest.fixture
def spec(tiny_table):
    out = table_spec(tiny_table, slug="schema-check", sequences=SMALL_SEQUENCES, **TINY_TEST_SET)
    return {"$schema": "studyapp/spec.schema.json", **out, "name": "Schema check", "target_per_condition": 12,
            "recruitment": "prolific", "completion_code": "C0DE", "language": "de", "bonus_per_correct": 0.25}


def test_a_real_spec_meets_the_schema_and_the_app(spec):
    assert list(VALIDATOR.iter_errors(spec)) == []
    specschema.check_spec(spec)


@pytest.mark.parametrize("field, value", [
    ("slug", "two words"), ("slug", "x" * 51), ("name", 3), ("target_per_condition", "30"),
    ("target_per_condition", 0), ("target_per_condition", 100_001), ("recruitment", "email"), ("language", "fr"),
    ("estimated_minutes", 2.5), ("bonus_per_correct", -1), ("bonus_cap", 101), ("keep_trails", "yes"),
    ("allow_phones", 1), ("conditions", []), ("conditions", [{"env_ids": [1, 2]}]),
    ("conditions", [{"name": "a b", "env_ids": [1]}]), ("conditions", [{"name": "a", "env_ids": [1], "target": 0}]),
    ("theta_star", []), ("theta_star", ["x"]), ("is_open", "true"), ("table", 7), ("test_set", {"env_id": 1}),
])
def test_on_a_fields_own_mistake_the_schema_and_the_app_agree(spec, field, value):
    spec[field] = value
    errors = list(VALIDATOR.iter_errors(spec))
    assert errors and all(list(e.absolute_path)[:1] == [field] for e in errors), [e.message for e in errors]
    with pytest.raises(SpecError):
        specschema.check_spec(spec)
