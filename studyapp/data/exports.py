"""CSV exports of a study: long (one row per answer), wide (one row per participant), and the data dictionary.

Staff previews are never exported.  Every participant row carries ``status`` (studyapp.status:
complete / incomplete / excluded / declined / returned / timed_out / screened_out); keeping
``status == complete`` gives exactly the participants the app analyses.  ``excluded = 1`` still marks a
failed attention check.  The columns and their descriptions are in :mod:`studyapp.data.exportcolumns`.

Both files are generated row by row (``long_stream`` / ``wide_stream``, sent by the dashboard as a
StreamingHttpResponse): participants are read a page at a time with only the columns written, their
answers one query per page, and the study's test set and conditions are decoded once per export.
Before, ``select_related("study", "condition")`` decoded the study's test set (about 30 KB of JSON)
and the condition's training once per participant: 20 s and 3.6 GB for 10,000 participants.

A show study (``Study.test_kind == "show"``: each test asks the participant to move the robot) has its own
test cells (:mod:`studyapp.data.exports_show`: the moves, their regret under theta* and whether they are optimal)
instead of a choice's; a choice study's files are exactly as they were.

A study with closed-loop conditions has check answers too.  The long file's CHECK rows carry the same
cells as a test's, theta*'s option read from the participant's LoopStep (one query more per page, for the
page's check steps); the wide file gets per-check columns (``n_checks_*``, ``check<k>_*``).  A study
without closed-loop conditions has exactly the columns and queries it had before.
"""
from __future__ import annotations

import csv
import io
import json

from ..guards.csvsafe import FORMULA_STARTS, neutralise  # noqa: F401  (the guard; exports.neutralise stays importable)
from ..models import Answer, LoopStep, Participant, StepKind, Study
from ..participant import closedloop, outcomes
from ..status import COMPLETE, EXCLUDED, participant_status
from ..trajectories import study_domain
from . import exports_comprehension as quiz
from .exportcolumns import (
    CHECK_SUMMARY_COLUMNS,
    LONG_COLUMNS,
    N_TESTS_WIDE,
    PARTICIPANT_COLUMNS,
    WIDE_COLUMNS,
    check_columns,
)
from .exports_show import show_long_columns, show_test_columns, show_test_fields, show_wide_columns, show_wide_fields
from .privacy import pseudonym

# Only the columns the files need: never the training / test-set JSON, decoded once per export instead.
_PARTICIPANT_VALUES = ("pk", "condition_id", "platform", "platform_pid", "platform_study_id", "platform_session_id",
                       "platform_session_ids", "started_at", "completed_at", "excluded", "position", "outcome",
                       "ended_at", "completion_code", "bonus")
_ANSWER_VALUES = ("participant_id", "step", "kind", "item", "data", "correct", "confidence_score", "regret",
                  "created_at")
PAGE = 500  # participants per query (their answers: one query more per page)


def _star(question: dict) -> int:
    """The canonical index of theta*'s option of a test or check question."""
    return next(k for k, o in enumerate(question["options"]) if o["is_theta_star"])


class _Context:
    """What every row of one export shares, decoded once: the study's slug, each test's theta* option,
    each condition's name and number of training environments, and for closed-loop conditions their
    check questions' theta* options ({condition pk: [option per question]}) and the most checks any asks."""

    def __init__(self, study: Study, pseudonymise: bool = False):
        self.slug = study.slug
        self.pseudonymise = pseudonymise  # platform ids replaced by privacy.pseudonym, for sharing
        self.show = study.test_kind == Study.SHOW
        self.comprehension = study.comprehension_check  # its attempts' rows and columns (exports_comprehension)
        # a show test has no options, so no theta* option: its answer is a way, scored by its regret
        self.stars = [None if self.show else _star(t) for t in study.test_set]
        self.difficulties = [neutralise(str(t.get("difficulty") or "")) for t in study.test_set]  # a spec's text
        self.conditions, self.check_stars, self.n_checks = {}, {}, 0
        for pk, name, training, loop in study.conditions.values_list("pk", "name", "training", "closed_loop"):
            self.conditions[pk] = (name, len(training))
            if loop:
                # a show study's checks ask to show the way too: no options, no theta* option
                self.check_stars[pk] = [None if self.show else _star(q) for q in loop["checks"]]
                self.n_checks = max(self.n_checks, closedloop.max_checks(loop))


def _participant_fields(p: dict, ctx: _Context) -> dict:
    def ids(value: str) -> str:
        return pseudonym(ctx.slug, value) if ctx.pseudonymise else value

    return {
        "participant_id": p["pk"], "study": ctx.slug, "condition": ctx.conditions[p["condition_id"]][0],
        "platform": p["platform"], "platform_pid": ids(p["platform_pid"]), "platform_study_id": p["platform_study_id"],
        "platform_session_id": ids(p["platform_session_id"]),
        "platform_session_ids": ";".join(ids(v) for v in p["platform_session_ids"]),
        "started_at": p["started_at"].isoformat(),
        "completed_at": p["completed_at"].isoformat() if p["completed_at"] else "", "excluded": int(p["excluded"]),
        "status": participant_status(position=p["position"], excluded=p["excluded"],
                                     completed=p["completed_at"] is not None, outcome=p["outcome"]),
        "ended_at": p["ended_at"].isoformat() if p["ended_at"] else "",
        "completion_code": "" if ctx.pseudonymise else p["completion_code"],
        "bonus": "" if p["bonus"] is None else f"{p['bonus']:.2f}",
    }


def _pages(study: Study, kinds=None):
    """(participant rows, {participant id: answers in step order}) a page at a time, by keyset on pk,
    so memory holds one page whatever the study's size.  Participants whose time ran out are marked
    timed out first (outcomes.expire), so the file says so even of those who never came back."""
    outcomes.expire(study)
    people = (Participant.objects.filter(study=study).exclude(platform=Participant.PREVIEW)
              .order_by("pk").values(*_PARTICIPANT_VALUES))
    last = 0
    while True:
        page = list(people.filter(pk__gt=last)[:PAGE])
        if not page:
            return
        answers = {p["pk"]: [] for p in page}
        rows = Answer.objects.filter(participant_id__in=list(answers)).order_by("participant_id", "step")
        if kinds is not None:
            rows = rows.filter(kind__in=kinds)
        for a in rows.values(*_ANSWER_VALUES):
            answers[a["participant_id"]].append(a)
        yield page, answers
        last = page[-1]["pk"]


def _check_questions(page: list[dict]) -> dict[tuple[int, int], int]:
    """{(participant id, loop index): check question} of the page's participants: one query."""
    steps = LoopStep.objects.filter(participant_id__in=[p["pk"] for p in page], kind=LoopStep.CHECK)
    return {(pid, index): question for pid, index, question in steps.values_list("participant_id", "index", "question")}


def _test_fields(answer: dict, star: int, difficulty: str = "") -> dict:
    """The long file's test cells of a test or check answer whose question has theta*'s option `star`
    (and, a graded test, its `difficulty`)."""
    data = answer["data"]
    choice = data["choice"]
    fields = {
        "chosen_option": choice, "chosen_display_position": data["order"].index(choice),
        "chosen_is_theta_star": int(choice == star), "chosen_rating": data["ratings"][choice],
        "confidence_score": answer["confidence_score"], "theta_star_option": star, "test_difficulty": difficulty,
        "display_order": " ".join(str(k) for k in data["order"]),
    }
    fields.update({f"rating_{k}": r for k, r in enumerate(data["ratings"])})
    return fields


TEST = StepKind.TEST.value  # a plain str compares faster than the enum member, once per answer
CHECK = StepKind.CHECK.value


def _safe(values) -> list:
    return [neutralise(v) if v.__class__ is str else v for v in values]


def long_columns(ctx: _Context) -> list[tuple[str, str]]:
    """LONG_COLUMNS; a show study's (exports_show.show_long_columns) for a show study; the comprehension
    check's column last in a study that asks it."""
    columns = show_long_columns(LONG_COLUMNS) if ctx.show else LONG_COLUMNS
    return columns + quiz.COMPREHENSION_LONG_COLUMNS if ctx.comprehension else columns


def long_rows(study: Study, ctx: _Context | None = None):
    """Lists in long_columns() order, text already neutralised: the long file has ~12 rows per
    participant, so their identity is made safe once, not once per row (half the file's time)."""
    ctx = ctx or _Context(study)
    names = [c for c, _ in long_columns(ctx)]
    cells = names[names.index("env_id") + 1:names.index("answer_json")]  # a test's own
    no_test = [""] * len(cells)
    for page, answers in _pages(study):
        questions = _check_questions(page) if ctx.check_stars else {}
        tries = quiz.attempts_of(page) if ctx.comprehension else None
        for p in page:
            fields = _participant_fields(p, ctx)
            base = _safe(fields[c] for c, _ in PARTICIPANT_COLUMNS)
            mine = answers[p["pk"]] if tries is None else quiz.with_attempts(answers[p["pk"]], tries.get(p["pk"], []))
            for a in mine:
                data = a["data"]
                kind = a["kind"]
                if ctx.show and (kind == TEST or kind == CHECK):  # a way shown: its own cells, the rest empty
                    test = show_test_fields(a, ctx.difficulties[a["item"]] if kind == TEST else "")
                    test = [test.get(c, "") for c in cells]
                elif kind == TEST:
                    test = _test_fields(a, ctx.stars[a["item"]], ctx.difficulties[a["item"]])
                    test = [test[c] for c in cells]
                elif kind == CHECK:
                    test = _test_fields(a, ctx.check_stars[p["condition_id"]][questions[p["pk"], a["item"]]])
                    test = [test[c] for c in cells]
                else:
                    test = no_test
                # The answer's own cells need no neutralise(): numbers, the step's kind, digits
                # (display_order, answered_at) and answer_json, which starts with "{" whatever the
                # participant typed inside it; a show test's moves are neutralised where they are joined.
                row = base + [a["step"], a["kind"], "" if a["item"] is None else a["item"],
                              data.get("env_id", ""), *test, json.dumps(data, sort_keys=True),
                              a["created_at"].isoformat()]
                yield row if tries is None else row + [a.get("passed", "")]


def _check_fields(ctx: _Context, condition_id: int, answers: list[dict]) -> dict:
    """The wide file's check columns of one participant (`answers`: theirs, in step order); empty cells in a
    condition without checks."""
    if condition_id not in ctx.check_stars:
        return {}
    checks = [a for a in answers if a["kind"] == CHECK]
    row = {"n_checks_answered": len(checks), "n_checks_correct": sum(int(a["correct"]) for a in checks)}
    for k, a in enumerate(checks, start=1):
        row.update({f"check{k}_env_id": a["data"]["env_id"], f"check{k}_correct": int(a["correct"]),
                    f"check{k}_confidence_score": a["confidence_score"]})
    return row


def wide_rows(study: Study, ctx: _Context | None = None):
    ctx = ctx or _Context(study)
    n_tests = len(ctx.stars)
    kinds = [StepKind.TEST, StepKind.ATTENTION, StepKind.DEMOGRAPHICS] + ([StepKind.CHECK] if ctx.check_stars else [])
    for page, answers in _pages(study, kinds=kinds):
        tries = quiz.attempts_of(page) if ctx.comprehension else None
        for p in page:
            row = _participant_fields(p, ctx)
            if tries is not None:
                row.update(quiz.wide_fields(tries.get(p["pk"], [])))
            by_kind = {(a["kind"], a["item"]): a for a in answers[p["pk"]]}
            attention = by_kind.get((StepKind.ATTENTION, None), {}).get("data")
            demo = by_kind.get((StepKind.DEMOGRAPHICS, None), {}).get("data")
            tests = sorted((a for a in by_kind.values() if a["kind"] == StepKind.TEST), key=lambda a: a["item"])
            # A mean over some of the tests is not the paper's measure: given only when all were answered.
            every_test = len(tests) == n_tests and row["status"] in (COMPLETE, EXCLUDED)
            row.update(
                attention_passed="" if attention is None else int(attention["passed"]),
                attention_goals="" if attention is None else " ".join(attention["goals"]),
                age="" if demo is None else demo["age"], gender="" if demo is None else demo["gender"],
                gender_text="" if demo is None else demo.get("gender_text", ""),
                n_training=ctx.conditions[p["condition_id"]][1], n_tests_answered=len(tests))
            if ctx.show:
                row.update(show_wide_fields(tests, every_test))
                row.update(_check_fields(ctx, p["condition_id"], answers[p["pk"]]))
                yield row
                continue
            scores = [a["confidence_score"] for a in tests]
            row.update(mean_confidence_score=round(sum(scores) / len(scores), 6) if scores and every_test else "",
                       n_correct=sum(int(a["correct"]) for a in tests))
            for a in tests:
                j = a["item"]
                row.update({f"test{j}_env_id": a["data"]["env_id"], f"test{j}_correct": int(a["correct"]),
                            f"test{j}_confidence_score": a["confidence_score"]})
            row.update(_check_fields(ctx, p["condition_id"], answers[p["pk"]]))
            yield row


def to_csv(columns, rows) -> str:
    return "".join(csv_stream(columns, rows))


def csv_stream(columns, rows, batch: int = 200):
    """The CSV text of `rows` (dicts) under `columns`, header first, in pieces of `batch` rows."""
    names = [c for c, _ in columns]
    known = set(names)

    def cells():
        for row in rows:  # as DictWriter's extrasaction="raise": a column the file lacks is a mistake
            if not row.keys() <= known:
                raise ValueError(f"columns not in the file: {sorted(row.keys() - known)}")
            yield _safe(row.get(k, "") for k in names)

    return _pieces(names, cells(), batch)


def _pieces(names, cells, batch: int = 200):
    """CSV text of lists of `cells` (already neutralised) under the header `names`, `batch` rows a piece.
    A plain csv.writer, `batch` rows per call: DictWriter's per-row key checks cost a quarter of the
    long file's time."""
    out = io.StringIO()
    writer = csv.writer(out)
    writer.writerow(names)
    rows = []
    for row in cells:
        rows.append(row)
        if len(rows) >= batch:
            writer.writerows(rows)
            yield out.getvalue()
            out.seek(0)
            out.truncate()
            rows = []
    writer.writerows(rows)
    if out.tell():
        yield out.getvalue()


def wide_columns(study: Study, ctx: _Context | None = None) -> list:
    """WIDE_COLUMNS, the tests beyond N_TESTS_WIDE, and for a study with closed-loop conditions the check
    columns (CHECK_SUMMARY_COLUMNS, then check_columns(k) for k = 1 .. the most checks a condition asks)."""
    ctx = ctx or _Context(study)
    if ctx.show:  # one group of columns per test the study has
        columns = show_wide_columns(WIDE_COLUMNS)
        columns += [c for j in range(len(study.test_set)) for c in show_test_columns(j)]
    else:
        columns = list(WIDE_COLUMNS)
        extra = len(study.test_set) - N_TESTS_WIDE
        for j in range(N_TESTS_WIDE, N_TESTS_WIDE + max(extra, 0)):
            columns += [(f"test{j}_env_id", ""), (f"test{j}_correct", ""), (f"test{j}_confidence_score", "")]
    if ctx.check_stars:
        columns += CHECK_SUMMARY_COLUMNS + [c for k in range(1, ctx.n_checks + 1) for c in check_columns(k)]
    return columns + quiz.COMPREHENSION_WIDE_COLUMNS if ctx.comprehension else columns


def long_stream(study: Study, pseudonymise: bool = False):
    ctx = _Context(study, pseudonymise)
    return _pieces([c for c, _ in long_columns(ctx)], long_rows(study, ctx))


def wide_stream(study: Study, pseudonymise: bool = False):
    ctx = _Context(study, pseudonymise)
    return csv_stream(wide_columns(study, ctx), wide_rows(study, ctx))


def long_csv(study: Study, pseudonymise: bool = False) -> str:
    return "".join(long_stream(study, pseudonymise))


def wide_csv(study: Study, pseudonymise: bool = False) -> str:
    return "".join(wide_stream(study, pseudonymise))


def domain_descriptions(domain) -> dict[str, str]:
    """The descriptions that depend on the study's robot, in its domain's words (Domain.texts, its
    environments and classes): env ids, the chosen option and the attention check."""
    texts = domain.texts
    n = domain.n_environments
    package = type(domain).__module__.rpartition(".")[0]
    right = "; ".join(label for value, label in texts.attention_choices if value in texts.attention_correct)
    values = ", ".join(value for value, _ in texts.attention_choices)
    return {
        "env_id": (f"Environment id: one of the {n:,} environments of the {domain.name} domain ({package}), "
                   f"0 .. {n - 1}, each of one class ({', '.join(domain.class_names)}); for training and test rows, "
                   "in a closed-loop condition also for check and feedback rows."),
        "chosen_option": (f"Test or check: canonical index (0-3) of the {texts.option} chosen as the answer to "
                          f"\"{texts.question}\""),
        "attention_passed": f"1 if exactly the right answers to \"{texts.attention_question}\" were ticked: {right}.",
        "attention_goals": f"Answers ticked in the attention check (of {values}), space separated.",
    }


def dictionary_csv(study: Study | None = None) -> str:
    """The data dictionary; of `study`, its domain's descriptions where they depend on the robot."""
    own = domain_descriptions(study_domain(study)) if study is not None else {}
    if study is not None and study.test_kind == Study.SHOW:  # its own columns: a show test's, not a choice's
        ctx = _Context(study)
        long, wide = long_columns(ctx), show_wide_columns(WIDE_COLUMNS) + show_test_columns("<j>")
        wide += CHECK_SUMMARY_COLUMNS + check_columns("<k>") if ctx.check_stars else []
    else:
        long, wide = LONG_COLUMNS, WIDE_COLUMNS + CHECK_SUMMARY_COLUMNS + check_columns("<k>")
    long, wide = long + quiz.COMPREHENSION_LONG_COLUMNS, wide + quiz.COMPREHENSION_WIDE_COLUMNS
    rows = [{"file": "long", "column": c, "description": own.get(c, d)} for c, d in long]
    rows += [{"file": "wide", "column": c, "description": own.get(c, d)} for c, d in wide]
    return to_csv([("file", ""), ("column", ""), ("description", "")], rows)


STREAMS = {"long": long_stream, "wide": wide_stream}  # the files a view or command streams, by name
