"""The designer's form fields made from declarations: a study spec's field (studyapp/researcher/specschema.py) and a
registered selector's numeric parameters (teaching's selector registry).  Each field takes its bounds,
choices, default and help from the declaration and only reads the text: the spec's schema judges the
value in the form's clean(), in the words every other entry point uses, and the bounds stay on the
widget.
"""
from __future__ import annotations

from django import forms
from django.core import validators

from studyapp.researcher import specrules, specschema
from teaching.api import get_selector, selector_names


class _SchemaChoice(forms.ChoiceField):
    """A choice the spec's schema judges (in its words); the widget offers the choices."""

    def validate(self, value):
        forms.Field.validate(self, value)


class _SchemaMultipleChoice(forms.MultipleChoiceField):
    def validate(self, value):
        forms.Field.validate(self, value)


_BOUNDS = (validators.MinValueValidator, validators.MaxValueValidator, validators.MinLengthValidator,
           validators.MaxLengthValidator)


def _judged_by_schema(field: forms.Field) -> forms.Field:
    field.validators = [v for v in field.validators if not isinstance(v, _BOUNDS)]
    return field


def schema_field(f: specschema.Field, **kwargs) -> forms.Field:
    """The form field of a study spec's field `f` (studyapp/researcher/specschema.py): its bounds, choices, default
    and help are the schema's."""
    kwargs = {"help_text": f.help, "initial": f.default, "required": f.default not in (None, ""), **kwargs}
    if f.kind is specrules.whole:
        field = forms.IntegerField(min_value=f.minimum, max_value=f.maximum, **kwargs)
    elif f.kind is specrules.number:
        field = forms.FloatField(min_value=f.minimum, max_value=f.maximum, **kwargs)
    elif f.choices:
        kind = _SchemaMultipleChoice if f.kind is specrules.selected else _SchemaChoice
        field = kind(choices=f.choices, **kwargs)
    else:
        field = forms.CharField(max_length=f.max_length, **kwargs)
    return _judged_by_schema(field)


def param_field_name(selector: str, key: str) -> str:
    """e.g. "bec_scaffold_k": a selector's parameter as a form field's name."""
    return f"{selector}_{key}".replace("-", "_").replace("*", "")


def selector_param_fields() -> dict[str, tuple[str, str, forms.Field]]:
    """{form field name: (selector, parameter, its field)} of every registered selector's numeric
    parameters, in registration order: the label and help are the parameter's declaration, the bound
    its check's declared minimum, the initial value its default.  A parameter naming a learner model
    (coverage's) is not here: the designer's approx* sets it."""
    out = {}
    for name in selector_names():
        for key, param in get_selector(name).params.items():
            if isinstance(param.default, bool) or not isinstance(param.default, int | float):
                continue
            kind = forms.IntegerField if isinstance(param.default, int) else forms.FloatField
            field = kind(required=False, initial=param.default, min_value=getattr(param.check, "minimum", None),
                         label=f"{name}: {param.doc or key} ({key})",
                         help_text=f"Used when {name} is ticked; empty: its default, {param.default}.")
            out[param_field_name(name, key)] = (name, key, _judged_by_schema(field))
    return out
