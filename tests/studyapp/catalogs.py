"""The English texts of the German catalogs, to find any that a German page still shows.

Read from the compiled catalogs (`make messages`) with Python's own gettext module, not Django's, so the
check shares no code with what it checks.  A text counts when its German differs and it has two words
or more (one word, "OK" or a name, may be the same in both languages); a text with placeholders counts by
its fixed pieces between them."""
from __future__ import annotations

import gettext
import re
from functools import cache
from pathlib import Path

LOCALE = Path(__file__).resolve().parents[2] / "locale"
PLACEHOLDER = re.compile(r"%\([^)]*\)[sd]|%[sd]|\{[^}]*\}")


@cache
def english_pieces(language: str = "de") -> frozenset[str]:
    """Every fixed piece (two words or more) of every English text the `language` catalogs translate."""
    pieces = set()
    for domain in ("django", "djangojs"):
        catalog = gettext.translation(domain, localedir=LOCALE, languages=[language])._catalog
        for msgid, msgstr in catalog.items():
            if not isinstance(msgid, str) or not msgid or msgid == msgstr:
                continue
            for piece in PLACEHOLDER.split(msgid):
                piece = " ".join(piece.split()).strip(" .,:;!?()\"'")
                if len(piece.split()) >= 2:
                    pieces.add(piece)
    return frozenset(pieces)


def english_leaks(text: str, language: str = "de") -> list[str]:
    """The catalog's English pieces that occur in `text` (whitespace folded), longest first."""
    flat = " ".join(text.split())
    return sorted((p for p in english_pieces(language) if p in flat), key=len, reverse=True)
