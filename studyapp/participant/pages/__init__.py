"""The participant's pages, one object per kind of step, in the order a participant meets them.

Each kind's :class:`~studyapp.participant.pages.base.Page` holds everything about it: the steps it adds to the flow,
its template and context, the form that checks its answer, what is stored with it and what a simulated
participant answers.  ``PAGE_SEQUENCE`` reads top to bottom as a study does (oTree's page_sequence):

    consent, instructions, comprehension (if the study asks it), training (or a closed loop's examples,
    check questions and feedback), test, attention, demographics, done

A new kind of step is one module: a Page subclass and ``register(page, before=<kind>)``.
"""
from .base import PAGE_SEQUENCE, PAGES, SHOW_PAGES, AnswerError, Page, Step, page_for, register, unregister
from .end import ATTENTION, DEMOGRAPHICS, DONE
from .questions import LETTERS, TEST, option_letters, question_of
from .start import COMPREHENSION, CONSENT, INSTRUCTIONS
from .teaching import TRAINING

PAGE_SEQUENCE[:] = [page.kind for page in (CONSENT, INSTRUCTIONS, COMPREHENSION, TRAINING, TEST, ATTENTION,
                                           DEMOGRAPHICS, DONE)]

__all__ = ["PAGES", "PAGE_SEQUENCE", "SHOW_PAGES", "AnswerError", "LETTERS", "Page", "Step", "option_letters",
           "page_for", "question_of", "register", "unregister"]
