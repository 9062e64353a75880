"""Where each of the study designer's fields stands on its page: five numbered sections, top to
bottom, then a summary before "Build".

The designer's form (precompute/design.py) declares what a field is; this module only places it.
The conditions are a table of rows, one per registered selector, each with its own parameters
beside its tick box; the other fields go in groups, and a group the researcher rarely needs
(a hand-picked or closed-loop condition, the learner models' settings, the consent texts) is folded,
opening by itself when one of its fields holds an error or a value of the researcher's own.

Every field of the form stands in exactly one place (tests/precompute/test_designer.py): a field
added to the form and forgotten here would fail that test, not vanish from the page.
"""
from __future__ import annotations

from dataclasses import dataclass, field

from studyapp.researcher.specschema import BONUS_FIELDS, COMPREHENSION_FIELDS, OUTCOME_FIELDS, TEXT_FIELDS
from teaching.api import get_selector


@dataclass(frozen=True)
class Group:
    """Fields shown together; `fields` may hold a callable (form -> names) for fields the form makes
    at run time (the fixed τ / λ of each learner model)."""
    fields: tuple = ()
    title: str = ""
    folded: bool = False
    wide: bool = False  # one field per line: a long choice (the table's identity) needs the width
    opened_by: tuple[str, ...] = ()  # fields whose own value (not the initial one) opens the fold


@dataclass(frozen=True)
class Section:
    key: str
    title: str
    intro: str
    groups: tuple[Group, ...] = field(default_factory=tuple)
    condition_rows: bool = False  # the conditions' table heads this section


def _fixed_fields(form) -> tuple[str, ...]:
    return tuple(name for name in form.fields if name.startswith("fixed_"))


LOOP_FIELDS = ("loop_name", "loop_model", "loop_value", "loop_lapse", "loop_max_examples", "loop_check_every",
               "loop_feedback", "loop_fit_from")

SECTIONS = (
    Section("study", "Study and table",
            "The table every condition and test is drawn from (its robot is the study's), and the study's names.",
            (Group(("table",), wide=True), Group(("slug", "name")))),
    Section("conditions", "Conditions",
            "Tick a row for each condition participants may be assigned to; its parameters are on its row (empty: "
            "the default). A hand-picked or a closed-loop condition is added below the table.",
            (Group(("hand_picked_name", "hand_picked_env_ids"), "A hand-picked condition", folded=True,
                   opened_by=("hand_picked_env_ids",)),
             Group(LOOP_FIELDS, "A closed-loop condition", folded=True, opened_by=("loop_name",)),
             Group(("approx_star", "seed", _fixed_fields), "Learner models and seed", folded=True)),
            condition_rows=True),
    Section("tests", "Tests",
            "The test set every participant answers after training: whether they choose the robot's way among four or "
            "show it themselves (grid worlds from a file), how hard its questions are, and how far apart their options "
            "must be.",
            (Group(("test_kind", "test_difficulty", "min_regret", "min_distance")),)),
    Section("participants", "Participants and payment",
            "How many participants each condition needs, where they come from, what they are told they earn, and "
            "which devices may take part.",
            (Group(("target_per_condition", "recruitment", "completion_code", "estimated_minutes",
                    "duration_tolerance_minutes", "payment_amount", "bonus_currency", "payment")),
             Group(("devices", "min_screen_width"), "Devices that may take part"),
             Group(("keep_trails",), "What the test pages show"),
             Group(BONUS_FIELDS[:3], "A performance bonus", folded=True, opened_by=BONUS_FIELDS[:3]),
             Group(OUTCOME_FIELDS, "Time limit and a code for each way of ending", folded=True,
                   opened_by=OUTCOME_FIELDS))),
    Section("texts", "Texts", "The language participants read, what the consent page says besides the payment and "
                              "time above, and the questions that may check the instructions were understood.",
            (Group(("language",)),
             Group(tuple(f for f in TEXT_FIELDS if f not in ("estimated_minutes", "payment", "payment_amount")),
                   "The consent page",
                   folded=True, opened_by=("consent_text", "contact", "ethics_reference")),
             Group(COMPREHENSION_FIELDS, "A comprehension check", folded=True, wide=True,
                   opened_by=("comprehension_check",)))),
)


def _names(group: Group, form) -> list[str]:
    out = []
    for item in group.fields:
        out.extend(item(form) if callable(item) else (item,))
    return out


def _own_value(bound) -> bool:
    """Whether the researcher typed or picked something other than the field's initial value."""
    if not bound.form.is_bound:
        return False
    return str(bound.value() or "").strip() not in ("", str(bound.initial or ""))


def condition_rows(form) -> list[dict]:
    """One row per registered selector: its tick box, what it does, and its parameters' fields."""
    params: dict[str, list] = {}
    for name, (selector, _key, _field) in form.selector_params.items():
        bound = form[name]  # its label names the selector, which the row already does
        params.setdefault(selector, []).append({"field": bound, "label": bound.label.removeprefix(f"{selector}: ")})
    return [{"box": box, "name": box.data["value"], "doc": get_selector(box.data["value"]).doc,
             "params": params.get(box.data["value"], [])} for box in form["conditions"]]


def placed_fields(form) -> list[str]:
    """Every field the page shows, in page order (the rows' parameters included)."""
    out = ["conditions", *form.selector_params]
    for section in SECTIONS:
        for group in section.groups:
            out.extend(_names(group, form))
    return out


def sections(form) -> list[dict]:
    """The page's sections as the template draws them: bound fields per group, each fold open when
    a field in it has an error or a value of the researcher's own."""
    out = []
    for number, section in enumerate(SECTIONS, 1):
        groups = []
        for group in section.groups:
            fields = [form[name] for name in _names(group, form)]
            opened = any(b.errors for b in fields) or any(_own_value(form[n]) for n in group.opened_by)
            groups.append({"title": group.title, "folded": group.folded, "wide": group.wide, "open": opened,
                           "fields": fields})
        rows = condition_rows(form) if section.condition_rows else None
        shown = [b for g in groups for b in g["fields"]] + [p["field"] for r in rows or () for p in r["params"]]
        out.append({"key": section.key, "number": number, "title": section.title, "intro": section.intro,
                    "groups": groups, "rows": rows, "conditions": form["conditions"] if rows is not None else None,
                    "has_errors": any(b.errors for b in shown) or bool(rows is not None and form["conditions"].errors)})
    return out
