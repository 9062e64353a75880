"""A study on a world from a file in its participants' language: a German study of the shipped taxi shows the
file's German (its title, cell label and object's name) and none of its English on any page, and says why a
shown way is refused in German; an English study of it stays English; a German study of a world whose file
lacks German is refused in one line (and the designer says so under the language), while every registered
domain can run a German study; a world's own comprehension questions are the study's, in its language."""
from __future__ import annotations

import contextlib
import json
import re
import tomllib

import pytest
from django.utils import translation

from precompute.models import Job
from studyapp.i18n import language_problem, participant_texts, untranslated_texts
from studyapp.models import Participant, StepKind, Study
from studyapp.participant import flow
from studyapp.participant.assignment import assign
from studyapp.participant.comprehension import questions_of
from studyapp.researcher.specschema import SpecError
from studyapp.researcher.studies import build_study, spec_from_teach
from teaching.api import domain_names, get_domain
from teaching.core.domain import register
from teaching.domains import WORLDS
from teaching.domains._grid.filedomain import FileGridDomain
from teaching.domains._grid.worldfile import parse_world
from tests.studyapp.catalogs import catalog_pieces, english_pieces
from tests.studyapp.helpers import design_post, step_url
from tests.studyapp.test_german_pages import assert_german, visible_text, walk
from tests.teaching.domains.worlds.shipped import NAMES, shipped, teach_show

pytestmark = pytest.mark.django_db

TAXI = (WORLDS / "taxi.toml").read_text()
ENGLISH = re.compile(r"\b(Augmented taxi|toll|passenger)\b", re.I)  # the taxi file's own English texts
# the taxi's own comprehension questions, and their German, appended to its [translations.de] (the file's last)
QUESTIONS = '''"What does the taxi have to do?" = "Was muss das Taxi tun?"
"Bring its passenger to the corner" = "Seinen Fahrgast in die Ecke bringen"
"Race another taxi" = "Mit einem anderen Taxi um die Wette fahren"
"Park in the middle" = "In der Mitte parken"

[[texts.comprehension]]
question = "What does the taxi have to do?"
choices = ["Bring its passenger to the corner", "Race another taxi", "Park in the middle"]
right = [1]
'''


@contextlib.contextmanager
def taxi_from(text: str):
    """The taxi registered from `text`, a version of its file with other texts, in place of the shipped one
    for the duration: the same world, so the taxi's table is its table (texts decide no trajectory)."""
    domain = FileGridDomain(parse_world(tomllib.loads(text), "taxi.toml"))
    shipped_taxi = get_domain("taxi")
    register(domain.name, lambda: domain)
    try:
        yield domain
    finally:
        register("taxi", lambda: shipped_taxi)


@pytest.fixture
def taxi_teach(tmp_path_factory):
    """The taxi's tiny table and `teach --tests show` output (built once per run)."""
    with shipped("taxi") as domain:
        return teach_show(tmp_path_factory, domain)


def taxi_study(teach_dir, slug: str, **fields) -> Study:
    spec = spec_from_teach(teach_dir)
    spec.update(slug=slug, completion_code="TAXI2026", comprehension_check=True, comprehension_attempts=3,
                time_limit_minutes=30, screened_out_code="SCRN2026", timed_out_code="TIME2026", **fields)
    return build_study(spec)


def test_a_german_taxi_studys_pages_show_the_files_german_and_none_of_its_english(client, taxi_teach):
    with shipped("taxi") as domain:
        study = taxi_study(taxi_teach[1], "de-taxi", language="de")
        assert study.test_kind == Study.SHOW
        pages = walk(client, study)
        assert_german(pages, sorted(english_pieces("de")))
        for name, page in pages.items():
            assert not ENGLISH.search(visible_text(page)), (name, ENGLISH.search(visible_text(page)))
        assert "Erweitertes Taxi" in visible_text(pages["consent"])  # the title, filled into the default consent
        assert "Erweitertes Taxi" in visible_text(pages["comprehension"])  # and into a default question
        legend = visible_text(pages["training 0"])
        assert "Maut" in legend and "Fahrgast" in legend  # the cell's label and the object's name
        assert "Erweitertes Taxi" in visible_text(pages["mturk preview"])  # the summary
        # the show page's script names the object as the page does (its status line says what was delivered)
        rules = json.loads(re.search(r'id="show-rules"[^>]*>(.*?)</script>', pages["test 0"], re.S)[1])
        assert rules["object"] == "Fahrgast"
        # a way into a wall is refused with the world's reason in German
        refused = visible_text(pages["test with a way into a wall"])
        assert re.search(r"Dieser Weg kann nicht abgeschickt werden \(Schritt \d+: „nach (oben|unten|links|rechts)“ "
                         r"ist bei \[\d+, \d+\] nicht möglich\)", refused), refused
        with translation.override("de"):
            texts = participant_texts(domain)
        assert texts.title == "Erweitertes Taxi" and [e.label for e in texts.legend][2:] == [
            "Fahrgast", "Maut", "hier startet der Roboter", "Ziel für: Fahrgast"]  # the letters' legend last


def test_an_english_taxi_studys_pages_stay_english(client, taxi_teach):
    with shipped("taxi") as domain:
        study = taxi_study(taxi_teach[1], "en-taxi")
        pages = walk(client, study)
        german = catalog_pieces("de")[1] | {"Erweitertes Taxi", "Maut", "Fahrgast"}
        for name, page in pages.items():
            assert '<html lang="en">' in page, name
            assert not [g for g in german if g in visible_text(page)], name
        with translation.override("en"):
            assert participant_texts(domain) == domain.texts  # the file's own words
        assert "grid world (Augmented taxi)" in visible_text(pages["consent"])
        legend = visible_text(pages["training 0"])
        assert re.search(r"\btoll\b", legend) and re.search(r"\bpassenger\b", legend)
        rules = json.loads(re.search(r'id="show-rules"[^>]*>(.*?)</script>', pages["test 0"], re.S)[1])
        assert rules["object"] == "passenger"
        assert re.search(r"This way cannot be submitted \(action \d+: (up|down|left|right) is not possible at "
                         r"\[\d+, \d+\]\)", visible_text(pages["test with a way into a wall"]))


def test_a_german_study_of_a_world_without_german_is_refused_in_one_line(taxi_teach, settings, staff_client):
    table_dir, teach_dir = taxi_teach
    without = TAXI[:TAXI.index("[translations.de]")]
    with taxi_from(without):
        with pytest.raises(SpecError) as refused:
            taxi_study(teach_dir, "de-taxi-untranslated", language="de")
        message = str(refused.value)
        assert "\n" not in message
        assert message == ("a study in German needs every text of the robot 'taxi' in German, and these have no "
                           "translation: 'Augmented taxi', 'passenger', 'toll'; add them under [translations.de] "
                           "in the world file taxi.toml (docs/gridworlds.md)")
        assert not Study.objects.filter(slug="de-taxi-untranslated").exists()
        english = taxi_study(teach_dir, "en-taxi-untranslated")
        assert english.language == "en" and english.opening_problems() == []  # English needs no translation
        Study.objects.filter(pk=english.pk).update(language="de")  # as the admin may, after creation
        english.refresh_from_db()
        assert english.opening_problems() == [message]  # so it is not opened in German
        settings.TABLES_DIR = table_dir.parent  # the designer, which says it under the language
        post = design_post(table_dir, language="de", test_kind="show")  # the taxi's tests show the way
        page = staff_client.post("/precompute/design/", post)
        assert page.status_code == 200 and page.context["form"].errors["language"] == [message]
        assert not Job.objects.exists()
    with taxi_from(without + '[translations.de]\n"Augmented taxi" = "Erweitertes Taxi"\n"toll" = "Maut"\n'):
        assert untranslated_texts(get_domain("taxi"), "de") == ["passenger"]  # one left is one too many
    with shipped("taxi"):
        assert staff_client.post("/precompute/design/", post).status_code == 302
    assert Study.objects.get(slug="designed").language == "de"


@pytest.mark.parametrize("name", [*domain_names(), *NAMES])
def test_every_domain_has_every_text_in_german(name):
    """Every registered domain (the Python robots, translated in the catalogs) and every shipped world (in
    its own file) can run a German study."""
    with shipped(name) if name in NAMES else contextlib.nullcontext():
        domain = get_domain(name)
        assert untranslated_texts(domain, "de") == [] and language_problem(domain, "de") == ""
        with translation.override("de"):
            german = participant_texts(domain)
        assert german.title != domain.texts.title or name == "skateboard"  # "Skateboard" in both


def test_a_worlds_own_comprehension_questions_are_the_studys_in_its_language(client, taxi_teach):
    with taxi_from(TAXI + QUESTIONS):
        german = taxi_study(taxi_teach[1], "de-taxi-questions", language="de")
        english = taxi_study(taxi_teach[1], "en-taxi-questions")
        assert questions_of(english) == [{"question": "What does the taxi have to do?", "right": [0], "choices": [
            "Bring its passenger to the corner", "Race another taxi", "Park in the middle"]}]
        for study, want, default in (
                (german, ("Was muss das Taxi tun?", "Seinen Fahrgast in die Ecke bringen"), "Was sehen Sie zuerst?"),
                (english, ("What does the taxi have to do?", "Bring its passenger to the corner"),
                 "What will you watch first?")):
            p = assign(study, Participant.PROLIFIC, f"{study.slug}-1")
            Participant.objects.filter(pk=p.pk).update(
                position=next(s.index for s in flow.steps_for(p) if s.kind == StepKind.COMPREHENSION))
            page = visible_text(client.get(step_url(p)).content.decode())
            assert all(text in page for text in want) and default not in page, page

