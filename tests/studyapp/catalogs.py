"""The texts of the German catalogs, to find any English that a German page still shows (and any German
that an English page shows).

Read from the compiled catalogs (`make messages`, which `make test` runs) with Python's own gettext
module, not Django's, so the check shares no code with what it checks.  A text counts when its translation
differs; it is cut at its placeholders and markup into the pieces a page can show as they are, and a piece
counts when it has two words or more (one word, "OK" or a name, may be the same in both languages)."""
from __future__ import annotations

import gettext
import re
from functools import cache
from pathlib import Path

LOCALE = Path(__file__).resolve().parents[2] / "locale"
PLACEHOLDER = re.compile(r"%\(\w+\)[sd]|%[sd]|\{\w*\}|<[^>]+>")


def _pieces(text: str) -> set[str]:
    out = set()
    for piece in PLACEHOLDER.split(text):
        piece = " ".join(piece.split()).strip(" .,;:!?()\"'")
        if len(re.findall(r"[A-Za-zÄÖÜäöüß]+", piece)) >= 2:
            out.add(piece)
    return out


@cache
def catalog_pieces(language: str = "de") -> tuple[frozenset[str], frozenset[str]]:
    """(the English pieces, the translated pieces) of every text the `language` catalogs translate."""
    english, translated = set(), set()
    for domain in ("django", "djangojs"):
        try:
            catalog = gettext.translation(domain, localedir=LOCALE, languages=[language])._catalog
        except FileNotFoundError:
            raise AssertionError(f"no compiled {language} catalog {domain}.mo: run `make messages`") from None
        for key, msgstr in catalog.items():
            msgid = key[0] if isinstance(key, tuple) else key  # a plural form: (msgid, n)
            if msgid and msgstr and msgid != msgstr:
                english |= _pieces(msgid)
                translated |= _pieces(msgstr)
    return frozenset(english), frozenset(translated)


def english_pieces(language: str = "de") -> frozenset[str]:
    return catalog_pieces(language)[0]


def english_leaks(text: str, language: str = "de") -> list[str]:
    """The catalog's English pieces that occur in `text` (whitespace folded), longest first."""
    flat = " ".join(text.split())
    return sorted((p for p in english_pieces(language) if p in flat), key=len, reverse=True)
