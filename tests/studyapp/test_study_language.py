"""A study's language (Study.language, studyapp/language.py): its participants read it whatever their browser
asks for, its researchers keep theirs, the JavaScript catalog speaks it, and an unknown language is refused
in one line."""
from __future__ import annotations

import pytest
from django.urls import reverse

from studyapp.i18n import participant_texts
from studyapp.models import Participant
from studyapp.participant.assignment import assign
from studyapp.researcher.specschema import SpecError
from studyapp.trajectories import study_domain
from tests.studyapp.helpers import design_form, step_url


@pytest.fixture
def german(make_study):
    return make_study(slug="deutsch", language="de")


def test_participants_read_the_studys_language_whatever_their_browser_says(german, study, client):
    p = assign(german, Participant.PROLIFIC, "de1")
    r = client.get(step_url(p), HTTP_ACCEPT_LANGUAGE="en-GB,en;q=0.9")
    page = r.content.decode()
    assert '<html lang="de">' in page and r["Content-Language"] == "de"
    assert "Einverständnis" in page or "Einwilligung" in page  # the consent page, in German
    english = assign(study, Participant.PROLIFIC, "en1")
    r = client.get(step_url(english), HTTP_ACCEPT_LANGUAGE="de-DE,de;q=0.9")
    assert '<html lang="en">' in r.content.decode() and r["Content-Language"] == "en"


def test_researchers_keep_their_language(german, staff_client):
    page = staff_client.get(reverse("dashboard_study", args=[german.slug]), HTTP_ACCEPT_LANGUAGE="de").content.decode()
    assert "Participant link" in page and '<html lang="en-us">' in page  # settings.LANGUAGE_CODE


def test_the_javascript_catalog_speaks_the_studys_language(german, study, client):
    r = client.get(reverse("jsi18n", args=[german.slug]))
    assert r.status_code == 200 and "javascript" in r["Content-Type"] and r["Content-Language"] == "de"
    assert "django.gettext" in r.content.decode() or "gettext" in r.content.decode()
    assert client.get(reverse("jsi18n", args=[study.slug]))["Content-Language"] == "en"
    page = client.get(step_url(assign(german, Participant.PROLIFIC, "js1"))).content.decode()
    assert f'<script src="{reverse("jsi18n", args=[german.slug])}"></script>' in page


def test_the_robots_texts_are_looked_up_in_the_active_language(german):
    from django.utils import translation  # noqa: PLC0415

    domain = study_domain(german)
    with translation.override("en"):
        assert participant_texts(domain) == domain.texts  # English: the domain's own words
    with translation.override("de"):
        german_texts = participant_texts(domain)
    assert german_texts.attention_correct == domain.texts.attention_correct  # stored values never translated
    assert [v for v, _ in german_texts.attention_choices] == [v for v, _ in domain.texts.attention_choices]
    assert german_texts.instructions != domain.texts.instructions  # every paragraph has its German


def test_an_unknown_language_is_a_one_line_refusal(make_study, tiny_table, db):
    with pytest.raises(SpecError, match="'language'") as refused:
        make_study(slug="klingon", language="tlh")
    assert "\n" not in str(refused.value)
    form = design_form(tiny_table, language="tlh")
    assert not form.is_valid()
    (message,) = form.errors["language"]
    assert "\n" not in message
    form = design_form(tiny_table, language="de")
    assert form.is_valid(), form.errors
    assert form.cleaned_data["job"]["language"] == "de"
