"""One form per step kind: what each step of the participant's flow accepts (its page in studyapp.participant.pages
names it).

The pages are written by hand (templates/studyapp/step_<kind>.html), so these forms only validate:
`StepForm.answer()` gives the JSON stored in Answer.data, `first_error()` the one message the
participant sees.  Every message is in the participant's words: the page calls things "Option B",
"your age".
"""
from __future__ import annotations

from django import forms
from django.core.exceptions import ValidationError
from django.utils.text import format_lazy
from django.utils.translation import gettext
from django.utils.translation import gettext_lazy as _

from ..guards.inputs import OneValue, WholeNumberField
from ..i18n import participant_texts, translated_error
from ..trajectories import study_domain

GENDER_CHOICES = [
    ("female", _("Female")),
    ("male", _("Male")),
    ("non-binary", _("Non-binary")),
    ("other", _("Prefer to self-describe")),
    ("undisclosed", _("Prefer not to say")),
]
AGE_MIN, AGE_MAX = 18, 120
RATING_MIN, RATING_MAX = 1, 7
GENDER_TEXT_MAX = 100


class OneChoiceField(forms.ChoiceField):
    widget = OneValue


def _whole_number(low: int, high: int, missing: str, bad: str) -> WholeNumberField:
    """bad: the message for a value that is not a whole number from low to high."""
    return WholeNumberField(min_value=low, max_value=high, error_messages={
        "required": missing, "invalid": bad, "min_value": bad, "max_value": bad})


class StepForm(forms.Form):
    """A step's form, bound to the POST data and to the participant's step it answers."""

    def __init__(self, data, participant, step):
        super().__init__(data)
        self.participant, self.step = participant, step

    def first_error(self) -> str:
        """The message shown: the first failing field in the form's order (the page's order)."""
        return next(message for messages in self.errors.values() for message in messages)

    def answer(self) -> dict:
        raise NotImplementedError


class ConsentForm(StepForm):
    # Only "yes" gets here with a stored answer: the view answers "no" with the declined page.
    consent = OneChoiceField(choices=[("yes", _("I agree"))], error_messages={
        "required": _("Please say whether you agree to take part."),
        "invalid_choice": _("You can only continue if you agree to take part.")})

    # The version of the text the page showed (Study.consent_version); a page without it is read as the
    # text now, and a page of another version is sent back to be read again.
    consent_version = forms.CharField(required=False, widget=OneValue)

    def clean_consent_version(self):
        shown, now = self.cleaned_data["consent_version"], self.participant.study.consent_version()
        if shown and shown != now:
            raise ValidationError(gettext("The study's information changed after this page was opened; please "
                                          "reload the page and read it again before you agree."))
        return now

    def answer(self) -> dict:
        return {"consent": True, "consent_version": self.cleaned_data["consent_version"]}


class InstructionsForm(StepForm):
    ack = forms.CharField(widget=OneValue, error_messages={
        "required": _("Please confirm that you have read the instructions.")})

    def answer(self) -> dict:
        return {"ack": True}


class TrainingForm(StepForm):
    # The page's script sets played=1 when the animation ends.
    played = forms.ChoiceField(choices=[("1", "played")], error_messages={
        "required": _("Please watch the whole animation before you continue."),
        "invalid_choice": _("Please watch the whole animation before you continue.")})

    def answer(self) -> dict:
        if self.participant.condition.closed_loop:  # a closed-loop example or feedback: its stored step
            return {"env_id": self.participant.loop_steps.get(index=self.step.item).env_id}
        return {"env_id": self.participant.condition.training[self.step.item]["env_id"]}


class AttentionForm(StepForm):
    """The study's domain asks its question (Domain.texts); the answer is stored as "goals" (the
    first study's name for it, kept for every domain so exports read one column)."""

    goals = forms.MultipleChoiceField(choices=[], error_messages={
        "required": _("Please tick your answer."),
        "invalid_choice": _("Please tick only answers from the list."),
        "invalid_list": _("Please tick only answers from the list.")})

    def __init__(self, data, participant, step):
        super().__init__(data, participant, step)
        self.texts = participant_texts(study_domain(participant.study))
        self.fields["goals"].choices = self.texts.attention_choices

    def answer(self) -> dict:
        goals = set(self.cleaned_data["goals"])
        return {"goals": sorted(goals), "passed": goals == self.texts.attention_correct}


class DemographicsForm(StepForm):
    gender = OneChoiceField(choices=GENDER_CHOICES, error_messages={
        "required": _("Please choose an answer for gender (or 'Prefer not to say')."),
        "invalid_choice": _("Please choose an answer for gender from the list.")})
    age = _whole_number(AGE_MIN, AGE_MAX, _("Please enter your age."), format_lazy(
        _("Your age must be a whole number from {low} to {high}."), low=AGE_MIN, high=AGE_MAX))
    # Optional free text, cut rather than refused: a long self-description is not an error.
    gender_text = forms.CharField(required=False)

    def answer(self) -> dict:
        data = {"age": self.cleaned_data["age"], "gender": self.cleaned_data["gender"]}
        if data["gender"] == "other":
            data["gender_text"] = self.cleaned_data["gender_text"][:GENDER_TEXT_MAX]
        return data


class TestForm(StepForm):
    """Test (or check question) step.item: every option played, one chosen, each rated; options go by the letters the
    participant sees (`shown`: (letter, option index), top to bottom; flow.option_letters)."""

    __test__ = False  # a study's test step, not a pytest class

    def __init__(self, data, participant, step, shown: list[tuple[str, int]], env_id: int):
        super().__init__(data, participant, step)
        self.shown, self.env_id = shown, env_id
        letters = [(letter, letter) for letter, _ in shown]
        listed = ", ".join(letter for letter, _ in shown)
        self.reload = gettext("This question has options {listed} only; please reload the page.").format(
            listed=listed)
        self.fields["played"] = forms.MultipleChoiceField(choices=letters, required=False, error_messages={
            "invalid_choice": self.reload, "invalid_list": self.reload})
        self.fields["choice"] = OneChoiceField(choices=letters, error_messages={
            "required": participant_texts(study_domain(participant.study)).choice_required,
            "invalid_choice": gettext("This question has options {listed} only; please choose one of them.").format(
                listed=listed)})
        for letter, _index in shown:
            self.fields[f"rating_{letter}"] = _whole_number(
                RATING_MIN, RATING_MAX,
                gettext("Please rate how well option {letter} matches (1 = not at all, 7 = exactly).").format(
                    letter=letter),
                gettext("The rating of option {letter} must be a whole number from {low} to {high}.").format(
                    letter=letter, low=RATING_MIN, high=RATING_MAX))

    def clean_played(self):
        played = set(self.cleaned_data["played"])
        unplayed = [letter for letter, _ in self.shown if letter not in played]
        if unplayed:
            raise ValidationError(gettext("Please play option {letters} before you continue.").format(
                letters=", ".join(unplayed)))
        return played

    def clean_choice(self):
        # A rating for an option this page does not have means a stale or tampered page.  Checked
        # here, after the choice and before the ratings, so that it is the message shown first.
        if any(key.startswith("rating_") and key not in self.fields for key in self.data):
            raise ValidationError(self.reload)
        return self.cleaned_data["choice"]

    def answer(self) -> dict:
        ratings = [0] * len(self.shown)
        for letter, k in self.shown:
            ratings[k] = self.cleaned_data[f"rating_{letter}"]
        return {
            "env_id": self.env_id,
            "choice": dict(self.shown)[self.cleaned_data["choice"]],
            "ratings": ratings,
            "order": [k for _, k in self.shown],
        }


class ShowForm(StepForm):
    """A "show the way" test step.item: the actions the participant took, space-separated action names
    (the page's hidden field), replayed and scored on the server (Domain.score_shown) so that a way the
    world does not allow (off the grid, through a wall, stopping before the end) is refused whatever the
    page let through."""

    moves = forms.CharField(widget=OneValue, error_messages={
        "required": _("Please show the way: move the robot until it has finished, then continue.")})

    def __init__(self, data, participant, step, test: dict):
        super().__init__(data, participant, step)
        self.test, self.domain = test, study_domain(participant.study)
        self.score: dict | None = None

    def clean_moves(self):
        moves = self.cleaned_data["moves"].split()
        try:  # the domain bounds the number of moves too (FileGridDomain.max_actions), for every caller
            self.score = self.domain.score_shown(self.test["env_id"], moves)
        except ValueError as exc:  # the domain's reason, in the participant's language where it can say it
            raise ValidationError(gettext("This way cannot be submitted ({reason}). Please undo and try again.").format(
                reason=translated_error(exc))) from None
        return moves

    def answer(self) -> dict:
        return {"env_id": self.test["env_id"], "moves": self.cleaned_data["moves"]}
