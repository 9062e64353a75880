"""A German study's participant pages are German: every page a participant of a driving study and of a
delivery-yard study can see (each step, the review after a failed comprehension check, the form errors of bad
posts, the ended, declined, closed, refused and error pages) shows no English text of the German catalogs
(locale/de/LC_MESSAGES, read by tests/studyapp/catalogs.py) that has a German translation; an English study's
pages stay English."""
from __future__ import annotations

import html
import os
import re
from pathlib import Path

import pytest
from django.conf import settings
from django.urls import reverse

from studyapp import status
from studyapp.models import Participant, StepKind, Study
from studyapp.participant import flow, outcomes
from studyapp.participant.assignment import assign
from studyapp.participant.comprehension import questions_of
from studyapp.researcher.studies import build_study
from teaching.api import get_domain
from teaching.core.build import build_table
from teaching.core.table import TrajectoryTable
from tests.conftest import answer_payload, built_once
from tests.studyapp.catalogs import catalog_pieces, english_pieces
from tests.studyapp.helpers import answer_url, step_url
from tests.studyapp.test_show_way_flow import _wall_walk
from tests.studyapp.test_stimuli import real_spec, smallest_preset

pytestmark = pytest.mark.django_db

# words any German page of a study shows somewhere (its header, buttons, headings)
GERMAN_WORDS = re.compile(r"\b(Sie|Ihre?[mnrs]?|und|der|die|das|[Bb]itte|zu|von|nicht|Weiter)\b")


@pytest.fixture(scope="module")
def english_texts() -> list[str]:
    """The English texts (of two words or more) a German page must not show (tests/studyapp/catalogs.py)."""
    pieces = english_pieces("de")
    assert len(pieces) > 150  # the whole catalog, not a fragment of it
    return sorted(pieces)


def visible_text(page: str) -> str:
    """What a reader sees of `page`: no scripts, styles or tags, entities decoded, whitespace collapsed."""
    page = re.sub(r"<(script|style)\b.*?</\1>", " ", page, flags=re.S | re.I)
    page = re.sub(r"<[^>]+>", " ", page)
    return " ".join(html.unescape(page).split())


class Pages:
    """Every page fetched, by name, for the checks."""

    def __init__(self, client):
        self.client, self.seen = client, {}

    def get(self, name, url, data=None, status_code=200):
        r = self.client.get(url, data or {})
        assert r.status_code == status_code, (name, r.status_code)
        self.seen[name] = r.content.decode()
        return r

    def post(self, name, url, data, status_code, **extra):
        r = self.client.post(url, data, **extra)
        assert r.status_code == status_code, (name, r.status_code)
        if status_code != 302:
            self.seen[name] = r.content.decode()
        return r


def wrong_answers(participant) -> dict:
    """A comprehension attempt that misses every question (the first choice that is not right)."""
    return {f"q{i}": [str(next(k for k in range(len(q["choices"])) if k not in q["right"]))]
            for i, q in enumerate(questions_of(participant.study))}


def wall_way(participant, step) -> str:
    """A way from the start of show test `step` that walks into a wall or off the grid (the page's field)."""
    test = flow.question_of(participant, step.kind, step.item)
    return " ".join(_wall_walk(get_domain(participant.study.domain), test))


def walk(client, study: Study) -> dict[str, str]:
    """Every page a participant of `study` may see, in order: each step, the comprehension check's review,
    form errors of bad posts (in a show study a way into a wall too), then the pages of ending, declining,
    refusal, closing and errors."""
    pages = Pages(client)
    slug = study.slug
    pages.get("mturk preview", reverse("entry", args=[slug]), {"assignmentId": "ASSIGNMENT_ID_NOT_AVAILABLE"})
    assert client.get(reverse("entry", args=[slug]), {"PROLIFIC_PID": "de1", "STUDY_ID": "S",
                                                      "SESSION_ID": "X"}).status_code == 302
    p = Participant.objects.get(study=study, platform_pid="de1")
    while True:
        p.refresh_from_db()
        step = flow.current_step(p)
        name = step.kind.value if step.item is None else f"{step.kind.value} {step.item}"
        pages.get(name, step_url(p))
        if step.kind == StepKind.DONE:
            break
        if step.kind == StepKind.COMPREHENSION and not p.comprehension_attempts.exists():
            pages.post("comprehension unanswered", answer_url(p, step.index), {"attempt": "1"}, 400)
            pages.post("comprehension failed", answer_url(p, step.index), {"attempt": "1", **wrong_answers(p)}, 302)
            pages.get("comprehension review", step_url(p))
            pages.get("comprehension again", step_url(p), {"questions": "1"})
        if step.kind == StepKind.TEST and step.item == 0:
            pages.post("test without an answer", answer_url(p, step.index), {}, 400)
            if study.test_kind == Study.SHOW:  # the world's reason for refusing a way is a page text too
                pages.post("test with a way into a wall", answer_url(p, step.index), {"moves": wall_way(p, step)}, 400)
        if step.kind == StepKind.ATTENTION:
            pages.post("attention without an answer", answer_url(p, step.index), {}, 400)
        if step.kind == StepKind.DEMOGRAPHICS:
            pages.post("demographics without an age", answer_url(p, step.index), {"gender": "female"}, 400)
            pages.post("demographics with a bad age", answer_url(p, step.index),
                       {"gender": "female", "age": "7"}, 400)
        pages.post(f"answer to {name}", answer_url(p, step.index), answer_payload(p, step), 302)
    pages.post("no such step", answer_url(p, 99), {"ack": "1"}, 404)
    # refused by the middleware before any view runs
    pages.post("request too large", answer_url(p, 99), {"ack": "1"}, 413,
               CONTENT_LENGTH=str(settings.MAX_REQUEST_BODY + 1))
    pages.post("NUL in an answer", answer_url(p, 99), {"ack": "1\x00"}, 400)
    pages.post("too many fields", answer_url(p, 99),
               {f"f{i}": "1" for i in range(settings.DATA_UPLOAD_MAX_NUMBER_FIELDS + 1)}, 400)
    pages.get("moved on", step_url(p), {"moved": "1"})

    for outcome in (status.TIMED_OUT, status.SCREENED_OUT):
        ended = assign(study, Participant.PROLIFIC, f"ended-{outcome}")
        assert outcomes.end(ended, outcome)
        pages.get(f"ended {outcome}", step_url(ended))
    returned = assign(study, Participant.PROLIFIC, "returned")
    outcomes.mark_returned(study, ["returned"])
    pages.get("ended returned", step_url(returned))

    declining = assign(study, Participant.ANONYMOUS, "")
    pages.post("declined", answer_url(declining, 0), {"consent": "no"}, 200)
    Study.objects.filter(pk=study.pk).update(min_screen_width=1200)
    refused = assign(study, Participant.ANONYMOUS, "")
    pages.get("consent with device rules", step_url(refused))
    pages.post("device refused", answer_url(refused, 0),
               {"consent": "yes", "screen_width": "800", "device": "computer"}, 403)
    pages.get("bad platform ids", reverse("entry", args=[slug]), {"PROLIFIC_PID": "x" * 101}, 400)
    Study.objects.filter(pk=study.pk).update(is_open=False)
    pages.get("closed", reverse("entry", args=[slug]), {"PROLIFIC_PID": "late"}, 403)
    Study.objects.filter(pk=study.pk).update(completion_code="")
    pages.get("no completion code", reverse("entry", args=[slug]), {"PROLIFIC_PID": "later"}, 503)
    return pages.seen


def assert_german(pages: dict[str, str], english_texts: list[str]) -> None:
    if os.environ.get("GERMAN_PAGES_DUMP"):  # to read the pages as a participant does
        Path(os.environ["GERMAN_PAGES_DUMP"]).write_text(
            "\n\n".join(f"== {name}\n{visible_text(page)}" for name, page in pages.items()), encoding="utf-8")
    assert len(pages) > 20
    for name, page in pages.items():
        assert '<html lang="de">' in page, name
        text = visible_text(page)
        assert GERMAN_WORDS.search(text), (name, text)
        left = [english for english in english_texts if english in text]
        assert not left, (name, left)


@pytest.fixture
def german_driving(make_study):
    return make_study(slug="de-car", language="de", comprehension_check=True, comprehension_attempts=3,
                      time_limit_minutes=30, screened_out_code="SCRN2026", timed_out_code="TIME2026",
                      bonus_per_correct=0.1, bonus_currency="GBP")


@pytest.fixture
def german_yard(db, tmp_path_factory):
    domain = get_domain("gridworld")
    preset = smallest_preset(domain)
    out = built_once(tmp_path_factory, f"{preset.name}-table", lambda out: build_table(preset, out))
    spec = real_spec(TrajectoryTable.load(out), out, slug="de-yard")
    spec.update(language="de", comprehension_check=True, comprehension_attempts=3, time_limit_minutes=30,
                screened_out_code="SCRN2026", timed_out_code="TIME2026")
    return build_study(spec)


def test_a_german_driving_studys_pages_are_german(client, german_driving, english_texts):
    pages = walk(client, german_driving)
    assert_german(pages, english_texts)
    assert "Einwilligung zur Teilnahme" in pages["consent"] and "Abschlusscode" in pages["done"]
    assert "autonome Auto" in visible_text(pages["instructions"])
    assert "Bitte geben Sie Ihr Alter an." in pages["demographics without an age"]
    assert "Die Anfrage ist zu groß" in pages["request too large"]
    assert "Ziel in dieser Situation" in pages["training 0"]
    assert "Bonus" in pages["done"] and re.search(r"\d+,\d\d\u00a0£", pages["done"])


def test_a_german_delivery_yard_studys_pages_are_german(client, german_yard, english_texts):
    pages = walk(client, german_yard)
    assert_german(pages, english_texts)
    assert "Lieferroboter" in visible_text(pages["instructions"]) and "Abschlusscode" in pages["done"]
    assert "Kontrollfrage" not in pages["test 0"] and "Frage 1 von" in pages["test 0"]


def test_an_english_studys_pages_stay_english(client, make_study, english_texts):
    study = make_study(slug="en-car", comprehension_check=True, comprehension_attempts=3, time_limit_minutes=30,
                       screened_out_code="SCRN2026", timed_out_code="TIME2026")
    pages = walk(client, study)
    german_pieces = catalog_pieces("de")[1]
    shown = set()
    for name, page in pages.items():
        assert '<html lang="en">' in page, name
        text = visible_text(page)
        assert not [g for g in german_pieces if g in text], name
        shown.update(english for english in english_texts if english in text)
    assert len(shown) > 60  # the check of the German pages would see English text
    assert "Consent to take part" in pages["consent"] and "I agree, start the study" in pages["consent"]
    assert "Your completion code is" in visible_text(pages["done"])
    assert "Please enter your age." in pages["demographics without an age"]
    assert "The request contains a NUL character" in pages["NUL in an answer"]
    assert "Goal in this situation" in pages["training 0"]
    assert "You have 2 more tries." in visible_text(pages["comprehension review"])
    assert "This study had to be finished within 30 minutes" in visible_text(pages["ended timed_out"])


def test_a_refusal_before_a_view_is_in_the_researchers_language_off_the_participant_pages(client, german_driving):
    too_large = {"CONTENT_LENGTH": str(settings.MAX_REQUEST_BODY + 1)}
    researcher = client.post(reverse("dashboard_toggle", args=[german_driving.slug]), {}, **too_large)
    participant = client.post(reverse("entry", args=[german_driving.slug]), {}, **too_large)
    assert researcher.status_code == participant.status_code == 413
    assert "The request is too large" in researcher.content.decode()
    assert "Die Anfrage ist zu groß" in participant.content.decode()
