"""Learning curves from the check questions of closed-loop conditions: the numbers on a
table worked out by hand, and the analysis page of a closed-loop study of simulated participants."""
import math
import re

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
import pytest
from django.urls import reverse
from statsmodels.stats.proportion import proportion_confint

from studyapp.analysis import data as D
from studyapp.analysis import learning as L
from studyapp.analysis import report as R
from studyapp.analysis import stats as S
from studyapp.analysis.simulate import post, run_participant, simulate
from studyapp.models import Answer, LoopStep, StepKind
from studyapp.participant import assignment, flow
from tests.conftest import answer_payload

# p1, p2 answered two checks, p3 one; p4 was excluded from the analysis and must change nothing.
CHECKS = pd.DataFrame(
    [("p1", 1, 1, True, 6.0), ("p1", 3, 2, True, 7.0),
     ("p2", 3, 2, True, 5.0), ("p2", 1, 1, False, -3.0),  # out of order: numbered by loop_index
     ("p3", 2, 2, False, -2.0),
     ("p4", 1, 1, True, 7.0), ("p4", 3, 2, False, -7.0)],
    columns=["participant_id", "loop_index", "examples_before", "correct", "score"],
).assign(condition="closed-loop")


def test_learning_curves_by_hand():
    checks = L.number_checks(CHECKS)
    p2 = checks[checks["participant_id"] == "p2"]
    assert dict(zip(p2["loop_index"], p2["check_number"], strict=True)) == {3: 2, 1: 1}  # rows stay in order
    curves = L.learning_curves(checks, participant_ids=["p1", "p2", "p3"])
    assert list(curves.columns) == L.CURVE_COLUMNS
    first, second = (curves.iloc[i] for i in range(2))
    assert (first["condition"], first["check_number"], first["n"], first["n_correct"]) == ("closed-loop", 1, 3, 1)
    assert first["p_correct"] == pytest.approx(1 / 3)
    assert first["mean_score"] == pytest.approx((6 - 3 - 2) / 3)
    # SD of (6, -3, -2) with ddof 1: sum of squared deviations 438/9, over 2; SE = SD / sqrt(3)
    assert first["se_score"] == pytest.approx(math.sqrt(438 / 9 / 2) / math.sqrt(3))
    assert first["mean_examples"] == pytest.approx(4 / 3)
    assert (second["check_number"], second["n"], second["n_correct"], second["p_correct"]) == (2, 2, 2, 1.0)
    assert second["mean_score"] == pytest.approx(6.0) and second["se_score"] == pytest.approx(1.0)
    assert second["mean_examples"] == pytest.approx(2.0)
    for row, (k, n) in ((first, (1, 3)), (second, (2, 2))):
        low, high = proportion_confint(k, n, alpha=0.05, method="wilson")
        assert (row["ci_low"], row["ci_high"]) == (pytest.approx(low), pytest.approx(high))
    # everyone in the table (no filter): p4 enters check 1 and check 2
    everyone = L.learning_curves(checks)
    assert list(everyone["n"]) == [4, 3] and list(everyone["n_correct"]) == [2, 2]


def test_one_answer_has_no_se_and_nothing_gives_an_empty_table():
    one = L.learning_curves(L.number_checks(CHECKS[CHECKS["participant_id"] == "p3"]))
    assert len(one) == 1 and np.isnan(one.iloc[0]["se_score"])
    for empty in (None, CHECKS.iloc[:0], L.number_checks(CHECKS)):
        curves = L.learning_curves(empty, participant_ids=[] if empty is not None else None)
        assert curves.empty and list(curves.columns) == L.CURVE_COLUMNS


def learning_table(html: str) -> dict[tuple[str, int], int]:
    """{(condition, check number): n} of the analysis page's learning-curve table."""
    table = re.search(r'<table id="table-learning">(.*?)</table>', html, re.S)
    assert table, "no learning-curve table"
    rows = re.findall(r"<tr><td>([^<]*)</td><td>(\d+)</td><td>(\d+)</td>", table.group(1))
    return {(cond, int(k)): int(n) for cond, k, n in rows}


def expected_n(study) -> dict[tuple[str, int], int]:
    """n per check number from the database: the complete, not excluded closed-loop participants who
    answered at least k checks."""
    counts = {}
    for p in study.participants.filter(condition__name="closed-loop", completed_at__isnull=False, excluded=False):
        for k in range(1, Answer.objects.filter(participant=p, kind=StepKind.CHECK).count() + 1):
            counts[("closed-loop", k)] = counts.get(("closed-loop", k), 0) + 1
    return counts


@pytest.mark.django_db
def test_the_analysis_page_shows_the_learning_curves(closed_loop_study, staff_client):
    study = closed_loop_study
    rng = simulate(study, n_per_condition=3, fail_every=100)
    looped = study.participants.filter(condition__name="closed-loop")
    # and someone of the closed loop who fails the attention check, not counted: alpha full, they land there
    study.conditions.filter(name="alpha").update(target=1)
    run_participant(study, rng, attentive=False)
    assert looped.filter(excluded=True).exists() and looped.filter(excluded=False).count() >= 2
    html = staff_client.get(reverse("dashboard_analysis", args=[study.slug])).content.decode()
    assert "Learning curves from the check questions" in html and 'id="fig-learning"' in html
    shown = learning_table(html)
    assert shown == expected_n(study) and shown[("closed-loop", 1)] >= 1
    # the analysis's numbers are the check answers of exactly the included participants
    analysis = D.analyze_study(study)
    included = set(analysis.participants.query("~excluded & mean_score.notna()")["participant_id"])
    checks = D.checks_frame(study)
    counted = checks[checks["participant_id"].isin(included)]
    first = analysis.learning.iloc[0]
    at_one = counted[counted["check_number"] == 1]
    assert first["n"] == len(at_one) and first["n_correct"] == at_one["correct"].sum()
    assert first["mean_score"] == pytest.approx(at_one["score"].mean())
    # examples before a check: the participant's example steps with a smaller loop index
    row = checks.iloc[-1]
    assert row["examples_before"] == LoopStep.objects.filter(
        participant_id=int(row["participant_id"]), kind=LoopStep.EXAMPLE, index__lt=row["loop_index"]).count()


@pytest.mark.django_db
def test_unfinished_participants_enter_only_with_include_incomplete(closed_loop_study):
    study = closed_loop_study
    rng = np.random.default_rng(5)
    done = [run_participant(study, rng) for _ in range(2)]
    looper = next(p for p in done if p.condition.closed_loop)
    midway = next(p for p in (run_participant_until_tests(study) for _ in range(2)) if p.condition.closed_loop)
    assert midway.answers.filter(kind=StepKind.CHECK).exists() and midway.completed_at is None
    assert set(D.checks_frame(study)["participant_id"]) == {str(looper.pk)}
    assert set(D.checks_frame(study, include_incomplete=True)["participant_id"]) == {str(looper.pk), str(midway.pk)}
    # the analysis counts only those it includes: without a final test answered, `midway` is not
    analysis = D.analyze_study(study, include_incomplete=True)
    assert analysis.learning.iloc[0]["n"] == 1


def run_participant_until_tests(study):
    """A participant who answers every step (θ*'s option in the checks) and stops at the first final test."""
    p = assignment.assign(study)
    while (step := flow.current_step(p)).kind != StepKind.TEST:
        p = flow.record(p, step.index, post(**answer_payload(p, step)))
    return p


@pytest.mark.django_db
def test_a_study_without_closed_loop_conditions_has_no_learning_section(study, staff_client, complete):
    for i in range(3):
        complete(assignment.assign(study, "prolific", f"n{i}"))
    assert D.checks_frame(study).empty
    analysis = D.analyze_study(study)
    assert analysis.learning.empty and R.context(analysis, figures={})["learning"] == []
    html = staff_client.get(reverse("dashboard_analysis", args=[study.slug])).content.decode()
    assert "Learning curves" not in html and "table-learning" not in html


def test_analyze_counts_the_included_participants_and_writes_the_csv_only_with_curves(tmp_path):
    """stats.analyze on tables made by hand: p4 failed the attention check, so only p1-p3 count."""
    people = [("p1", "closed-loop", True), ("p2", "closed-loop", True), ("p3", "closed-loop", True),
              ("p4", "closed-loop", False), ("a1", "alpha", True), ("a2", "alpha", True)]
    P = pd.DataFrame(people, columns=["participant_id", "condition", "attention_ok"])
    A = pd.DataFrame([{"participant_id": pid, "test_index": 0, "test_cluster": 0, "correct": True, "confidence": 5}
                      for pid, _, _ in people])
    T = pd.DataFrame([{"condition": "alpha", "position": 0, "cluster": 0}])
    without = S.analyze(P, A, T)
    assert without.learning.empty
    assert "learning_curves.csv" not in {p.name for p in R.write_csvs(without, tmp_path / "a")}
    analysis = S.analyze(P, A, T, checks=L.number_checks(CHECKS))
    assert list(analysis.learning["n"]) == [3, 2]  # as test_learning_curves_by_hand, p4 left out
    assert R.headline(analysis)[-1].startswith("Learning curve closed-loop (chose θ* at check k): 1: 1/3 = 0.33 [")
    written = {p.name: p for p in R.write_csvs(analysis, tmp_path / "b")}
    assert list(pd.read_csv(written["learning_curves.csv"]).columns) == L.CURVE_COLUMNS
    figures = R.FIG.all_figures(analysis)
    assert "learning" in figures and R.FIG.to_bytes(figures.pop("learning")).startswith(b"\x89PNG")
    for fig in figures.values():
        plt.close(fig)


def test_show_learning_curves_by_hand():
    """A show study's checks: p1 showed an optimal way at both checks, p2 a way of regret 2 then an optimal
    one, p3 one of regret 1.5; p4 is excluded."""
    checks = L.number_checks(CHECKS.assign(
        correct=[True, True, True, False, False, True, False], score=np.nan,
        regret=[0.0, 0.0, 0.0, 2.0, 1.5, 0.0, 9.0]))
    curves = L.show_learning_curves(checks, participant_ids=["p1", "p2", "p3"])
    assert list(curves.columns) == L.SHOW_CURVE_COLUMNS
    first, second = (curves.iloc[i] for i in range(2))
    # check 1: p1 0, p2 2.0 (its loop_index 1), p3 1.5: one optimal of three, mean regret 3.5 / 3
    assert (first["check_number"], first["n"], first["n_optimal"]) == (1, 3, 1)
    assert first["p_optimal"] == pytest.approx(1 / 3) and first["mean_regret"] == pytest.approx(3.5 / 3)
    # SD of (0, 2, 1.5) with ddof 1: squared deviations about 7/6 sum to 13/6, over 2; SE = SD / sqrt(3)
    assert first["se_regret"] == pytest.approx(math.sqrt(13 / 6 / 2) / math.sqrt(3))
    # check 2: p1 0 and p2 0
    assert (second["n"], second["n_optimal"], second["mean_regret"], second["se_regret"]) == (2, 2, 0.0, 0.0)
    low, high = proportion_confint(1, 3, alpha=0.05, method="wilson")
    assert (first["ci_low"], first["ci_high"]) == (pytest.approx(low), pytest.approx(high))
    assert L.show_learning_curves(None).columns.tolist() == L.SHOW_CURVE_COLUMNS
