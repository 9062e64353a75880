"""A show study (each test asks the participant to move the robot): its exports carry the moves, regret and
optimality of each way shown, and its analysis compares each participant's mean regret and share of optimal
ways between conditions (one-way ANOVA, the paper's factorial ANOVAs, Welch's t-tests), checked against SciPy and
hand-worked numbers, with per-test, per-level summaries and closed-loop learning curves."""
import csv
import io
from datetime import timedelta

import numpy as np
import pandas as pd
import pytest
from django.core.management import call_command
from django.utils import timezone
from scipy import stats

from studyapp.analysis import data as D
from studyapp.analysis import modelfit as MF
from studyapp.analysis import report as R
from studyapp.analysis import report_show as RS
from studyapp.analysis.shown import MEASURES, ShowAnalysis, analyze_show
from studyapp.analysis.simulate import run_participant
from studyapp.analysis.stats import DETERMINISM
from studyapp.data import exports
from studyapp.models import Answer, Condition, LoopStep, Participant, StepKind, Study
from studyapp.participant import assignment
from tests.studyapp.test_analysis_stats import check_anova, hand_anova

pytestmark = pytest.mark.django_db

MOVES = [["right", "up", "pickup"], ["left", "left"], ["down", "pickup", "right"]]
# Each complete participant's regret in tests 0, 1, 2 (θ*'s units); a way is optimal when its regret is 0.
REGRETS = {
    "exact": [[0, 0, 1.5], [0, 0.5, 0], [0, 0, 0], [2.0, 0, 0.25]],
    "det-euclidean": [[1.0, 0, 0.5], [0, 2.5, 1.0], [3.0, 0, 0], [0.5, 1.5, 2.0]],
    "random": [[4.0, 1.0, 2.5], [0, 3.0, 3.5], [5.0, 2.0, 0], [1.0, 4.5, 3.0], [2.0, 0, 6.0]],
}
TEST_SET = [{"env_id": 10 + j, "cluster": j % 2, "cluster_name": f"cluster {j % 2}", "kind": "show",
             "robot": [], "optimum": 4.0 + j} for j in range(3)]


def rows(text):
    return list(csv.DictReader(io.StringIO(text)))


def _answer(p, step, kind, item=None, data=None, **fields):
    return Answer.objects.create(participant=p, step=step, kind=kind, item=item, data=data or {}, **fields)


def _participant(study, condition, pid, regrets, *, completed=True, attentive=True):
    """A participant who showed ways with these regrets (test j: MOVES[j]), then the attention check and
    demographics when `completed`."""
    now = timezone.now()
    p = Participant.objects.create(study=study, condition=condition, platform="prolific", platform_pid=pid,
                                   position=30 if completed else 11, excluded=not attentive,
                                   completed_at=now if completed else None, started_at=now - timedelta(minutes=5))
    _answer(p, 0, StepKind.CONSENT, data={"consent": True})
    for j, regret in enumerate(regrets):
        _answer(p, 10 + j, StepKind.TEST, j, {"env_id": TEST_SET[j]["env_id"], "moves": MOVES[j]},
                correct=regret == 0, regret=float(regret))
    if completed:
        _answer(p, 20, StepKind.ATTENTION, data={"passed": attentive, "goals": ["forward"]})
        _answer(p, 21, StepKind.DEMOGRAPHICS, data={"age": 30, "gender": "female"})
    return p


@pytest.fixture
def show_study(db):
    study = Study.objects.create(slug="show", name="Show study", test_kind=Study.SHOW, test_set=TEST_SET,
                                 is_open=False)
    conditions = {name: Condition.objects.create(study=study, name=name, position=i,
                                                 training=[{"env_id": 100 + i, "cluster": i % 2}])
                  for i, name in enumerate(REGRETS)}
    for name, people in REGRETS.items():
        for k, regrets in enumerate(people):
            _participant(study, conditions[name], f"{name}-{k}", regrets)
    # never analysed: one who failed the attention check (ways far from optimal), one who stopped early
    _participant(study, conditions["exact"], "careless", [9.0, 9.0, 9.0], attentive=False)
    _participant(study, conditions["det-euclidean"], "unfinished", [0.0], completed=False)
    return study


def _means(name):
    """Each complete participant's (mean regret, share of optimal ways) in condition `name`, computed here."""
    return ([sum(r) / len(r) for r in REGRETS[name]], [sum(x == 0 for x in r) / len(r) for r in REGRETS[name]])


# ------------------------------------------------------------------ exports

def test_a_show_studys_long_file_has_the_moves_regret_and_optimality_of_each_way(show_study):
    out = rows(exports.long_csv(show_study))
    header = list(out[0])
    assert header[header.index("test_difficulty"):header.index("answer_json")] == [
        "test_difficulty", "moves", "regret", "optimal"]
    assert not {"chosen_option", "confidence_score", "rating_0", "display_order"} & set(header)
    tests = [r for r in out if r["platform_pid"] == "exact-0" and r["kind"] == StepKind.TEST]
    assert [(r["item"], r["env_id"], r["moves"], r["regret"], r["optimal"]) for r in tests] == [
        ("0", "10", "right up pickup", "0.0", "1"), ("1", "11", "left left", "0.0", "1"),
        ("2", "12", "down pickup right", "1.5", "0")]
    consent = next(r for r in out if r["platform_pid"] == "exact-0" and r["kind"] == StepKind.CONSENT)
    assert (consent["moves"], consent["regret"], consent["optimal"]) == ("", "", "")


def test_a_show_studys_wide_file_has_each_tests_way_and_the_participants_means(show_study):
    out = {r["platform_pid"]: r for r in rows(exports.wide_csv(show_study))}
    header = list(out["exact-0"])
    assert header[header.index("n_tests_answered"):] == ["n_tests_answered", "mean_regret", "share_optimal"] + [
        f"test{j}_{c}" for j in range(3) for c in ("env_id", "moves", "regret", "optimal")]
    assert not {"mean_confidence_score", "n_correct", "test0_correct", "test0_confidence_score"} & set(header)
    first = out["exact-0"]  # regrets 0, 0, 1.5
    assert (first["mean_regret"], first["share_optimal"]) == ("0.5", "0.666667")
    assert (first["test2_env_id"], first["test2_moves"], first["test2_regret"], first["test2_optimal"]) == (
        "12", "down pickup right", "1.5", "0")
    assert (out["random-1"]["mean_regret"], out["random-1"]["share_optimal"]) == ("2.166667", "0.333333")
    # an unfinished participant: what they answered, but no mean over some of the tests
    late = out["unfinished"]
    assert (late["status"], late["n_tests_answered"], late["test0_regret"], late["mean_regret"],
            late["share_optimal"], late["test1_moves"]) == ("incomplete", "1", "0.0", "", "", "")


def test_a_show_studys_dictionary_describes_its_own_columns_in_theta_stars_units(show_study):
    d = {(r["file"], r["column"]): r["description"] for r in rows(exports.dictionary_csv(show_study))}
    assert "theta*'s units" in d["long", "regret"] and "theta*'s units" in d["wide", "mean_regret"]
    assert {("wide", "test<j>_moves"), ("wide", "test<j>_optimal"), ("wide", "share_optimal"),
            ("long", "moves"), ("long", "optimal")} <= set(d)
    assert ("long", "confidence_score") not in d and ("wide", "mean_confidence_score") not in d


def test_a_choice_studys_exports_have_none_of_the_show_columns(study, complete):
    complete(assignment.assign(study, "prolific", "C1"))
    new = {"moves", "regret", "optimal", "mean_regret", "share_optimal"}
    long_header = list(rows(exports.long_csv(study))[0])
    wide_header = list(rows(exports.wide_csv(study))[0])
    assert long_header == [c for c, _ in exports.LONG_COLUMNS]
    assert wide_header == [c for c, _ in exports.WIDE_COLUMNS]
    assert not new & set(long_header + wide_header)
    assert not [c for c in wide_header if c.endswith(("_moves", "_regret", "_optimal"))]
    dictionary = {r["column"] for r in rows(exports.dictionary_csv(study))}
    assert not new & dictionary and "test<j>_moves" not in dictionary


# ------------------------------------------------------------------ analysis

def test_the_show_analysis_matches_scipy_on_the_same_numbers(show_study):
    analysis = D.analyze_study(show_study)
    assert isinstance(analysis, ShowAnalysis)
    assert analysis.n_included == sum(len(p) for p in REGRETS.values()) and analysis.n_excluded == 1
    assert [m.name for m in analysis.measures] == ["mean regret (θ*'s units, 0 = optimal)", "share of optimal ways"]
    for index, measure in enumerate(analysis.measures):
        groups = {name: _means(name)[index] for name in REGRETS}
        f, p = stats.f_oneway(*groups.values())
        table = measure.anova.type2
        assert measure.anova.ok
        assert table.loc["condition", "F"] == pytest.approx(f, rel=1e-9)
        assert table.loc["condition", "p"] == pytest.approx(p, rel=1e-9)
        assert table.loc["condition", "df"] == 2 and table.loc["Residual", "df"] == 13 - 3
        welch = measure.welch.set_index("comparison")
        assert list(welch.index) == ["approx* (det-euclidean) vs exact", "approx* (det-euclidean) vs random"]
        for other in ("exact", "random"):
            t = stats.ttest_ind(groups["det-euclidean"], groups[other], equal_var=False)
            row = welch.loc[f"approx* (det-euclidean) vs {other}"]
            assert row["t"] == pytest.approx(t.statistic, rel=1e-9)
            assert row["p"] == pytest.approx(t.pvalue, rel=1e-9)
            assert row["mean_a"] == pytest.approx(np.mean(groups["det-euclidean"]))
        summary = measure.summary
        assert summary.loc["random", "mean"] == pytest.approx(np.mean(groups["random"]))
        assert (summary.loc["exact", "n_recruited"], summary.loc["exact", "n_excluded"],
                summary.loc["exact", "n"]) == (5, 1, 4)


def test_a_show_studys_analysis_page_and_files(show_study, staff_client, tmp_path):
    r = staff_client.get("/dashboard/show/analysis/")
    page = r.content.decode()
    assert r.status_code == 200
    for _, name in MEASURES:
        assert name.replace("'", "&#x27;") in page
    assert "One-way ANOVA of the share of optimal ways across conditions" in page
    assert "approx* (det-euclidean) vs random" in page and "Not computed for a show study" in page
    assert "Learner models fitted to the answers: not fitted" in page
    frag = staff_client.get("/dashboard/show/analysis/", {"fragment": "1", "compare": "exact:random"})
    assert frag.status_code == 200 and "exact vs random" in frag.content.decode()
    models = staff_client.get("/dashboard/show/analysis/models/")
    assert models.status_code == 200 and "show the way" in models.content.decode()
    assert staff_client.get("/dashboard/show/analysis/models.csv").status_code == 409
    assert staff_client.get("/dashboard/show/").status_code == 200  # its dashboard, pilot section included

    out = io.StringIO()
    call_command("analyze", "show", "--out", str(tmp_path), stdout=out)
    assert "ANOVA of the mean regret" in out.getvalue()
    welch = rows((tmp_path / "welch.csv").read_text())
    assert {w["measure"] for w in welch} == {name for _, name in MEASURES} and len(welch) == 4
    anova = [a for a in rows((tmp_path / "anova.csv").read_text()) if a["effect"] == "condition"]
    f, _ = stats.f_oneway(*(_means(name)[0] for name in REGRETS))
    assert float(anova[0]["F"]) == pytest.approx(f, rel=1e-9)
    people = rows((tmp_path / "participants.csv").read_text())
    first = next(p for p in people if p["participant_id"] == str(
        Participant.objects.get(platform_pid="exact-0").pk))
    assert (float(first["mean_regret"]), float(first["share_optimal"]), first["regret_2"]) == (0.5, 2 / 3, "1.5")


def test_a_show_study_with_no_answers_yet_says_what_it_cannot_compute(staff_client):
    study = Study.objects.create(slug="fresh", name="Fresh", test_kind=Study.SHOW, test_set=TEST_SET, is_open=False)
    for i, name in enumerate(("exact", "random")):
        Condition.objects.create(study=study, name=name, position=i, training=[])
    analysis = D.analyze_study(study)
    assert not any(m.anova.ok for m in analysis.measures)
    assert "too few participants" in analysis.measures[0].anova.message
    assert "exact: 0" in R.headline(analysis)[1]
    assert staff_client.get("/dashboard/fresh/analysis/").status_code == 200


def test_choices_alone_are_refused_on_a_show_study_with_their_reason(show_study):
    with pytest.raises(MF.ModelFitError, match="show the way"):
        MF.fit_study(show_study)
    with pytest.raises(ValueError, match="show study"):
        run_participant(show_study, np.random.default_rng(0))


def test_a_choice_studys_analysis_page_is_as_before(study, complete, staff_client):
    for k in range(2):
        complete(assignment.assign(study, "prolific", f"A{k}"))
    r = staff_client.get(f"/dashboard/{study.slug}/analysis/")
    page = r.content.decode()
    assert r.status_code == 200 and "Scores per condition" in page and "mean confidence score" in page
    assert "regret" not in page and "Not computed for a show study" not in page


def test_each_conditions_answers_per_test_and_per_level_as_worked_by_hand(show_study, tmp_path):
    show_study.test_set = [{**t, "difficulty": level} for t, level in zip(TEST_SET, ["low", "high", "low"],
                                                                           strict=True)]
    show_study.save()
    analysis = D.analyze_study(show_study)
    exact = analysis.by_test[analysis.by_test["condition"] == "exact"].set_index("test_index")
    # test 0 in "exact": regrets 0, 0, 0, 2.0 (the careless participant's 9.0 is excluded)
    assert exact.loc[0, "n"] == 4 and exact.loc[0, "mean_regret"] == pytest.approx(0.5)
    assert exact.loc[0, "share_optimal"] == pytest.approx(0.75) and exact.loc[0, "difficulty"] == "low"
    assert exact.loc[0, "sd_regret"] == pytest.approx(np.std([0, 0, 0, 2.0], ddof=1))
    assert list(analysis.by_test["test_index"].unique()) == [0, 1, 2]
    # the unfinished participant's one answer to test 0 is not analysed: det-euclidean has its four
    assert analysis.by_test.query("condition == 'det-euclidean' and test_index == 0")["n"].item() == 4
    levels = analysis.by_level[analysis.by_level["condition"] == "exact"].set_index("difficulty")
    assert list(analysis.by_level["difficulty"].unique()) == ["low", "high"]
    # low: tests 0 and 2, regrets 0, 0, 0, 2.0 and 1.5, 0, 0, 0.25: 3.75 / 8, five of eight optimal
    assert levels.loc["low", "n"] == 8 and levels.loc["low", "mean_regret"] == pytest.approx(3.75 / 8)
    assert levels.loc["low", "share_optimal"] == pytest.approx(5 / 8)
    assert levels.loc["high", "mean_regret"] == pytest.approx(0.125) and levels.loc["high", "n"] == 4
    written = R.write_report(analysis, tmp_path)
    assert {p.name for p in written["csv"]} >= {"by_test.csv", "by_level.csv"}
    page = written["html"].read_text()
    assert 'id="table-by-test"' in page and 'id="table-by-level"' in page


# Mean regrets' design for the paper's distance x determinism ANOVA: each participant's regrets in two tests
# (unbalanced, n = 3, 4, 2, 3 and 2 det-strategy participants for the additive model)
APPROX_REGRETS = {
    "det-reward": [[0, 1.5], [2.0, 0], [0.5, 0.5]],
    "det-euclidean": [[0, 0], [1.0, 0], [0, 0.5], [3.0, 1.0]],
    "prob-reward": [[2.5, 4.0], [1.0, 3.5]],
    "prob-euclidean": [[0.5, 2.0], [4.0, 0], [1.5, 1.5]],
    "det-strategy": [[0, 2.0], [1.0, 1.0]],
}


def _show_frames(regrets: dict):
    P, A = [], []
    for cond, people in regrets.items():
        for i, ways in enumerate(people):
            pid = f"{cond}#{i}"
            P.append({"participant_id": pid, "condition": cond, "attention_ok": True})
            A += [{"participant_id": pid, "test_index": t, "test_cluster": t, "test_difficulty": None,
                   "optimal": r == 0, "regret": float(r)} for t, r in enumerate(ways)]
    T = pd.DataFrame([{"condition": c, "position": 0, "cluster": 0} for c in regrets])
    return pd.DataFrame(P), pd.DataFrame(A), T


def test_the_papers_factorial_anovas_of_each_show_measure_by_hand():
    analysis = analyze_show(*_show_frames(APPROX_REGRETS), conditions=list(APPROX_REGRETS))
    for m in analysis.measures:
        per = {c: [np.mean(w) if m.column == "mean_regret" else np.mean([r == 0 for r in w]) for w in people]
               for c, people in APPROX_REGRETS.items()}
        square = ["det-reward", "det-euclidean", "prob-reward", "prob-euclidean"]
        additive, full = m.factorial
        for anova, conds, interaction in ((full, square, True), (additive, [*square, "det-strategy"], False)):
            y = np.array([v for c in conds for v in per[c]])
            a = np.array([c.split("-")[1] for c in conds for _ in per[c]])  # distance
            b = np.array([DETERMINISM[c.split("-")[0]] for c in conds for _ in per[c]])  # determinism
            names = {"a": "distance", "b": "determinism", **({"ab": "distance x determinism"} if interaction else {})}
            check_anova(anova, hand_anova(y, a, b, interaction=interaction), names)
    page = RS.render_fragment(analysis)
    assert page.count('class="anova" id="anova-mean_regret-') == 2
    assert page.count('class="anova" id="anova-share_optimal-') == 2
    assert any("distance x determinism" in line and "mean regret" in line for line in RS.headline(analysis))


def test_a_show_studys_closed_loop_checks_give_its_learning_curves(show_study, tmp_path):
    """Check answers stored as the flow stores a shown check (kind CHECK, item = its loop step, optimal and
    regret), with the examples before them: the report's learning curves count the included participants."""
    for pid, regrets in (("exact-0", [2.0, 0.0]), ("exact-1", [0.0, 0.0]), ("careless", [9.0, 9.0])):
        p = Participant.objects.get(study=show_study, platform_pid=pid)
        for k, regret in enumerate(regrets):
            LoopStep.objects.create(participant=p, index=2 * k, kind=LoopStep.EXAMPLE, env_id=5)
            LoopStep.objects.create(participant=p, index=2 * k + 1, kind=LoopStep.CHECK, env_id=6, question=k)
            _answer(p, 40 + k, StepKind.CHECK, 2 * k + 1, {"env_id": 6, "moves": ["exit"]}, correct=regret == 0,
                    regret=regret)
    analysis = D.analyze_study(show_study)
    curve = analysis.learning.set_index("check_number")
    assert list(curve["condition"]) == ["exact", "exact"]  # careless is excluded
    assert (curve.loc[1, "n"], curve.loc[1, "n_optimal"], curve.loc[1, "mean_regret"]) == (2, 1, 1.0)
    assert (curve.loc[2, "n_optimal"], curve.loc[2, "mean_examples"]) == (2, 2.0)
    written = R.write_report(analysis, tmp_path)
    assert "learning_curves.csv" in {p.name for p in written["csv"]}
    assert 'id="table-learning"' in written["html"].read_text()
    assert any(line.startswith("Learning curve exact") for line in R.headline(analysis))
