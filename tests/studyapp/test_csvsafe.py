"""Formula neutralisation in the CSV exports covers fullwidth and other compatibility forms:
a spreadsheet folds ``＝`` into ``=`` and runs the cell."""
import csv
import io

import pytest
from django.urls import reverse

from studyapp.guards.csvsafe import neutralise
from studyapp.participant import assignment

FORMULAS = [
    "=1+1", "+1", "-2", "@SUM(A1)", "\tTAB", "\rCR", "\nLF",
    "\uff1dHYPERLINK(\"http://x\")",  # fullwidth =
    "\uff0bcmd", "\uff0d2", "\uff20SUM(A1)",  # fullwidth + - @
    "\ufe66cmd", "\ufe62cmd", "\ufe63cmd", "\ufe6bcmd",  # small forms of = + - @
    "\u22121",  # MINUS SIGN (not folded by NFKC)
    " =1+1", "\u3000\uff1d1",  # behind a space, an ideographic space
    "\u200b=1+1", "\ufeff=1+1",  # behind a zero-width space, a BOM
]


@pytest.mark.parametrize("text", FORMULAS)
def test_each_formula_start_gets_a_quote(text):
    assert neutralise(text) == "'" + text


@pytest.mark.parametrize("value", ["ok", "A=1", "5e8a-12", "", "   ", "\u3000name", -5, -0.5, 3, None])
def test_plain_text_and_numbers_are_untouched(value):
    assert neutralise(value) == value


@pytest.mark.django_db
def test_a_fullwidth_id_is_neutralised_in_the_export(staff_client, study, complete):
    pid = "\uff1dHYPERLINK(\"http://x\")"
    p = complete(assignment.assign(study, "prolific", pid, platform_session_id="\uff0b1"))
    body = staff_client.get(reverse("dashboard_export", args=[study.slug, "wide"])).getvalue().decode()
    row = next(r for r in csv.DictReader(io.StringIO(body)) if r["participant_id"] == str(p.pk))
    assert (row["platform_pid"], row["platform_session_id"]) == ("'" + pid, "'\uff0b1")
    long = staff_client.get(reverse("dashboard_export", args=[study.slug, "long"])).getvalue().decode()
    pids = {r["platform_pid"] for r in csv.DictReader(io.StringIO(long)) if r["participant_id"] == str(p.pk)}
    assert pids == {"'" + pid}
