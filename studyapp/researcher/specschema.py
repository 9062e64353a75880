"""A study spec's fields, declared once (name, rule, required or default, bounds, help), and the
functions that check each entry point's input against them.

Three entry points make a study, and each goes through here:

* a JSON spec (``manage.py create_study``, the demo): ``check_spec``, over ``STUDY_FIELDS`` and
  ``SPEC_FIELDS`` (a condition's own fields: ``CONDITION_FIELDS``);
* the study job, which selects the conditions on the workers (``precompute/study.py``, ``manage.py
  build_study``): ``check_job``, over ``STUDY_FIELDS`` and ``JOB_FIELDS``;
* the designer's form (``precompute/design.py``): its fields are made from these declarations (bounds,
  choices, help), and its cleaned data go through ``job_problems``, the checks of ``check_job``, so
  each problem is said under its own field in the words the other two use.

So a rule (a target is a positive whole number, a condition name is a slug, the test set's
thresholds are 0 or more) is written once, and changing it changes every entry point.  Each route checks
once: its check gives a :class:`CheckedStudy`, frozen, and everything downstream (studies.new_study,
studies.build_study, precompute.study.create_study_job) takes that object and checks none of these rules
again.  The rules of
each kind of value are in studyapp/researcher/specrules.py; a problem is a SpecError, one line naming the field.
What needs the table (its environment ids, its theta*) or the database (a slug taken, a study to fit)
is checked where those are read.
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace
from types import MappingProxyType

from teaching.api import APPROX_STAR, CONDITIONS, DIFFICULTIES, MIN_REGRET, model_names, selector_names

from ..conditions import aliased_pairs
from ..models import Condition, Study
from ..participant import comprehension
from . import specrules as rules
from .specrules import Field, SpecError

__all__ = ["BONUS_FIELDS", "COMPREHENSION_FIELDS", "CONDITION_FIELDS", "DEVICE_FIELDS", "JOB_FIELDS", "OUTCOME_FIELDS",
           "PLAN_FIELDS", "SPEC_FIELDS", "STUDY_FIELDS", "TEXT_FIELDS", "THRESHOLD_FIELDS", "CheckedStudy", "Field",
           "SpecError", "check_condition_names", "check_job", "check_spec", "job_problems"]

# The per-study texts of the consent page (models.Study holds their defaults, lengths and help).
TEXT_FIELDS = ("consent_text", "estimated_minutes", "payment", "payment_amount", "contact", "ethics_reference")
# Who may take part (studyapp/participant/devices.py).
DEVICE_FIELDS = ("min_screen_width", "allow_phones", "allow_tablets")
# How a participant's study may end early, and the code each way of ending gives (studyapp/participant/outcomes.py).
OUTCOME_FIELDS = ("time_limit_minutes", "excluded_code", "screened_out_code", "timed_out_code")
# How long the conditions may differ in their estimated durations (studyapp/researcher/durations.py), and whether a
# test option's path stays drawn after it played.
PLAN_FIELDS = ("duration_tolerance_minutes", "keep_trails")
# A performance bonus (studyapp/participant/bonuses.py): its rates, cap and currency.
BONUS_FIELDS = ("bonus_per_correct", "bonus_per_point", "bonus_cap", "bonus_currency")
MAX_BONUS = 100  # in the study's currency, per participant: more is a typing slip
MAX_PAYMENT = 10_000  # likewise, for taking part
MAX_TIME_LIMIT = 24 * 60  # minutes: a longer limit is a typing slip (Prolific's own maximum is shorter)
# The comprehension check after the instructions (studyapp/participant/comprehension.py).
COMPREHENSION_FIELDS = ("comprehension_check", "comprehension_questions", "comprehension_attempts")
MAX_TARGET = 100_000  # participants per condition: more is a typing slip, not a study


def _column(name: str, kind=rules.string, **kw) -> Field:
    """A field stored in a Study column: its default, length and help are the column's unless given."""
    col = Study._meta.get_field(name)
    kw.setdefault("default", col.default if col.has_default() else None)
    kw.setdefault("help", col.help_text)
    return Field(name, kind, max_length=col.max_length if kind in (rules.string, rules.slug) else None, **kw)


# --- rules of fields made of other fields ------------------------------------------------------------
def target(f, v, found, where):
    """A condition's own target: the study's target_per_condition rule."""
    return rules.whole(replace(STUDY_FIELDS["target_per_condition"], says=f.label), v, found, where)


def spec_conditions(f, v, found, where):
    """A spec's conditions: each an object with a name and env_ids, or closed-loop settings instead."""
    if not isinstance(v, list):
        found.append(SpecError(f.missing, where))
        return v
    for i, c in enumerate(v):
        if not isinstance(c, dict):
            found.append(SpecError(f"condition {i} must be an object with 'name' and 'env_ids'", where))
            return v
        label = c.get("name", i)
        says = {"closed_loop": f"closed-loop condition {label!r}", "env_ids": f"condition {label!r}: 'env_ids'",
                "target": f"condition {label!r}: 'target'", "selector": f"condition {label!r}"}
        for key in (k for k in says if k in c):
            found += replace(CONDITION_FIELDS[key], says=says[key]).problems(c[key], where)[1]
        if not found and ("params" in c or "selector" in c):
            _selected_by(c, label, found, where)
        if found:
            return v
    check_condition_names([(c.get("name"), where) for c in v], found)
    for c in v if not found else ():
        if "closed_loop" in c and c.get("env_ids"):
            found.append(SpecError(f"condition {c['name']!r}: a closed-loop condition chooses its own examples; "
                                   f"drop its 'env_ids'", where))
        elif not c.get("env_ids") and "closed_loop" not in c:
            found.append(SpecError(f"condition {c['name']!r} needs a non-empty 'env_ids' list", where))
    return v


def _selected_by(c: dict, label, found, where) -> None:
    """A spec condition's record of what selected it: params only with a selector, the selector's own
    checks on them, and no selector for a closed loop (it chooses per participant)."""
    if "closed_loop" in c:
        found.append(SpecError(f"closed-loop condition {label!r} chooses its own examples: drop its 'selector' "
                               "and 'params'", where))
    elif "selector" not in c:
        found.append(SpecError(f"condition {label!r}: 'params' needs the 'selector' they are for", where))
    else:
        rules.selector_params(f"condition {label!r}", c["selector"], c.get("params", {}), found, where)


def _per_condition(key: str, who: str, part: str):
    """The rule of {condition name: its `key` (a condition field)}: a hand-picked condition's environment
    ids, which must be some, or a closed-loop condition's settings; `part`: the path of a value's problem."""
    def rule(f, v, found, where):
        if not rules.mapping(f, v, found, where):
            return v
        out = {}
        for name, value in v.items():
            rules.condition_name(CONDITION_FIELDS["name"], name, found, f"{where}.name")
            if key == "env_ids" and not value:
                found.append(SpecError(f"{who} condition {name!r}: no environment ids given", f"{where}.{part}"))
                continue
            says = f"{who} condition {name!r}" + (": 'env_ids'" if key == "env_ids" else "")
            out[name], problems = replace(CONDITION_FIELDS[key], says=says).problems(value, f"{where}.{part}")
            found += problems
        return out
    return rule


def fits(f, v, found, where):
    """{closed-loop condition: the slug of the study whose best learner-model fit sets its model}."""
    if not rules.mapping(f, v, found, where):
        return v
    for name, slug in v.items():
        says = f"the study that the fit for {name!r} is taken from"
        rules.slug(replace(STUDY_FIELDS["slug"], says=says), slug, found, where)
    return dict(v)


# --- the fields ------------------------------------------------------------------------------------
# What every study stores (studies.new_study): a JSON spec and the study job both take these.
STUDY_FIELDS: dict[str, Field] = {f.name: f for f in (
    _column("slug", rules.slug, required=True, missing="a study needs a 'slug'",
            help="The study's URL: /s/SLUG/ (letters, digits, - and _)."),
    _column("name", help="Title for researchers (default: the slug)."),
    _column("target_per_condition", rules.whole, minimum=1, maximum=MAX_TARGET,
            help="Participants wanted per condition; new arrivals go to the condition furthest from it."),
    _column("recruitment", rules.choice, choices=tuple(Study.RECRUITMENTS),
            help="How participants arrive: a plain link, Prolific or MTurk."),
    _column("completion_code", default="", help="Prolific's completion code (required for Prolific)."),
    _column("consent_text"),
    _column("estimated_minutes", rules.whole, minimum=1),
    _column("duration_tolerance_minutes", rules.whole, minimum=0, maximum=MAX_TIME_LIMIT),
    _column("keep_trails", rules.boolean, says="keep_trails"),
    _column("min_screen_width", rules.whole, minimum=0, maximum=10000,
            help="Smallest screen width (CSS pixels) a participant may take part on; 0: any (a laptop: 1024)."),
    _column("allow_phones", rules.boolean, help="Phones may take part."),
    _column("allow_tablets", rules.boolean, help="Tablets may take part."),
    _column("language", rules.choice, choices=tuple(Study.LANGUAGES)),
    _column("time_limit_minutes", rules.whole, minimum=0, maximum=MAX_TIME_LIMIT),
    _column("excluded_code"),
    _column("bonus_per_correct", rules.number, minimum=0, maximum=MAX_BONUS),
    _column("bonus_per_point", rules.number, minimum=0, maximum=MAX_BONUS),
    _column("bonus_cap", rules.number, minimum=0, maximum=MAX_BONUS),
    _column("bonus_currency", rules.choice, choices=tuple(Study.CURRENCIES)),
    _column("screened_out_code"),
    _column("timed_out_code"),
    _column("payment"),
    _column("payment_amount", rules.number, minimum=0, maximum=MAX_PAYMENT),
    _column("contact"),
    _column("ethics_reference"),
    _column("comprehension_check", rules.boolean, says="the comprehension check",
            help="Ask multiple-choice questions about the instructions before the examples; whoever fails them "
                 "too often is screened out (the study's screened-out code)."),
    _column("comprehension_questions", rules.questions, default=[], says="the comprehension questions",
            help="One question per block, blocks separated by a blank line: the question on its first line, then "
                 "one line per choice, '* ' before a right one and '- ' before a wrong one; empty: the robot's "
                 "own questions."),
    _column("comprehension_attempts", rules.whole, minimum=1, maximum=comprehension.MAX_ATTEMPTS,
            says="the comprehension check's attempts",
            help="Failed attempts after which a participant is screened out."),
)}

# One condition of a JSON spec.
CONDITION_FIELDS: dict[str, Field] = {f.name: f for f in (
    Field("name", rules.condition_name, "The condition's name: letters, digits, - and _ (or a selector's own "
          "name, such as coverage-approx*); two names of one condition are refused.", required=True,
          max_length=Condition._meta.get_field("name").max_length),
    Field("env_ids", rules.ids, "Environment ids of the table, in the order they are shown."),
    Field("closed_loop", rules.loop, "A closed-loop condition's settings, instead of env_ids ({}: every default)."),
    Field("target", target, "This condition's own target of participants (default: target_per_condition)."),
    Field("selector", rules.selector, "The registered selector that chose env_ids (teaching's selector_names), "
          "recorded with the study."),
    Field("params", rules.obj, "That selector's parameters, each checked by its declaration (default: its "
          "defaults)."),
)}

# A JSON spec's own fields (create_study): the table, and what was selected on it.
SPEC_FIELDS: dict[str, Field] = {f.name: f for f in (
    Field("conditions", spec_conditions, "The conditions, in the order given, each an object of the condition "
          "fields.", required=True, missing="spec needs a non-empty 'conditions' list"),
    Field("table", rules.string, "The trajectory table the environment ids and θ indices refer to.",
          required=True, missing="a spec needs a 'table': the trajectory table its trajectories come from "
                                 "(build one with `python -m teaching build --preset demo`)"),
    Field("test_set", rules.tests, "The shared test set, as select_test_set gives it, or 'show the way' tests as "
          "select_show_tests gives them ({'env_id': int, 'kind': 'show'}: grid worlds from a file); extra keys are "
          "ignored.",
          required=True, missing="a spec with a 'table' needs its 'test_set'"),
    Field("theta_star", rules.numbers, "θ*, one weight per feature of the table's domain: a table built for "
          "another θ* is refused."),
    Field("table_hash", rules.string, "The table's content hash (a teach output records it): another table is "
          "refused."),
    Field("is_open", rules.boolean, "Open the study once it is built (false: open it on the dashboard).",
          default=True),
    Field("pilot", rules.obj, "The simulated pilot of a teach output (its matrix.json), set by create_study."),
)}

# The test set's thresholds (select_test_set's keywords).
THRESHOLD_FIELDS: dict[str, Field] = {f.name: f for f in (
    Field("min_regret", rules.number, "Each wrong option is at least this much worse for θ* (reward units).",
          default=MIN_REGRET, minimum=0, says="test-set threshold 'min_regret'"),
    Field("min_distance", rules.number, "The four options are at least this far apart (scaled state units); "
          "empty: the table's domain's default.", minimum=0, says="test-set threshold 'min_distance'"),
)}

# The study job's own fields (precompute/study.py): what the workers select, and how.
JOB_FIELDS: dict[str, Field] = {f.name: f for f in (
    Field("conditions", rules.selected, "The paper's nine conditions (ticked), the hierarchical learner's "
          "(strategy first, then the trajectory within it) and the field's example-based teachers (SCOT, BEC "
          "scaffolding, HIGHLIGHTS): each selects its own training examples for θ*.",
          choices=lambda: [(c, c) for c in selector_names()]),
    Field("hand_picked", _per_condition("env_ids", "hand-picked", "env_ids"), "{condition name: environment ids "
          "of the table}, each shown in the order given, after the selected conditions.", default={}),
    Field("closed_loop", _per_condition("closed_loop", "closed-loop", "settings"), "{condition name: closed-loop "
          "settings}: conditions that pick each participant's next example from their answers.", default={}),
    Field("closed_loop_fit", fits, "{closed-loop condition: a study whose participants' best-fitting learner "
          "model sets its model, τ / λ and ε}.", default={}),
    Field("approx_star", rules.choice, "The learner model whose examples coverage-approx* starts from.",
          default=APPROX_STAR, choices=lambda: [(m, m) for m in model_names()]),
    Field("hyperparameters", rules.hyperparameters, "{learner model: τ or λ} used instead of the paper's rule "
          "(the largest τ or smallest λ that still teaches θ*).", default={}),
    Field("seed", rules.whole, "Seeds the random conditions and the test set.", default=0, minimum=0),
    Field("test_difficulty", rules.choice, "Draw every test among environments of this difficulty (a tertile "
          "of BEC size: low is a large BEC, easy); none: any environment.", default="none",
          choices=(("none", "none: any environment"), *((d, d) for d in DIFFICULTIES))),
    Field("test_kind", rules.choice, "What every test asks: to choose the robot's trajectory among four, or to "
          "show the way it would go (grid worlds from a file).", default="choose",
          choices=tuple(Study.TEST_KINDS)),
    Field("test_set_thresholds", rules.parts, "The test set's thresholds: min_regret and min_distance.",
          default={}, parts=tuple(THRESHOLD_FIELDS.values())),
    SPEC_FIELDS["is_open"],
    Field("replace", rules.boolean, "Rebuild a study of this slug that has no participants yet (else an existing "
          "slug is refused).", default=False),
)}


# --- the checked study -----------------------------------------------------------------------------
@dataclass(frozen=True)
class CheckedStudy:
    """A study's design as its route's check left it (check_spec: a JSON spec; check_job or job_problems: a
    study job, from the command line or the designer): every declared field as stored, defaults filled in,
    read-only.  Only those checks make one, so a function that takes one need not check again."""

    values: Mapping[str, object]

    def __post_init__(self):
        object.__setattr__(self, "values", MappingProxyType(dict(self.values)))

    def __getitem__(self, key: str):
        return self.values[key]

    def __contains__(self, key: str) -> bool:
        return key in self.values

    def get(self, key: str, default=None):
        return self.values.get(key, default)

    @property
    def condition_names(self) -> list[str]:
        """Every condition's name, in the study's order: a JSON spec's as listed; a job's selected ones, then
        the hand-picked, then the closed-loop ones."""
        named = [c["name"] for c in self.values["conditions"]]
        if "table" in self.values:  # a JSON spec
            return named
        return named + list(self.values["hand_picked"]) + list(self.values["closed_loop"])

    @property
    def study_fields(self) -> dict:
        """The Study's own columns this design sets (all but the slug and the title)."""
        return {k: self.values[k] for k in STUDY_FIELDS if k not in ("slug", "name") and k in self.values}


# --- checking --------------------------------------------------------------------------------------
def _empty(v) -> bool:
    return v is None or (isinstance(v, str | list | dict) and not v)


def _problems(data: dict, fields: dict[str, Field]) -> tuple[dict, list[SpecError]]:
    """(the declared fields as stored, defaults filled in; every problem: those of the values given,
    then those of required fields left out).  None is a value left out."""
    out, found, missing = {}, [], []
    for name, f in fields.items():
        v = data.get(name)
        if _empty(v) and (f.required or v is None):
            if f.required:
                missing.append(SpecError(f.missing or f"a study needs {f.label}", name))
            elif f.default is not None:
                out[name] = f.default
            continue
        out[name], problems = f.problems(v)
        found += problems
    return out, found + missing


def _raise_first(found: list[SpecError]) -> None:
    if found:
        raise found[0]


def check_condition_names(named: list[tuple[object, str]], found: list[SpecError]) -> None:
    """(name, where) of every condition of a study: each a condition name, none twice, and no two names
    of one condition (the analysis would pool them: studyapp/conditions.py).  Problems go to `found`,
    each blamed on the later of two names."""
    for name, where in named:
        rules.condition_name(CONDITION_FIELDS["name"], name, found, where)
    if found:
        return
    names = [n for n, _ in named]
    twice = next((i for i, n in enumerate(names) if n in names[:i]), None)
    if twice is not None:
        found.append(SpecError(f"every condition needs a unique, non-empty 'name'; a condition is listed twice: "
                               f"{names[twice]!r}", named[twice][1]))
        return
    pairs = aliased_pairs(names)
    if pairs:
        found.append(SpecError("; ".join(f"conditions {a!r} and {b!r} are one condition ({c})" for a, b, c in pairs)
                               + ": a study may name each condition once; keep one of the names",
                               dict(named)[pairs[0][1]]))


def _study_rules(values: dict, found: list[SpecError]) -> None:
    """The rules across a study's own fields, once each field is right by itself."""
    if found:
        return
    limit, minutes = values.get("time_limit_minutes") or 0, values.get("estimated_minutes")
    if limit and minutes and limit < minutes:
        found.append(SpecError(f"a time limit of {limit} minutes is shorter than the {minutes} minutes the study "
                               "takes: participants would time out before they could finish", "time_limit_minutes"))
    if (values.get("bonus_cap") or 0) > 0 and not ((values.get("bonus_per_correct") or 0) > 0
                                                   or (values.get("bonus_per_point") or 0) > 0):
        found.append(SpecError("a bonus cap needs a bonus to cap: set an amount per correct test or per "
                               "confidence point", "bonus_cap"))
    if values.get("test_kind") == Study.SHOW and (values.get("bonus_per_point") or 0) > 0:
        found.append(SpecError("tests that show the way have no confidence score: pay a bonus per correct test "
                               "instead", "bonus_per_point"))


def check_spec(spec) -> CheckedStudy:
    """A JSON spec, checked (its first problem raised): the spec with its declared fields as stored and their
    defaults filled in."""
    if not isinstance(spec, dict):
        raise SpecError(f"a study spec is a JSON object, not a {type(spec).__name__} "
                        "(for the output of `python -m teaching teach`, give its directory)")
    out, found = _problems(spec, {**STUDY_FIELDS, **SPEC_FIELDS})
    _study_rules(out, found)
    _raise_first(found)
    return CheckedStudy({**{k: v for k, v in spec.items() if v is not None}, **out})


def job_problems(args: dict) -> tuple[CheckedStudy | None, list[SpecError]]:
    """(the study job's arguments as stored, defaults filled in, or None when there are problems; every
    problem with them): each field's own, then, if there are none, the first of the rules across fields (the
    conditions' names; a fit is for a closed-loop condition)."""
    out, found = _problems(args, {**STUDY_FIELDS, **JOB_FIELDS})
    _study_rules(out, found)
    if found:
        return None, found
    if not out.get("conditions"):  # by default the paper's, unless the study has conditions of its own
        out["conditions"] = [] if out["hand_picked"] or out["closed_loop"] else \
            [{"name": c, "selector": c, "params": {}} for c in CONDITIONS]
    check_condition_names([(c["name"], "conditions") for c in out["conditions"]]
                          + [(n, "hand_picked.name") for n in out["hand_picked"]]
                          + [(n, "closed_loop.name") for n in out["closed_loop"]], found)
    stray = [name for name in out["closed_loop_fit"] if name not in out["closed_loop"]]
    if stray and not found:
        found.append(SpecError(f"a fit is asked for {stray[0]!r}, which is not a closed-loop condition of this "
                               "study", "closed_loop_fit"))
    return (None if found else CheckedStudy(out)), found


def check_job(args: dict) -> CheckedStudy:
    """The study job's arguments, checked (the first problem raised), as stored, defaults filled in."""
    checked, found = job_problems(args)
    _raise_first(found)
    return checked
