"""A world file's own participant texts: [texts] takes only what the domain reads (a typo is named), its
comprehension questions replace the default ones, and [translations.<language>] gives each of the file's
own texts in another language, each mistake in one line naming the field; the shipped worlds have German
for every text of theirs; a refused way says why in English and can be said in another language."""
from __future__ import annotations

import pytest

from teaching.core.i18n import TranslatableError
from teaching.domains import WORLDS
from teaching.domains._grid.filedomain import world_domain
from teaching.domains._grid.fileworld import ReplayError
from teaching.domains._grid.worldfile import WorldFileError
from tests.teaching.domains.worlds import key_room

# the key room with a title, a label, texts, comprehension questions of its own and their German
TEXTS = r'''
[texts]
summary = "you watch a robot fetch a key"
instructions = ["You will watch {n_training} example{training_plural} of a robot fetching a key.",
                "Then you answer {n_tests} question{tests_plural}."]
comprehension = [
  { question = "What does the robot fetch?", choices = ["A key", "A ball", "A cup"], right = [1] },
  { question = "Which are in the room?", choices = ["Puddles", "Sand", "Lava"], right = [2, 1] },
]

[translations.de]
"Key room" = "Schlüsselraum"
"a puddle" = "eine Pfütze"
"sand" = "Sand"
"you watch a robot fetch a key" = "Sie sehen einem Roboter zu, der einen Schlüssel holt"
"You will watch {n_training} example{training_plural} of a robot fetching a key." = """\
  Sie sehen {n_training} Beispiele eines Roboters, der einen Schlüssel holt."""
"What does the robot fetch?" = "Was holt der Roboter?"
'''


def _world(tmp_path, extra: str = TEXTS, text: str | None = None):
    path = tmp_path / "world.toml"
    text = key_room.PATH.read_text() if text is None else text
    text = text.replace('name = "key-room"\n', 'name = "key-room"\ntitle = "Key room"\n')
    path.write_text(text.replace('colour = "#1d4ed8"\n', 'colour = "#1d4ed8"\nlabel = "a puddle"\n') + extra)
    return world_domain(path)


def test_a_files_texts_questions_and_translations_are_the_domains(tmp_path):
    domain = _world(tmp_path)
    world = domain.world
    assert world.participant_texts == (
        "Key room", "a puddle", "sand", "you watch a robot fetch a key",
        "You will watch {n_training} example{training_plural} of a robot fetching a key.",
        "Then you answer {n_tests} question{tests_plural}.", "What does the robot fetch?", "A key", "A ball",
        "A cup", "Which are in the room?", "Puddles", "Sand", "Lava")
    assert domain.translations == {"de": {
        "Key room": "Schlüsselraum", "a puddle": "eine Pfütze", "sand": "Sand",
        "you watch a robot fetch a key": "Sie sehen einem Roboter zu, der einen Schlüssel holt",
        "You will watch {n_training} example{training_plural} of a robot fetching a key.":
            "Sie sehen {n_training} Beispiele eines Roboters, der einen Schlüssel holt.",
        "What does the robot fetch?": "Was holt der Roboter?"}}
    texts = domain.texts
    assert texts.summary == "you watch a robot fetch a key"
    assert [e.label for e in texts.legend if not e.letter][-2:] == ["a puddle", "sand"]
    # then the letters the canvas writes: the start, and the key to reach (no object, so no destination)
    assert [(e.letter, e.label) for e in texts.legend if e.letter] == [
        ("S", "where the robot starts"), ("G", "a goal: reaching it ends the way")]
    # the file's questions replace the default ones; right: 1-based in the file, 0-based in the domain
    assert [(q.text, q.choices, q.right) for q in texts.comprehension] == [
        ("What does the robot fetch?", ("A key", "A ball", "A cup"), (0,)),
        ("Which are in the room?", ("Puddles", "Sand", "Lava"), (0, 1))]
    # texts and translations decide no trajectory: a table built before them stays the world's
    assert domain.fingerprint() == key_room.DOMAIN.fingerprint()
    # without questions of its own, a world asks the default ones
    plain = _world(tmp_path, extra="")
    assert plain.translations == {}
    assert [q.text for q in plain.texts.comprehension] == ["What will you watch first?",
                                                            "What are the questions after the examples about?"]


@pytest.mark.parametrize("extra, message", [
    ('\n[texts]\nsumary = "x"\n', "world.toml: texts.sumary: not a field of this table (one of summary, consent, "
     "instructions, attention_question, watch, question, title, comprehension); did you mean 'summary'?"),
    ('\n[texts]\nsummary = 3\n', "world.toml: texts.summary: expected a non-empty text, got 3"),
    ('\n[texts]\nwatch = "  "\n', "world.toml: texts.watch: expected a non-empty text, got '  '"),
    ('\n[texts]\ninstructions = "Watch."\n', "world.toml: texts.instructions: expected a list of paragraphs (texts), "
     "got 'Watch.'"),
    ('\n[texts]\ninstructions = ["Watch {n_examples} examples."]\n', "world.toml: texts.instructions[0]: braces only "
     "around what is filled in per participant: {n_training}, {n_tests}, {training_plural}, {tests_plural} "
     "(write {{ for a brace)"),
    ('\n[texts]\ncomprehension = [{ question = "Q?", choices = ["a"], right = [1] }]\n',
     "world.toml: texts.comprehension[0].choices: 1 given, at least 2 needed (2 to 8 choices, in the order shown)"),
    ('\n[texts]\ncomprehension = [{ question = "Q?", choices = ["a", "b"], right = [] }]\n',
     "world.toml: texts.comprehension[0].right: expected the positions of the right choices, e.g. right = [1], "
     "got []"),
    ('\n[texts]\ncomprehension = [{ question = "Q?", choices = ["a", "b"], right = [0] }]\n',
     "world.toml: texts.comprehension[0].right: 0 is not a choice's position (1 to 2, in the order listed)"),
    ('\n[texts]\ncomprehension = [{ question = "Q?", choices = ["a", "b"], right = [3] }]\n',
     "world.toml: texts.comprehension[0].right: 3 is not a choice's position (1 to 2, in the order listed)"),
    ('\n[texts]\ncomprehension = [{ question = "Q?", choices = ["a", "b"], right = [2, 1] }]\n',
     "world.toml: texts.comprehension[0].right: every choice is right, so the question checks nothing"),
    ('\n[texts]\ncomprehension = [{ question = "Q?", choices = ["a", "b"], right = [1], answer = [1] }]\n',
     "world.toml: texts.comprehension[0].answer: not a field of this table (one of question, choices, right)"),
    ('\n[texts]\ncomprehension = [{ choices = ["a", "b"], right = [1] }]\n',
     "world.toml: texts.comprehension[0].question: missing"),
    ('\n[translations.DE]\n"sand" = "Sand"\n',
     "world.toml: translations.DE: expected a language's two-letter code in lower case (e.g. de), got 'DE'"),
    ('\n[translations.de]\n"sant" = "Sand"\n', 'world.toml: translations.de.sant: not one of the file\'s own '
     "participant texts (its title, cell labels, object name and [texts], written exactly); did you mean 'sand'?"),
    ('\n[translations.de]\n"fetch the key" = "den Schlüssel holen"\n', 'world.toml: translations.de."fetch the key": '
     "not one of the file's own participant texts (its title, cell labels, object name and [texts], written exactly)"),
    ('\n[translations.de]\n"sand" = ""\n', "world.toml: translations.de.sand: expected a non-empty text, got ''"),
    ('\n[translations.de]\n"sand" = 3\n', "world.toml: translations.de.sand: expected a non-empty text, got 3"),
    ('\n[texts]\ninstructions = ["{n_tests} questions."]\n[translations.de]\n"{n_tests} questions." = '
     '"{n_training} Fragen."\n', 'world.toml: translations.de."{n_tests} questions.": braces only around what the '
     "English paragraph fills in ({n_tests}; {{ for a brace)"),
])
def test_a_mistake_in_a_files_texts_gets_one_line_naming_the_field(tmp_path, extra, message):
    with pytest.raises(WorldFileError) as err:
        world_domain(_write(tmp_path, key_room.PATH.read_text() + extra))
    assert str(err.value) == message


def _write(tmp_path, text: str):
    path = tmp_path / "world.toml"
    path.write_text(text)
    return path


@pytest.mark.parametrize("name", ["taxi", "two-goal", "skateboard"])
def test_every_shipped_world_has_german_for_each_text_of_its_own(name):
    domain = world_domain(WORLDS / f"{name}.toml")
    german = domain.translations["de"]
    assert set(german) == set(domain.world.participant_texts) and all(german.values())
    assert domain.world.title in german and all(k.label in german for k in domain.world.kinds.values())
    assert domain.world.obj is None or domain.world.obj in german


def test_the_taxis_german_is_a_participants():
    german = world_domain(WORLDS / "taxi.toml").translations["de"]
    assert german == {"Augmented taxi": "Erweitertes Taxi", "toll": "Maut", "passenger": "Fahrgast"}


def test_a_refused_way_says_why_in_english_and_can_be_said_in_another_language():
    taxi = world_domain(WORLDS / "taxi.toml")
    words = {"action {number}: {action} is not possible at [{x}, {y}]": "Schritt {number}: {action} geht nicht bei "
             "[{x}, {y}]", "up": "nach oben"}
    with pytest.raises(ReplayError) as err:
        taxi.score_shown(0, ["left", "left", "left", "up"])  # into the wall at [1, 2]
    assert isinstance(err.value, (ValueError, TranslatableError))
    assert str(err.value) == "action 4: up is not possible at [1, 1]"  # what the core and its tests read
    assert err.value.say(lambda text: words.get(text, text)) == "Schritt 4: nach oben geht nicht bei [1, 1]"
    with pytest.raises(ReplayError) as err:
        taxi.score_shown(0, ["jump"])
    listed = err.value.say(lambda text: text.upper() if text in ("right", "exit") else text)
    assert listed == "action 1: 'jump' is not one of RIGHT, up, down, left, pickup, drop, EXIT"
