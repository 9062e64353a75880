"""What every step kind is: a :class:`Page`, and the registry the flow, the views and the simulation read.

A page declares, for its kind of step, everything the rest of the app asks of it: the steps it adds to a
participant's flow (``items``), its template and what the template is given (``context``), the form that
checks its answer (``form``, ``bind``), what is stored with the answer (``score``, ``stored``) and what a
simulated participant answers (``simulate``).  Nothing about one kind of step is written anywhere else.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from django.shortcuts import render
from django.utils.translation import gettext


@dataclass(frozen=True)
class Step:
    """One step of a participant's flow: its place (index), its kind and which item of the kind it shows
    (a training example's, a test's or a closed loop's step number; None for a page shown once)."""

    index: int
    kind: str
    item: int | None = None


class AnswerError(Exception):
    """An answer that is rejected; nothing was written.

    `moved`: the page was out of date (the step was answered in another tab, or the participant
    is elsewhere in the study); the participant is sent to where they are, with `MOVED_ON`."""

    def __init__(self, message: str, status: int = 400, moved: bool = False):
        super().__init__(message)
        self.message, self.status, self.moved = message, status, moved


def elsewhere(participant, step_index: int) -> str:
    """The refusal of an answer to a step the participant is not on."""
    return gettext("You are on step {current}, not step {asked}.").format(current=participant.position + 1,
                                                                           asked=step_index + 1)


def replayed(stored, given, refusal: str) -> bool:
    """Whether a post is one already stored: `stored` is what was stored for it (None: nothing yet).  True
    when it is `given` again (a double click, a retried post: store nothing), AnswerError(`refusal`) when it
    differs (a stored answer is never changed), False when nothing was stored."""
    if stored is None:
        return False
    if stored == given:
        return True
    raise AnswerError(refusal, status=409, moved=True)


class Page:
    """One kind of step.  A subclass sets `kind` (what Answer.kind stores and the exports carry: never
    change it) and overrides what differs from these defaults: shown once, a template named after its
    kind, no answer taken, nothing scored, and a simulated participant who stops here."""

    kind: str = ""
    form = None  # the studyapp.participant.forms.StepForm subclass that checks its answer; None: the page takes none
    draws_robot = False  # its page draws the robot's world: the scene's module, palette, legend and texts

    @property
    def template(self) -> str:
        return f"studyapp/step_{self.kind}.html"

    def items(self, participant) -> Sequence[int | None]:
        """The steps of this kind in `participant`'s flow, by item: (None,) once, () not at all."""
        return (None,)

    def context(self, participant, step: Step, ctx: dict) -> dict:
        """What the template needs beyond `ctx` (the study, participant, step, progress and totals, and the
        scene's when ``draws_robot``)."""
        return {}

    def render(self, request, ctx: dict, status: int = 200):
        return render(request, self.template, ctx, status=status)

    def bind(self, participant, step: Step, post):
        """The form bound to `post`, or AnswerError for a page that takes no answer."""
        if self.form is None:
            raise AnswerError(gettext("This page takes no answer."), status=409)
        return self.form(post, participant, step)

    def store(self, locked, step_index: int, step: Step, data: dict):
        """Store an answer another way than as one Answer row (the caller holds the participant's row
        lock): the updated participant, or None for the one-row way every other page takes."""
        return None

    def score(self, answer, participant, step: Step, data: dict) -> None:
        """Set what the Answer row holds besides its data (correct, confidence, regret, chosen option)."""

    def stored(self, locked, data: dict) -> None:
        """What the stored answer changes on the participant (saved by the caller with its position)."""

    def simulate(self, sim, participant, step: Step) -> dict | None:
        """The POST fields a simulated participant (studyapp.analysis.simulate) sends; None: it stops."""
        return None


PAGES: dict[str, Page] = {}  # kind -> its page; a test kind's "show the way" page is SHOW_PAGES'
SHOW_PAGES: dict[str, Page] = {}
PAGE_SEQUENCE: list[str] = []  # the kinds in a participant's flow, in order (teaching's steps under TRAINING)


def add(page: Page, *, show: bool = False) -> Page:
    """Make `page` the one of its kind (show: the page of its kind in a study whose tests show the way)."""
    (SHOW_PAGES if show else PAGES)[page.kind] = page
    return page


def register(page: Page, before: str) -> None:
    """Add a new kind of step to every participant's flow, just before the steps of kind `before`."""
    if page.kind in PAGES:
        raise ValueError(f"a page of kind {page.kind!r} is registered already")
    add(page)
    PAGE_SEQUENCE.insert(PAGE_SEQUENCE.index(before), page.kind)


def unregister(kind: str) -> None:
    """Forget a kind `register` added (a test's own), so later flows never meet it."""
    PAGES.pop(kind, None)
    if kind in PAGE_SEQUENCE:
        PAGE_SEQUENCE.remove(kind)


def page_for(study, kind: str) -> Page:
    """The page of a step of `kind` in `study`: a test or check asks to show the way in a show study."""
    if study.test_kind == study.SHOW and kind in SHOW_PAGES:
        return SHOW_PAGES[kind]
    return PAGES[kind]
