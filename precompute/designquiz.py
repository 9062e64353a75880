"""The study designer's comprehension check (studyapp/participant/comprehension.py): a tick box, the questions as text
(one block per question, '* ' before a right choice, '- ' before a wrong one) and the attempts.

The questions are prefilled with the chosen table's robot's own (designer.js swaps them when another
table is chosen, unless the researcher has edited them); questions left as some robot's own are stored
empty, so the study asks its own robot's, whatever table was chosen without JavaScript.
"""
from __future__ import annotations

import json

from django import forms

from studyapp.participant import comprehension
from studyapp.researcher.specschema import STUDY_FIELDS
from teaching.api import domain_names, get_domain

from .schemafields import schema_field

FIELDS = ("comprehension_check", "comprehension_questions", "comprehension_attempts")


def _defaults_text(domain: str) -> str:
    return comprehension.format_text(comprehension.defaults(get_domain(domain)))


def _same(a: str, b: str) -> bool:
    def lines(text):
        return [line.strip() for line in (text or "").replace("\r\n", "\n").strip().split("\n")]

    return lines(a) == lines(b)


def fields(tables: list[dict]) -> dict[str, forms.Field]:
    """The three fields, the questions prefilled with the first table's robot's own."""
    by_table = {t["path"]: _defaults_text(t["domain"]) for t in tables}
    first = next(iter(by_table.values()), "")
    return {
        "comprehension_check": forms.BooleanField(
            required=False, label="Ask a comprehension check after the instructions",
            help_text=STUDY_FIELDS["comprehension_check"].help),
        "comprehension_questions": forms.CharField(
            required=False, initial=first, label="Comprehension questions",
            help_text=STUDY_FIELDS["comprehension_questions"].help,
            widget=forms.Textarea(attrs={"rows": 12, "data-comprehension-defaults": json.dumps(by_table)})),
        # empty (a post from before the check existed): the schema's default
        "comprehension_attempts": schema_field(STUDY_FIELDS["comprehension_attempts"], required=False,
                                               label="Comprehension check: attempts"),
    }


def arguments(data: dict) -> dict:
    """The study's comprehension fields from the designer's cleaned data: questions that are some robot's own
    (the prefilled text, unchanged) are stored empty (the study's robot's own); with the check off, none."""
    on = bool(data.get("comprehension_check"))
    text = (data.get("comprehension_questions") or "").strip() if on else ""
    if any(_same(text, _defaults_text(d)) for d in domain_names()):
        text = ""
    return {"comprehension_check": on, "comprehension_questions": text,
            "comprehension_attempts": data.get("comprehension_attempts")}
