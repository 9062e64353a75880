"""Every exported participant has a status (complete / incomplete / excluded /
declined), keeping `status == complete` gives the app's own analysed set, the headline names every
group, and the CSV files are streamed (unchanged for complete participants but for the `status` column)."""
import csv
import io
import re
from pathlib import Path

import pytest
from django.core.management import CommandError, call_command
from django.http import StreamingHttpResponse
from django.urls import reverse

from studyapp.analysis import data as D
from studyapp.analysis import report as R
from studyapp.analysis import tables
from studyapp.data import exports
from studyapp.models import StepKind
from studyapp.participant import assignment, flow
from tests.conftest import answer_payload
from tests.studyapp import exports_before
from tests.studyapp.helpers import record

pytestmark = pytest.mark.django_db
DOCS = Path(__file__).resolve().parents[2] / "docs" / "study.md"


def rows(text):
    return list(csv.DictReader(io.StringIO(text)))


def answer_tests(p, n_tests):
    """Answer p's steps from where they stand until `n_tests` tests are answered (none past them)."""
    for step in flow.steps_for(p):
        if step.index < p.position:
            continue
        if step.kind == StepKind.TEST and step.item == n_tests:
            return p
        body = answer_payload(p, step)
        p = record(p, step.index, **body)
    return p


@pytest.fixture
def cohort(study, complete):
    """One participant of each kind the issue names, by platform id."""
    new = lambda pid: assignment.assign(study, "prolific", pid)  # noqa: E731
    complete(new("done"))
    answer_tests(new("three"), 3)  # stopped after 3 of the 6 tests
    complete(new("noattention"), stop_before=StepKind.ATTENTION)  # every test, not the attention check
    complete(new("inattentive"), attentive=False)  # failed the attention check, then finished
    complete(new("notest"), stop_before=StepKind.TEST)  # consent, instructions, training; no test
    new("noconsent")  # arrived, never agreed
    assignment.preview_participant(study.conditions.first())  # never exported nor analysed
    return study


EXPECTED = {"done": "complete", "three": "incomplete", "noattention": "incomplete", "inattentive": "excluded",
            "notest": "incomplete", "noconsent": "declined"}


def test_status_column_in_both_files(cohort):
    wide = {r["platform_pid"]: r for r in rows(exports.wide_csv(cohort))}
    assert {pid: r["status"] for pid, r in wide.items()} == EXPECTED
    assert (wide["three"]["n_tests_answered"], wide["noattention"]["n_tests_answered"]) == ("3", "6")
    # an incomplete participant's mean is not offered as the paper's measure; their answers are all there
    assert [wide[pid]["mean_confidence_score"] for pid in ("three", "noattention", "notest", "noconsent")] == [""] * 4
    assert [wide["three"][f"test{j}_confidence_score"] for j in range(4)] == ["6", "6", "6", ""]
    assert wide["done"]["mean_confidence_score"] == "6.0" and wide["inattentive"]["mean_confidence_score"] == "6.0"
    long = rows(exports.long_csv(cohort))
    by_pid = {}
    for r in long:
        by_pid.setdefault(r["platform_pid"], set()).add(r["status"])
    # the declined participant stored no answer, so has no long row
    assert by_pid == {pid: {s} for pid, s in EXPECTED.items() if pid != "noconsent"}


def test_keeping_status_complete_gives_the_apps_analysed_set(cohort):
    wide = rows(exports.wide_csv(cohort))
    kept = {r["participant_id"] for r in wide if r["status"] == "complete"}
    table = D.analyze_study(cohort).participants
    assert kept == set(tables.included(table)["participant_id"]) and len(kept) == 1
    # and the analysis's own table carries the same status for everyone it lists
    everyone = D.analyze_study(cohort, include_incomplete=True).participants
    assert dict(zip(everyone["participant_id"], everyone["status"], strict=True)) == {r["participant_id"]: r["status"]
                                                                        for r in wide}


def test_dictionary_says_how_to_choose_the_analysed_set():
    d = {(r["file"], r["column"]): r["description"] for r in rows(exports.dictionary_csv())}
    for f in ("long", "wide"):
        status = d[(f, "status")]
        assert "Analyse only status == complete" in status
        assert all(s in status for s in ("complete:", "incomplete:", "excluded:", "declined:"))
        assert "drop from analysis" not in d[(f, "excluded")] and "use status" in d[(f, "excluded")]
    assert "empty unless every test was answered" in d[("wide", "mean_confidence_score")]
    # docs/study.md's dictionary lists the same columns, the new one included
    doc = DOCS.read_text()
    for column, _ in exports.LONG_COLUMNS + exports.WIDE_COLUMNS:
        assert f"| `{re.sub(r'^test[0-9]+_', 'test<j>_', column)}` |" in doc, column
    assert "| `declined` |" in doc and "| `incomplete` |" in doc


def test_include_incomplete_headline_names_every_group(cohort, tmp_path):
    analysis = D.analyze_study(cohort, include_incomplete=True)
    line = R.headline(analysis)[0]
    assert line.startswith("6 participants: 1 complete, 2 incomplete (some tests answered), "
                           "1 incomplete (no test answered), 1 excluded (attention), 1 declined (no consent); "
                           "3 analysed;"), line
    groups = R.participant_groups(analysis.participants)
    assert sum(n for _, n in groups) == len(analysis.participants) == 6
    out = io.StringIO()
    call_command("analyze", cohort.slug, "--out", str(tmp_path / "a"), stdout=out)
    text = out.getvalue()
    assert "2 participants: 1 complete, 1 excluded (attention); 1 analysed;" in text, text
    assert "4 unfinished participants left out" in text


def no_store(response) -> bool:
    return "no-store" in {d.strip() for d in response.get("Cache-Control", "").split(",")}


def test_export_views_stream_without_caching(staff_client, cohort):
    for kind, whole in (("long", exports.long_csv), ("wide", exports.wide_csv)):
        r = staff_client.get(reverse("dashboard_export", args=[cohort.slug, kind]))
        assert isinstance(r, StreamingHttpResponse) and r.status_code == 200
        assert no_store(r) and r["Content-Type"] == "text/csv; charset=utf-8"
        assert r.getvalue().decode() == whole(cohort)
    assert no_store(staff_client.get(reverse("dashboard_export", args=[cohort.slug, "dictionary"])))


def test_paging_does_not_split_or_drop_participants(cohort, monkeypatch):
    whole = exports.long_csv(cohort), exports.wide_csv(cohort)
    monkeypatch.setattr(exports, "PAGE", 2)  # 6 participants over 3 pages
    assert (exports.long_csv(cohort), exports.wide_csv(cohort)) == whole


def test_unchanged_against_the_previous_exporter(cohort):
    """The files as the previous, object-at-a-time exporter (exports_before.py) wrote them on the same
    data: the long file row for row but for `status`; the wide file the same for complete (and
    excluded) participants, and for incomplete ones only their mean score is now left empty."""
    def without_status(text):
        return [{k: v for k, v in r.items() if k not in exports_before.NEW} for r in rows(text)]

    assert without_status(exports.long_csv(cohort)) == rows(exports_before.long_csv(cohort))
    old = {r["platform_pid"]: r for r in rows(exports_before.wide_csv(cohort))}
    new = {r["platform_pid"]: r for r in without_status(exports.wide_csv(cohort))}
    assert set(old) == set(new) == set(EXPECTED)
    for pid, status in EXPECTED.items():
        if status in ("complete", "excluded"):
            assert new[pid] == old[pid], pid
        else:
            assert {**new[pid], "mean_confidence_score": ""} == {**old[pid], "mean_confidence_score": ""}, pid
            assert new[pid]["mean_confidence_score"] == ""
    assert old["three"]["mean_confidence_score"] == "6.0"  # what the issue reported: an analysable-looking mean


def test_export_command_writes_the_same_files(cohort, tmp_path):
    for kind, whole in (("long", exports.long_csv), ("wide", exports.wide_csv)):
        path = tmp_path / f"{kind}.csv"
        call_command("export_study", cohort.slug, kind, "--out", str(path), stderr=io.StringIO())
        assert path.read_bytes().decode() == whole(cohort)
    printed = io.StringIO()
    call_command("export_study", cohort.slug, "wide", stdout=printed)
    assert printed.getvalue() == exports.wide_csv(cohort)
    with pytest.raises(CommandError, match="no study 'nope'"):
        call_command("export_study", "nope", "wide")
