"""The participant texts of a world file, checked: ``[texts]`` (the defaults a file replaces) and
``[translations.<language>]`` (its own texts in other languages).  docs/gridworlds.md, "Participant texts,
comprehension questions and languages".

Each check takes the world file's reader (worldfile._Reader), so every mistake is the same one line naming
the file and the field.
"""
from __future__ import annotations

import difflib
import json
import re
import string
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from .worldfile import World, _Reader

# [texts]: what the domain's participant texts take from the file (filedomain._texts), each text a string but
# the instructions (paragraphs) and the comprehension check (questions)
TEXT_KEYS = ("summary", "consent", "instructions", "attention_question", "watch", "question", "title",
             "comprehension")
# what an instruction paragraph may leave to be filled in per participant (ParticipantTexts.instructions)
INSTRUCTION_FIELDS = ("n_training", "n_tests", "training_plural", "tests_plural")
QUESTION_KEYS = ("question", "choices", "right")
MAX_QUESTIONS, MAX_CHOICES = 20, 8  # a study's own comprehension questions have the same limits


def did_you_mean(name: str, known) -> str:
    """', did you mean ...' for a name close to one of `known` (a typo), else ''."""
    close = difflib.get_close_matches(name, list(known), n=1)
    return f"; did you mean {close[0]!r}?" if close else ""


def _text(r: _Reader, value, where: str) -> str:
    if not isinstance(value, str) or not value.strip():
        r.fail(where, f"expected a non-empty text, got {repr(value)[:80]}")
    return value


def _fields(text: str) -> set[str] | None:
    """The {placeholders} of `text` (str.format's), None where its braces are not str.format's."""
    try:
        return {name for _, name, _, _ in string.Formatter().parse(text) if name is not None}
    except ValueError:
        return None


def check_texts(r: _Reader, raw: dict) -> dict:
    """[texts] checked: only the keys filedomain._texts reads, each of its type (module constants)."""
    out = {}
    for key, value in raw.items():
        where = f"texts.{key}"
        if key not in TEXT_KEYS:
            r.fail(where, f"not a text a world file gives (one of {', '.join(TEXT_KEYS)})"
                   f"{did_you_mean(key, TEXT_KEYS)}")
        if key == "instructions":
            if not isinstance(value, list) or not value:
                r.fail(where, f"expected a list of paragraphs (texts), got {repr(value)[:80]}")
            out[key] = tuple(_text(r, p, f"{where}[{i}]") for i, p in enumerate(value))
            for i, paragraph in enumerate(out[key]):
                names = _fields(paragraph)
                if names is None or names - set(INSTRUCTION_FIELDS):
                    r.fail(f"{where}[{i}]", "braces only around what is filled in per participant: "
                           f"{', '.join('{' + f + '}' for f in INSTRUCTION_FIELDS)} (write {{{{ for a brace)")
        elif key == "comprehension":
            out[key] = _comprehension(r, value, where)
        else:
            out[key] = _text(r, value, where)
    return out


def _comprehension(r: _Reader, value, where: str) -> tuple:
    """texts.comprehension: [{question, choices, right}] -> ((question, choices, 0-based right), ...)."""
    if not isinstance(value, list) or not value or len(value) > MAX_QUESTIONS:
        r.fail(where, f"expected a list of 1 to {MAX_QUESTIONS} questions "
               "({ question = \"...\", choices = [\"...\", ...], right = [1] }), got " + repr(value)[:80])
    out = []
    for i, item in enumerate(value):
        at = f"{where}[{i}]"
        if not isinstance(item, dict):
            r.fail(at, f"expected a table {{ question, choices, right }}, got {repr(item)[:80]}")
        for key in item:
            if key not in QUESTION_KEYS:
                r.fail(f"{at}.{key}", f"not one of {', '.join(QUESTION_KEYS)}{did_you_mean(key, QUESTION_KEYS)}")
        question = _text(r, r.get(item, "question", at + ".", str), at + ".question")
        choices = r.get(item, "choices", at + ".", list)
        if not 2 <= len(choices) <= MAX_CHOICES:
            r.fail(at + ".choices", f"a question needs 2 to {MAX_CHOICES} choices, not {len(choices)}")
        choices = tuple(_text(r, c, f"{at}.choices[{k}]") for k, c in enumerate(choices))
        right = r.get(item, "right", at + ".", list)
        if not right:
            r.fail(at + ".right", "no right choice: give the positions of the right ones, e.g. right = [1]")
        for k in right:
            if not isinstance(k, int) or isinstance(k, bool) or not 1 <= k <= len(choices):
                r.fail(at + ".right", f"{k!r} is not a choice's position (1 to {len(choices)}, in the order listed)")
        if len(set(right)) != len(right):
            r.fail(at + ".right", f"{right}: a position given twice")
        if len(right) == len(choices):
            r.fail(at + ".right", "every choice is right, so the question checks nothing")
        out.append((question, choices, tuple(sorted(k - 1 for k in right))))
    return tuple(out)


def check_translations(r: _Reader, raw: dict, world: World) -> dict[str, dict[str, str]]:
    """[translations.<language>]: each of the file's own texts (World.participant_texts) -> its translation;
    an instruction paragraph's translation fills in only what the English fills in."""
    own, paragraphs = world.participant_texts, set(world.texts.get("instructions", ()))
    out = {}
    for language, table in raw.items():
        where = f"translations.{language}"
        if not re.fullmatch(r"[a-z]{2}", language):
            r.fail(where, f"{language!r} is not a language's two-letter code in lower case (e.g. de)")
        if not isinstance(table, dict):
            r.fail(where, f"expected a table of \"English text\" = \"translation\", got {repr(table)[:80]}")
        for key, value in table.items():
            at = f"{where}.{json.dumps(key, ensure_ascii=False)}"  # as TOML quotes a key
            if key not in own:
                r.fail(at, "not one of the file's own participant texts (its title, cell labels, object name and "
                       f"[texts], written exactly){did_you_mean(key, own)}")
            _text(r, value, at)
            if key in paragraphs:  # filled in per participant: a name the English lacks has no value
                names, english = _fields(value), _fields(key)
                if names is None or not names <= english:
                    r.fail(at, "braces only around what the English paragraph fills in "
                           f"({', '.join('{' + f + '}' for f in sorted(english)) or 'nothing'}; {{{{ for a brace)")
        out[language] = dict(table)
    return out
