"""Marks a robot's participant texts for translation without importing Django (teaching/ knows none).

:func:`gettext_noop` returns its text unchanged: it only tells ``makemessages`` (which extracts every
``_("...")``) to put the text into the catalogs.  The web side translates: it looks each text of a domain's
ParticipantTexts up in the active language's catalog (studyapp/i18n.py, ``participant_texts``), so the
domain's English text is the catalog's key and must stay exactly as written here.  A refusal a participant
reads is a :class:`TranslatableError`: its English line, and what the web side needs to say it in theirs.
"""
from __future__ import annotations


def gettext_noop(text: str) -> str:
    """`text` itself; marked so that it is extracted into the catalogs (see the module's docstring)."""
    return text


class TranslatableError(ValueError):
    """A one-line refusal a participant may read (a way the world does not allow, say), in any language.

    str() is the English line, so everything that reads it as before still does.  ``message`` is the
    English text with ``{placeholders}``, marked with :func:`gettext_noop` where it is raised so that it is
    in the catalogs, and ``values`` fill it in; the values named in ``words`` are themselves marked texts (a
    tuple of them is said as a list), which the web side translates too (studyapp/i18n.py,
    ``translated_error``)."""

    def __init__(self, message: str, words: tuple[str, ...] = (), **values):
        self.message, self.words, self.values = message, tuple(words), values
        super().__init__(self.say(str))

    def say(self, translate) -> str:
        """The line with `translate` (a text -> its translation) applied to the message and the words."""
        def value(name, v):
            if isinstance(v, tuple):
                return ", ".join(translate(w) if name in self.words else str(w) for w in v)
            return translate(v) if name in self.words else v

        return translate(self.message).format(**{name: value(name, v) for name, v in self.values.items()})
