"""The participant texts of a world file, checked: ``[texts]`` (the defaults a file replaces) and
``[translations.<language>]`` (its own texts in other languages).  docs/gridworlds.md, "Participant texts,
comprehension questions and languages".

Their shapes (which keys, texts that are not empty, how many questions and choices) are the schema's
(worldschema); these checks are what one text says of another: the braces a paragraph fills in, the right
choices among a question's, a translation of a text the file has.  Each takes the file's reader, so every
mistake is the same one line naming the file and the field.
"""
from __future__ import annotations

import string

from ...core.schemacheck import did_you_mean, field_name
from .worldschema import _Reader

# what an instruction paragraph may leave to be filled in per participant (ParticipantTexts.instructions)
INSTRUCTION_FIELDS = ("n_training", "n_tests", "training_plural", "tests_plural")


def _fields(text: str) -> set[str] | None:
    """The {placeholders} of `text` (str.format's), None where its braces are not str.format's."""
    try:
        return {name for _, name, _, _ in string.Formatter().parse(text) if name is not None}
    except ValueError:
        return None


def check_texts(r: _Reader, raw: dict) -> dict:
    """[texts] as filedomain._texts reads them: the instructions a tuple of paragraphs, each filling in only
    INSTRUCTION_FIELDS, and the comprehension check a tuple of (question, choices, right choices' 0-based
    positions)."""
    out = dict(raw)
    if "instructions" in raw:
        out["instructions"] = tuple(raw["instructions"])
        for i, paragraph in enumerate(out["instructions"]):
            names = _fields(paragraph)
            if names is None or names - set(INSTRUCTION_FIELDS):
                r.fail(f"texts.instructions[{i}]", "braces only around what is filled in per participant: "
                       f"{', '.join('{' + f + '}' for f in INSTRUCTION_FIELDS)} (write {{{{ for a brace)")
    if "comprehension" in raw:
        out["comprehension"] = tuple(_question(r, item, f"texts.comprehension[{i}]")
                                     for i, item in enumerate(raw["comprehension"]))
    return out


def _question(r: _Reader, item: dict, at: str) -> tuple:
    """One comprehension question: (question, choices, the right ones' 0-based positions, sorted)."""
    choices, right = tuple(item["choices"]), item["right"]
    for k in right:
        if not 1 <= k <= len(choices):
            r.fail(at + ".right", f"{k!r} is not a choice's position (1 to {len(choices)}, in the order listed)")
    if len(set(right)) != len(right):
        r.fail(at + ".right", f"{right}: a position given twice")
    if len(right) == len(choices):
        r.fail(at + ".right", "every choice is right, so the question checks nothing")
    return item["question"], choices, tuple(sorted(k - 1 for k in right))


def check_translations(r: _Reader, raw: dict, own: tuple[str, ...], paragraphs) -> dict[str, dict[str, str]]:
    """[translations.<language>]: each of the file's own texts (`own`: World.participant_texts) -> its
    translation; a translation of one of the instructions' `paragraphs` fills in only what the English does."""
    paragraphs, out = set(paragraphs), {}
    for language, table in raw.items():
        for key, value in table.items():
            at = field_name(["translations", language, key])
            if key not in own:
                r.fail(at, "not one of the file's own participant texts (its title, cell labels, object name and "
                       f"[texts], written exactly){did_you_mean(key, own)}")
            if key in paragraphs:  # filled in per participant: a name the English lacks has no value
                names, english = _fields(value), _fields(key)
                if names is None or not names <= english:
                    r.fail(at, "braces only around what the English paragraph fills in "
                           f"({', '.join('{' + f + '}' for f in sorted(english)) or 'nothing'}; {{{{ for a brace)")
        out[language] = dict(table)
    return out
