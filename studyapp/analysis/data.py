"""Build the analysis input tables (see :mod:`studyapp.analysis.stats`) from the Django models.

* Staff previews are never analysed (not in any table).
* By default only participants who finished (``completed_at`` set) are analysed; with
  ``include_incomplete=True`` unfinished ones enter too (with the tests they answered).
* ``status`` is studyapp.status's (complete / incomplete / excluded / declined), the exports' column.
* ``attention_ok`` comes from the stored attention answer (``data["passed"]``); ``excluded``
  is the participant's flag (set by the flow when the attention check fails).
* ``test_cluster`` of a test is the strategy cluster stored with the study's test set
  (``test_set[j]["cluster"]``, theta*'s trajectory there); the training clusters come from each
  condition's frozen ``training[i]["cluster"]``.
"""
from __future__ import annotations

import pandas as pd
from django.db.models import Count, Max, Q

from ..models import Answer, Condition, Participant, StepKind, Study
from ..status import participant_status
from . import stats as S

PARTICIPANT_COLUMNS = ["participant_id", "condition", "attention_ok", "excluded", "exclusion_reason", "age",
                       "gender", "platform", "completed", "status"]
ANSWER_COLUMNS = ["participant_id", "test_index", "test_cluster", "correct", "confidence", "score"]
TRAINING_COLUMNS = ["condition", "position", "environment_id", "cluster"]


def _participants(study: Study, include_incomplete: bool):
    qs = Participant.objects.filter(study=study).exclude(platform=Participant.PREVIEW)
    if not include_incomplete:
        qs = qs.filter(completed_at__isnull=False)
    # values(): never decode the large training / test-set JSON once per participant
    return qs.order_by("pk").values("pk", "condition__name", "excluded", "completed_at", "platform", "position")


def training_frame(study: Study) -> pd.DataFrame:
    rows = []
    for cond in Condition.objects.filter(study=study).order_by("position", "pk"):
        for i, env in enumerate(cond.training or []):
            rows.append({"condition": cond.name, "position": i, "environment_id": env.get("env_id"),
                         "cluster": env.get("cluster")})
    return pd.DataFrame(rows, columns=TRAINING_COLUMNS)


def frames(study: Study, include_incomplete: bool = False) -> tuple[pd.DataFrame, pd.DataFrame, pd.DataFrame]:
    """(participants, answers, training) DataFrames for :func:`stats.analyze`."""
    people = list(_participants(study, include_incomplete))
    ids = [p["pk"] for p in people]
    kinds = [StepKind.TEST, StepKind.ATTENTION, StepKind.DEMOGRAPHICS]
    answers = (Answer.objects.filter(participant_id__in=ids, kind__in=kinds)
               .values("participant_id", "kind", "item", "data", "correct", "confidence_score"))
    tests = study.test_set or []
    attention, demo, arows = {}, {}, []
    for a in answers:
        pid = a["participant_id"]
        if a["kind"] == StepKind.ATTENTION:
            attention[pid] = bool((a["data"] or {}).get("passed"))
        elif a["kind"] == StepKind.DEMOGRAPHICS:
            demo[pid] = a["data"] or {}
        elif a["confidence_score"] is not None and a["item"] is not None:
            j = int(a["item"])
            cluster = tests[j].get("cluster") if j < len(tests) else None
            arows.append({"participant_id": str(pid), "test_index": j, "test_cluster": cluster,
                          "correct": bool(a["correct"]), "confidence": abs(int(a["confidence_score"])),
                          "score": float(a["confidence_score"])})
    prows = []
    for p in people:
        pk, excluded = p["pk"], bool(p["excluded"])
        ok = attention.get(pk, not excluded)
        reason = ("failed attention check" if not ok else "excluded by the researcher") if excluded else ""
        prows.append({"participant_id": str(pk), "condition": p["condition__name"], "attention_ok": ok,
                      "excluded": excluded, "exclusion_reason": reason,
                      "age": demo.get(pk, {}).get("age"), "gender": demo.get(pk, {}).get("gender"),
                      "platform": p["platform"], "completed": p["completed_at"] is not None,
                      "status": participant_status(position=p["position"], excluded=excluded,
                                                   completed=p["completed_at"] is not None)})
    return (pd.DataFrame(prows, columns=PARTICIPANT_COLUMNS), pd.DataFrame(arows, columns=ANSWER_COLUMNS),
            training_frame(study))


def analyze_study(study: Study, include_incomplete: bool = False, extra_comparisons=(),
                  approx_star: str = S.APPROX_STAR_DEFAULT) -> S.Analysis:
    participants, answers, training = frames(study, include_incomplete)
    names = set(S.canonical(c) for c in training["condition"])
    star = S.canonical(approx_star)
    if star not in names:  # e.g. a study naming it "approx*"
        for alt in ("approx*", "approx-star"):
            if alt in names:
                star = alt
    return S.analyze(participants, answers, training, extra_comparisons=extra_comparisons, approx_star=star)


def fingerprint(study: Study, include_incomplete: bool = False) -> str:
    """Changes whenever a response arrives (answers are write-once; exclusion and completion are
    set together with an answer), so a cached report keyed on it is recomputed exactly then."""
    agg = Answer.objects.filter(participant__study=study).aggregate(n=Count("pk"), last=Max("pk"))
    np_ = Participant.objects.filter(study=study).aggregate(
        n=Count("pk"), ex=Count("pk", filter=Q(excluded=True)), done=Count("pk", filter=Q(completed_at__isnull=False)))
    conds = Condition.objects.filter(study=study).aggregate(n=Count("pk"), last=Max("pk"))
    return (f"{study.pk}-{agg['n']}-{agg['last']}-{np_['n']}-{np_['ex']}-{np_['done']}-{conds['n']}-{conds['last']}-"
            f"{int(include_incomplete)}")
