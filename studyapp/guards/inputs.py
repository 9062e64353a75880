"""What a participant's browser sends, read in one place: a field sent once, and whole numbers as ASCII
digits with a length bound.

Python's ``str.isdigit`` and ``int`` also take "²", "١٩٢٠" and full-width digits, and ``int`` parses a
5,000-digit number (or refuses one past 4,300 digits with a ValueError): no page of the study sends
either, so both are refused here as a tampered post, before anything is stored.
"""
from __future__ import annotations

import re

from django import forms
from django.core.exceptions import ValidationError

MAX_DIGITS = 9  # the largest number a page sends is a screen width in CSS pixels
_ASCII_WHOLE = re.compile(rf"[0-9]{{1,{MAX_DIGITS}}}")


def parse_whole(value) -> int | None:
    """`value` (a str as posted, already stripped) as a whole number >= 0, or None unless it is 1 to
    MAX_DIGITS ASCII digits."""
    return int(value) if isinstance(value, str) and _ASCII_WHOLE.fullmatch(value) else None


class OneValue(forms.TextInput):
    """Exactly one value, stripped: a field sent twice counts as missing instead of Django's
    usual last-one-wins, so a tampered or doubled post is refused rather than half-read."""

    def value_from_datadict(self, data, files, name):
        values = data.getlist(name) if hasattr(data, "getlist") else [data.get(name)]
        return values[0].strip() if len(values) == 1 and isinstance(values[0], str) else None


class WholeNumberField(forms.IntegerField):
    """A whole number as :func:`parse_whole` reads it: no "6.0", no "-3", no digits but ASCII's, at
    most MAX_DIGITS of them; anything else is the field's "invalid" message."""

    widget = OneValue

    def to_python(self, value):
        if value in self.empty_values:
            return None
        number = parse_whole(value.strip() if isinstance(value, str) else value)
        if number is None:
            raise ValidationError(self.error_messages["invalid"], code="invalid")
        return number
