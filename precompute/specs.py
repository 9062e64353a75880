"""What a job stores to be (re)launched: one frozen, typed spec per kind of job, in a versioned
JSON format (``Job.params``), and the reader that upgrades every older stored format.

A job can be retried weeks after it was created, by code that has changed since.  So the stored
form carries ``version``; reading it upgrades older versions step by step (``_UPGRADES``) and
then refuses any key it does not know and any required key that is missing, with a message
naming them, instead of launching a silently different job.

Version history:
  1  (no "version" key) table: preset, out, queue (absent in the oldest rows);
     study: study_id, slug, table, content_hash, seed, approx_star, hyperparameters,
     conditions, open, queue, hand_picked, test_set_thresholds (the last three and
     content_hash absent in the oldest rows).
  2  "version": 2; study: "open" is called "open_when_done" (create_study_job's word).
  3  "version": 3; study: "closed_loop", {condition name: closed-loop settings}, and "closed_loop_fit",
     {condition name: slug of the study whose best model fit gives its model, τ / λ and ε}
     (empty in every older row, which had none).
  4  "version": 4; study: "selectors", {condition name: {"selector", "params"}}: the registered selector
     and every parameter a selected condition runs with (empty in older rows: each condition's name was
     its selector, with approx* as a coverage condition's model), and "test_difficulty", none or a
     difficulty of every test (None in older rows: any environment).
  5  "version": 5; study: "test_kind", "choose" (among options) or "show" (the way); "choose" in older rows.

Changing the format: add the field here, bump SPEC_VERSION, and add an upgrade from the last
version that fills it (a test keeps a row of every older version as a literal:
tests/precompute/test_job_specs.py).
"""
from __future__ import annotations

from dataclasses import MISSING, asdict, dataclass, field, fields

SPEC_VERSION = 5


class BuildRefused(ValueError):
    """What only the build could find out about a study, said on its job page in one line with what to
    change (no traceback: the code did what it should)."""


class SpecFormatError(ValueError):
    """A stored job spec this code cannot read: unknown or missing keys, or a newer version."""


def _v1_to_v2(kind: str, data: dict) -> dict:
    data = dict(data)
    if kind == "table":
        data.setdefault("queue", None)
    else:
        if "open" in data:
            data["open_when_done"] = data.pop("open")
        # the oldest rows were written before these existed; the tasks treated them as absent
        data.setdefault("open_when_done", True)
        data.setdefault("queue", None)
        data.setdefault("content_hash", None)
        data.setdefault("hand_picked", {})
        data.setdefault("test_set_thresholds", {})
    return data


def _v2_to_v3(kind: str, data: dict) -> dict:
    data = dict(data)
    if kind == "study":
        data.setdefault("closed_loop", {})
        data.setdefault("closed_loop_fit", {})
    return data


def _v3_to_v4(kind: str, data: dict) -> dict:
    data = dict(data)
    if kind == "study":
        data.setdefault("selectors", {})
        data.setdefault("test_difficulty", None)
    return data


def _v4_to_v5(kind: str, data: dict) -> dict:
    data = dict(data)
    if kind == "study":
        data.setdefault("test_kind", "choose")
    return data


# version -> function(kind, data) giving version + 1
_UPGRADES = {1: _v1_to_v2, 2: _v2_to_v3, 3: _v3_to_v4, 4: _v4_to_v5}


@dataclass(frozen=True)
class _Spec:
    KIND = ""

    def to_json(self) -> dict:
        return {"version": SPEC_VERSION, **asdict(self)}

    @classmethod
    def from_json(cls, data: dict):
        """The spec stored as `data`, in this or any older version (upgraded)."""
        if not isinstance(data, dict):
            raise SpecFormatError(f"a {cls.KIND} job's spec must be a JSON object, got {type(data).__name__}")
        data = dict(data)
        version = data.pop("version", 1)
        if not isinstance(version, int) or not 1 <= version <= SPEC_VERSION:
            raise SpecFormatError(f"{cls.KIND} job spec version {version!r}: this code reads versions 1 to "
                                  f"{SPEC_VERSION} (was it written by newer code?)")
        while version < SPEC_VERSION:
            data = _UPGRADES[version](cls.KIND, data)
            version += 1
        names = {f.name for f in fields(cls)}
        required = {f.name for f in fields(cls) if f.default is MISSING and f.default_factory is MISSING}
        unknown, missing = sorted(set(data) - names), sorted(required - set(data))
        if unknown or missing:
            raise SpecFormatError(f"{cls.KIND} job spec (version {SPEC_VERSION}): "
                                  + "; ".join(p for p in (unknown and f"unknown key(s) {', '.join(unknown)}",
                                                          missing and f"missing key(s) {', '.join(missing)}") if p))
        return cls(**data)



@dataclass(frozen=True)
class TableJobSpec(_Spec):
    """A trajectory table: `preset` (teaching's Preset fields) built in directory `out`."""
    KIND = "table"
    preset: dict
    out: str
    queue: str | None = None


@dataclass(frozen=True)
class StudyJobSpec(_Spec):
    """A study's conditions and test set selected on `table` (precompute/study.py)."""
    KIND = "study"
    study_id: int
    slug: str
    table: str
    seed: int
    approx_star: str
    conditions: list
    content_hash: str | None = None  # None: a row from before the hash was stored; the table is verified
    hyperparameters: dict = field(default_factory=dict)
    hand_picked: dict = field(default_factory=dict)
    test_set_thresholds: dict = field(default_factory=dict)
    # {name: teaching's ClosedLoopSpec as a dict}: conditions decided per participant, prepared with the test set
    closed_loop: dict = field(default_factory=dict)
    closed_loop_fit: dict = field(default_factory=dict)  # {name: study slug}: that study's best fit sets the model
    # {name: {"selector", "params"}}: a selected condition's selector; absent: its name, with approx*
    selectors: dict = field(default_factory=dict)
    test_difficulty: str | None = None  # None: tests among any environments
    test_kind: str = "choose"  # "show": every test asks the participant to show the way
    open_when_done: bool = True
    queue: str | None = None


SPECS = {TableJobSpec.KIND: TableJobSpec, StudyJobSpec.KIND: StudyJobSpec}


def read_spec(kind: str, data: dict) -> TableJobSpec | StudyJobSpec:
    """The typed spec of a job of `kind` stored as `data` (Job.params), upgraded to this version."""
    try:
        return SPECS[kind].from_json(data)
    except KeyError:
        raise SpecFormatError(f"unknown kind of job {kind!r}") from None
