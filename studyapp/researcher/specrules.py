"""The rules of each kind of value a study spec holds (a whole number within bounds, a slug, a condition
name, closed-loop settings, ...), and the Field that declares one; studyapp/researcher/specschema.py declares the
spec's fields with them.

A rule is a function (field, value, found, where) -> the value as stored: it appends a SpecError (one
line naming the field by ``field.label``; ``where``: the field's path, for a form) to ``found`` for
each problem, so a form can show all of them at once and everything else raises the first.
"""
from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from numbers import Integral

from django.core.validators import slug_re

from teaching.api import (
    DIFFICULTIES,
    ClosedLoopError,
    ClosedLoopSpec,
    check_params,
    is_show,
    make_model,
    parse_selector,
    selector_names,
)

from ..participant import comprehension

LOOP_EXAMPLE = '{"model": "det-euclidean", "check_every": 2}'
# The selectors' own names that are not slugs ("coverage-approx*"): a condition may carry them.
SELECTOR_SPELLINGS = tuple(c for c in selector_names() if not slug_re.match(c))


class SpecError(ValueError):
    """A study spec's problem in one line naming the field; ``field`` says where ("slug",
    "test_set_thresholds.min_regret", "hand_picked.name"), so a form can say it under its own field."""

    def __init__(self, message: str, field: str = ""):
        super().__init__(message)
        self.field = field


@dataclass(frozen=True)
class Field:
    """One field of a spec.  kind: the rule its value follows (a function of this module's, or of
    specschema's for fields made of other fields); choices: (value, label) pairs, or a function giving
    them; missing: the message when a required field is absent or empty; says: how messages name it
    (default: 'name'); parts: the fields of an object made of named fields."""

    name: str
    kind: Callable
    help: str
    required: bool = False
    default: object = None
    minimum: float | None = None
    maximum: float | None = None
    max_length: int | None = None
    choices: tuple | Callable[[], list] = ()
    missing: str = ""
    says: str = ""
    parts: tuple[Field, ...] = ()

    @property
    def label(self) -> str:
        return self.says or f"'{self.name}'"

    @property
    def choice_pairs(self) -> list:
        return list(self.choices() if callable(self.choices) else self.choices)

    def values(self) -> list:
        return [v for v, _ in self.choice_pairs]

    def problems(self, value, where: str = "") -> tuple[object, list[SpecError]]:
        """(the value as the study stores it, every problem with it); `where`: the field's path."""
        found: list[SpecError] = []
        out = self.kind(self, value, found, where or self.name)
        return out, found


def _is_int(v) -> bool:
    return isinstance(v, Integral) and not isinstance(v, bool)


def _is_number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _num(x) -> str:
    return f"{x:,}" if isinstance(x, int) else f"{x:g}"


def _range_words(f: Field, noun: str) -> str:
    """e.g. "a positive whole number up to 100,000", "a number, 0 or more", "a whole number from 5 to 9"."""
    lo, hi = f.minimum, f.maximum
    if noun == "whole number" and lo == 1:
        return "a positive whole number" + (f" up to {_num(hi)}" if hi is not None else "")
    if lo is not None and hi is not None:
        return f"a {noun} from {_num(lo)} to {_num(hi)}"
    if lo is not None:
        return f"a {noun}, {_num(lo)} or more"
    return f"a {noun}" + (f", at most {_num(hi)}" if hi is not None else "")


def _within(f: Field, v) -> bool:
    return (f.minimum is None or v >= f.minimum) and (f.maximum is None or v <= f.maximum)


def whole(f, v, found, where):
    if not (_is_int(v) and _within(f, v)):
        found.append(SpecError(f"{f.label} must be {_range_words(f, 'whole number')}, not {v!r}", where))
    return int(v) if _is_int(v) else v


def number(f, v, found, where):
    if not (_is_number(v) and _within(f, v)):
        found.append(SpecError(f"{f.label} must be {_range_words(f, 'number')}, not {v!r}", where))
        return v
    return float(v)


def string(f, v, found, where):
    if not isinstance(v, str):
        found.append(SpecError(f"{f.label} must be a string, not {v!r}", where))
    elif f.max_length is not None and len(v) > f.max_length:
        found.append(SpecError(f"{f.label} must be at most {f.max_length} characters long, not {len(v)}", where))
    return v


def slug(f, v, found, where):
    if not (isinstance(v, str) and slug_re.match(v)):
        found.append(SpecError(f"{f.label} may hold only letters, digits, - and _, not {v!r}", where))
        return v
    return string(f, v, found, where)


def condition_name(f, v, found, where):
    if not isinstance(v, str) or not v:
        found.append(SpecError("every condition needs a unique, non-empty 'name'", where))
    elif v not in SELECTOR_SPELLINGS and not slug_re.match(v):
        found.append(SpecError(f"condition name {v!r} may hold only letters, digits, - and _ (or be "
                               f"{' or '.join(SELECTOR_SPELLINGS)})", where))
    else:
        string(f, v, found, where)
    return v


def choice(f, v, found, where):
    if v not in f.values():
        found.append(SpecError(f"{f.label} must be one of {', '.join(map(str, f.values()))}, not {v!r}", where))
    return v


def boolean(f, v, found, where):
    if not isinstance(v, bool):
        found.append(SpecError(f"{f.label} must be true or false, not {v!r}", where))
    return v


def questions(f, v, found, where):
    """The comprehension check's questions: stored ones ([{question, choices, right}]) or the designer's text
    (studyapp/participant/comprehension.py's format); empty: the domain's own."""
    try:
        return comprehension.parse_text(v) if isinstance(v, str) else comprehension.check(v)
    except comprehension.QuestionsError as exc:
        found.append(SpecError(f"{f.label}: {exc}", where))
        return v


def obj(f, v, found, where):
    if not isinstance(v, dict):
        found.append(SpecError(f"{f.label} must be an object, not {v!r}", where))
    return v


def numbers(f, v, found, where):
    if not (isinstance(v, list) and v and all(_is_number(x) for x in v)):
        found.append(SpecError(f"{f.label} must be a list of numbers, one per feature, not {v!r}", where))
    return v


def ids(f, v, found, where):
    if not (isinstance(v, list) and all(_is_int(e) for e in v)):
        found.append(SpecError(f"{f.label} must be a list of environment ids", where))
        return v
    return [int(e) for e in v]


def tests(f, v, found, where):
    if not isinstance(v, list):
        found.append(SpecError(f"{f.label} must be a list of tests", where))
        return v
    show = [isinstance(t, dict) and is_show(t) for t in v]
    if any(show) and not all(show):
        found.append(SpecError(f"{f.label} mixes 'show' tests with tests that have options; a study's tests are "
                               "one kind", where))
        return v
    for j, t in enumerate(v):
        if show[j]:
            if not _is_int(t.get("env_id")) or "options" in t:
                found.append(SpecError(f"test {j} must be an object with an 'env_id' and \"kind\": \"show\", "
                                       "and no 'options'", where))
                break
            continue
        if not (isinstance(t, dict) and _is_int(t.get("env_id")) and isinstance(t.get("options"), list)
                and all(isinstance(o, dict) and _is_int(o.get("theta_index"))
                        and isinstance(o.get("is_theta_star"), bool) for o in t["options"])):
            found.append(SpecError(f"test {j} must be an object with an 'env_id' and 'options' "
                                   "[{'theta_index': int, 'is_theta_star': bool}, ...]", where))
            break
        if "difficulty" in t and t["difficulty"] not in DIFFICULTIES:
            found.append(SpecError(f"test {j}: 'difficulty' must be one of {', '.join(DIFFICULTIES)}, "
                                   f"not {t['difficulty']!r}", where))
            break
    return v


def loop(f, v, found, where):
    """A condition's closed-loop settings as teaching's ClosedLoopSpec reads them (its defaults filled)."""
    who = f.says or "a closed-loop condition"
    if not isinstance(v, dict):
        found.append(SpecError(f"{who}: 'closed_loop' must be an object of settings, e.g. {LOOP_EXAMPLE}", where))
        return v
    try:
        return ClosedLoopSpec.from_dict(v).as_dict()
    except (ClosedLoopError, TypeError) as exc:
        found.append(SpecError(f"{who}: {exc}", where))
        return v


def selector(f, v, found, where):
    """A registered selector's name (teaching's selector_names)."""
    if v not in selector_names():
        found.append(SpecError(f"{f.label}: unknown selector {v!r}; choose from {', '.join(selector_names())}",
                               where))
    return v


def selector_params(who: str, name: str, params, found, where) -> dict:
    """`params` of selector `name`, as given, each checked by the selector's own declaration (teaching's
    check_params, whose message names the selector and the parameter); `who`: how messages name the
    condition."""
    if not isinstance(params, dict):
        found.append(SpecError(f"{who}: 'params' must be an object of the selector's parameters, not {params!r}",
                               where))
        return params
    try:
        checked = check_params(name, params)
    except ValueError as exc:
        key = next((k for k in params if f"parameter {k!r}" in str(exc)), "")
        found.append(SpecError(f"{who}: {exc}", f"{where}.{name}.{key}" if key else where))
        return params
    return {k: checked[k] for k in params}  # only those given: a coverage condition's model is approx*'s


def condition_label(name: str, params: dict) -> str:
    """A selected condition's default name: the selector's, then each parameter given, as a slug
    ("bec-scaffold:k=2" -> "bec-scaffold-k2")."""
    if not params:
        return name
    return "-".join([name.replace("*", ""), *(f"{k}{v}" for k, v in params.items())]).replace(".", "_")


def _selection(text: str) -> dict:
    """ "NAME" or "NAME:KEY=VALUE,..." (teaching's --selector form, read by its parse_selector) ->
    {"selector", "params": the parameters given}; ValueError (one line) if malformed or refused."""
    if ":" not in text:
        return {"selector": text.strip(), "params": {}}
    try:
        label, name, params = parse_selector(text)
    except ValueError as exc:
        raise ValueError(f"condition {text!r}: {exc}") from None
    given = [item.partition("=")[0] for item in label.partition(":")[2].split(",")]
    return {"selector": name, "params": {k: params[k] for k in given}}


def selected(f, v, found, where):
    """Conditions a selector chooses the examples of: each a selector's name, "NAME:KEY=VALUE,..." or an
    object {"selector", "params", "name"}; stored as such objects, the parameters as given (checked), the
    name by default the selector's and its parameters' (condition_label)."""
    if not (isinstance(v, list | tuple) and all(isinstance(c, str | dict) for c in v)):
        found.append(SpecError(f"{f.label} must be a list of condition names, not {v!r}", where))
        return v
    out = []
    for c in v:
        try:
            c = _selection(c) if isinstance(c, str) else {"params": {}, **c}
        except ValueError as exc:
            found.append(SpecError(str(exc), where))
            continue
        unknown = sorted(set(c) - {"selector", "params", "name"})
        if unknown or "selector" not in c:
            found.append(SpecError(f"a selected condition is an object of 'selector', 'params' and 'name', not "
                                   f"{c!r}", where))
            continue
        label = c.get("name") or c["selector"]
        if c["selector"] not in selector_names():
            found.append(SpecError(f"condition {label!r}: unknown selector {c['selector']!r}; choose from "
                                   f"{', '.join(selector_names())}", where))
            continue
        params = selector_params(f"condition {label!r}", c["selector"], c["params"], found, where)
        out.append({"name": c.get("name") or condition_label(c["selector"], params), "selector": c["selector"],
                    "params": params})
    return out

def mapping(f, v, found, where) -> bool:
    if not isinstance(v, dict):
        found.append(SpecError(f"{f.label} must be an object, not {v!r}", where))
        return False
    return True


def hyperparameter_symbol(model: str) -> str:
    """τ for a deterministic learner model, λ for a probabilistic one."""
    return "τ" if make_model(model).param == "tau" else "λ"


def hyperparameters(f, v, found, where):
    """{learner model: its τ or λ}, each a number above 0."""
    if not mapping(f, v, found, where):
        return v
    out = {}
    for model, value in v.items():
        try:
            symbol = hyperparameter_symbol(model)
        except ValueError as exc:
            found.append(SpecError(str(exc), f"{where}.{model}"))
            continue
        if not (_is_number(value) and value > 0):
            found.append(SpecError(f"{symbol} of {model} must be a number greater than 0 (e.g. 0.5), not {value!r}",
                                   f"{where}.{model}"))
            continue
        out[str(model)] = float(value)
    return out


def parts(f, v, found, where):
    """An object of the named `parts` only, each checked by its own field."""
    if not mapping(f, v, found, where):
        return v
    named = {p.name: p for p in f.parts}
    unknown = [k for k in v if k not in named]
    if unknown:
        found.append(SpecError(f"{f.label} takes {' and '.join(named)}, not {unknown[0]!r}", where))
        return v
    out = {}
    for key, value in v.items():
        out[key], problems = named[key].problems(value, f"{where}.{key}")
        found += problems
    return out
