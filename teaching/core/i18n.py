"""Marks a robot's participant texts for translation without importing Django (teaching/ knows none).

:func:`gettext_noop` returns its text unchanged: it only tells ``makemessages`` (which extracts every
``_("...")``) to put the text into the catalogs.  The web side translates: it looks each text of a domain's
ParticipantTexts up in the active language's catalog (studyapp/i18n.py, ``participant_texts``), so the
domain's English text is the catalog's key and must stay exactly as written here.
"""
from __future__ import annotations


def gettext_noop(text: str) -> str:
    """`text` itself; marked so that it is extracted into the catalogs (see the module's docstring)."""
    return text
