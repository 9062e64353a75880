"""Build the analysis input tables (see :mod:`studyapp.analysis.stats`) from the Django models.

* Staff previews are never analysed (not in any table).
* By default only participants who finished (``completed_at`` set) are analysed; with
  ``include_incomplete=True`` unfinished ones enter too (with the tests they answered).
* ``status`` is studyapp.status's (complete / incomplete / excluded / declined / returned / timed_out /
  screened_out), the exports' column.
* ``attention_ok`` comes from the stored attention answer (``data["passed"]``); ``excluded``
  is the participant's flag (set by the flow when the attention check fails), and true for everyone
  who returned, timed out or was screened out (their ``exclusion_reason`` says which).
* ``checks_frame`` holds the check answers of closed-loop conditions (their learning curves,
  :mod:`studyapp.analysis.learning`), for the same participants as ``frames``.
* ``test_cluster`` of a test is the strategy cluster stored with the study's test set
  (``test_set[j]["cluster"]``, theta*'s trajectory there); the training clusters come from each
  condition's frozen ``training[i]["cluster"]``.  ``test_difficulty`` is the test's difficulty
  (``test_set[j]["difficulty"]``: low / medium / high) where the study's tests were graded, else None.
* A show study's tests (``Study.test_kind == "show"``) ask for a way, not a choice: its answers table has
  ``optimal`` and ``regret`` instead of a choice's ``correct``, ``confidence`` and ``score``
  (SHOW_ANSWER_COLUMNS), and :func:`analyze_study` analyses it by :mod:`studyapp.analysis.shown`.
"""
from __future__ import annotations

import pandas as pd
from django.db.models import Count, Max, Q

from ..models import Answer, Condition, LoopStep, Participant, StepKind, Study
from ..participant import outcomes
from ..status import RETURNED, SCREENED_OUT, TIMED_OUT, participant_status
from ..trajectories import study_domain
from . import learning as L
from . import shown as SH
from . import stats as S

ENDED_REASONS = {RETURNED: "returned the study", TIMED_OUT: "timed out", SCREENED_OUT: "screened out"}
PARTICIPANT_COLUMNS = ["participant_id", "condition", "attention_ok", "excluded", "exclusion_reason", "age",
                       "gender", "platform", "completed", "status"]
ANSWER_COLUMNS = ["participant_id", "test_index", "test_cluster", "test_difficulty", "correct", "confidence", "score"]
SHOW_ANSWER_COLUMNS = ["participant_id", "test_index", "test_cluster", "test_difficulty", "optimal", "regret"]
TRAINING_COLUMNS = ["condition", "position", "environment_id", "cluster"]


def _participants(study: Study, include_incomplete: bool):
    qs = Participant.objects.filter(study=study).exclude(platform=Participant.PREVIEW)
    if not include_incomplete:
        qs = qs.filter(completed_at__isnull=False)
    # values(): never decode the large training / test-set JSON once per participant
    return qs.order_by("pk").values("pk", "condition__name", "excluded", "completed_at", "platform", "position",
                                    "outcome")


def training_frame(study: Study) -> pd.DataFrame:
    rows = []
    for cond in Condition.objects.filter(study=study).order_by("position", "pk"):
        for i, env in enumerate(cond.training or []):
            rows.append({"condition": cond.name, "position": i, "environment_id": env.get("env_id"),
                         "cluster": env.get("cluster")})
    return pd.DataFrame(rows, columns=TRAINING_COLUMNS)


def frames(study: Study, include_incomplete: bool = False) -> tuple[pd.DataFrame, pd.DataFrame, pd.DataFrame]:
    """(participants, answers, training) DataFrames for :func:`stats.analyze` (a show study's answers:
    SHOW_ANSWER_COLUMNS, for :func:`shown.analyze_show`)."""
    show = study.test_kind == Study.SHOW
    outcomes.expire(study)  # a participant whose time ran out reads as timed out, here as in the exports
    people = list(_participants(study, include_incomplete))
    ids = [p["pk"] for p in people]
    kinds = [StepKind.TEST, StepKind.ATTENTION, StepKind.DEMOGRAPHICS]
    answers = (Answer.objects.filter(participant_id__in=ids, kind__in=kinds)
               .values("participant_id", "kind", "item", "data", "correct", "confidence_score", "regret"))
    tests = study.test_set or []
    attention, demo, arows = {}, {}, []
    for a in answers:
        pid = a["participant_id"]
        if a["kind"] == StepKind.ATTENTION:
            attention[pid] = bool((a["data"] or {}).get("passed"))
        elif a["kind"] == StepKind.DEMOGRAPHICS:
            demo[pid] = a["data"] or {}
        elif show and a["regret"] is not None and a["item"] is not None:
            j = int(a["item"])
            test = tests[j] if j < len(tests) else {}
            arows.append({"participant_id": str(pid), "test_index": j, "test_cluster": test.get("cluster"),
                          "test_difficulty": test.get("difficulty"), "optimal": bool(a["correct"]),
                          "regret": float(a["regret"])})
        elif a["confidence_score"] is not None and a["item"] is not None:
            j = int(a["item"])
            test = tests[j] if j < len(tests) else {}
            arows.append({"participant_id": str(pid), "test_index": j, "test_cluster": test.get("cluster"),
                          "test_difficulty": test.get("difficulty"),
                          "correct": bool(a["correct"]), "confidence": abs(int(a["confidence_score"])),
                          "score": float(a["confidence_score"])})
    prows = []
    for p in people:
        pk, excluded = p["pk"], bool(p["excluded"])
        ok = attention.get(pk, not excluded)
        reason = ("failed attention check" if not ok else "excluded by the researcher") if excluded else ""
        if p["outcome"]:  # returned, timed out or screened out: never analysed, whatever they answered
            excluded, reason = True, ENDED_REASONS[p["outcome"]]
        prows.append({"participant_id": str(pk), "condition": p["condition__name"], "attention_ok": ok,
                      "excluded": excluded, "exclusion_reason": reason,
                      "age": demo.get(pk, {}).get("age"), "gender": demo.get(pk, {}).get("gender"),
                      "platform": p["platform"], "completed": p["completed_at"] is not None,
                      "status": participant_status(position=p["position"], excluded=bool(p["excluded"]),
                                                   completed=p["completed_at"] is not None, outcome=p["outcome"])})
    return (pd.DataFrame(prows, columns=PARTICIPANT_COLUMNS),
            pd.DataFrame(arows, columns=SHOW_ANSWER_COLUMNS if show else ANSWER_COLUMNS), training_frame(study))


def checks_frame(study: Study, include_incomplete: bool = False) -> pd.DataFrame:
    """One row per check answer (learning.CHECK_COLUMNS) of the participants :func:`frames` lists;
    empty when none answered a check.  ``check_number`` counts each participant's checks in the order
    answered; ``examples_before`` their example steps before it.  Three queries (participants, their check
    answers, the example steps of those who answered one); a study without check answers stops at two."""
    people = {p["pk"]: p["condition__name"] for p in _participants(study, include_incomplete)}
    answers = list(Answer.objects.filter(participant_id__in=list(people), kind=StepKind.CHECK)
                   .values_list("participant_id", "item", "correct", "confidence_score", "regret"))
    if not answers:
        return pd.DataFrame(columns=L.CHECK_COLUMNS)
    examples: dict[int, list[int]] = {}  # participant id -> loop indices of the examples they saw
    for pid, index in (LoopStep.objects.filter(participant_id__in={a[0] for a in answers}, kind=LoopStep.EXAMPLE)
                       .values_list("participant_id", "index")):
        examples.setdefault(pid, []).append(index)
    rows = [{"participant_id": str(pid), "condition": people[pid], "loop_index": int(item),
             "examples_before": sum(i < item for i in examples.get(pid, [])), "correct": bool(correct),
             # a choice check has a confidence score, a show check a regret
             "score": float("nan") if score is None else float(score),
             "regret": float("nan") if regret is None else float(regret)}
            for pid, item, correct, score, regret in answers]
    return L.number_checks(pd.DataFrame(rows))[L.CHECK_COLUMNS]


def condition_names(study: Study) -> list[str]:
    """The study's condition names, canonical; a ConditionError if two of them are one condition
    (a study stored before creating one refused that: it is not analysed, docs/analysis.md)."""
    names = list(Condition.objects.filter(study=study).order_by("position", "pk").values_list("name", flat=True))
    S.check_distinct_conditions(names)
    return [S.canonical(n) for n in names]


def study_approx_star(names, approx_star: str = S.APPROX_STAR_DEFAULT) -> str:
    """approx* for a study with these (canonical) condition names: `approx_star`, unless the study
    lacks it and calls a condition "approx*" (or "approx-star")."""
    star = S.canonical(approx_star)
    if star not in names:
        for alt in S.APPROX_STAR_NAMES:
            if alt in names:
                star = alt
    return star


def planned_comparisons(study: Study) -> list[tuple[str, str]]:
    """The planned comparisons of `study` (its approx* resolved): what a named one may not repeat."""
    return S.default_comparisons(study_approx_star(condition_names(study)))


def analyze_study(study: Study, include_incomplete: bool = False, extra_comparisons=(),
                  approx_star: str = S.APPROX_STAR_DEFAULT) -> S.Analysis | SH.ShowAnalysis:
    """The analysis of `study` (a show study's: a ShowAnalysis); a ConditionError (a ValueError, with a
    message for the researcher) for aliased condition names, an approx* that is no approximate model, or
    named comparisons that are not new pairs of the study's conditions."""
    names = condition_names(study)
    star = study_approx_star(names, approx_star)
    participants, answers, training = frames(study, include_incomplete)
    if study.test_kind == Study.SHOW:
        domain = study_domain(study)  # its score_shown gave each regret under its θ*
        return SH.analyze_show(participants, answers, training, extra_comparisons=extra_comparisons,
                               approx_star=star, conditions=names, cluster_names=domain.cluster_names,
                               checks=checks_frame(study, include_incomplete),
                               theta_star_l1=float(sum(abs(float(w)) for w in domain.theta_star)))
    return S.analyze(participants, answers, training, extra_comparisons=extra_comparisons, approx_star=star,
                     checks=checks_frame(study, include_incomplete), clusters=S.Clusters.of(study_domain(study)))


def fingerprint(study: Study, include_incomplete: bool = False) -> str:
    """Changes whenever a response arrives (answers are write-once; exclusion and completion are
    set together with an answer; an outcome is counted), so a cached report keyed on it is recomputed
    exactly then."""
    outcomes.expire(study)
    agg = Answer.objects.filter(participant__study=study).aggregate(n=Count("pk"), last=Max("pk"))
    np_ = Participant.objects.filter(study=study).aggregate(
        n=Count("pk"), ex=Count("pk", filter=Q(excluded=True)), done=Count("pk", filter=Q(completed_at__isnull=False)),
        ended=Count("pk", filter=~Q(outcome="")))
    conds = Condition.objects.filter(study=study).aggregate(n=Count("pk"), last=Max("pk"))
    return (f"{study.pk}-{agg['n']}-{agg['last']}-{np_['n']}-{np_['ex']}-{np_['done']}-{np_['ended']}-"
            f"{conds['n']}-{conds['last']}-{int(include_incomplete)}")
