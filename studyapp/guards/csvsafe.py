"""The CSV-injection guard for every export (OWASP "CSV injection"), on its own so that changes to
how exports are built (studyapp/data/exports.py) and to what counts as a formula stay apart.

A spreadsheet runs a cell whose text starts with ``= + - @`` (or a tab or carriage return before
one) as a formula.  Spreadsheets also fold compatibility forms: LibreOffice and Excel read a
fullwidth ``＝`` (U+FF1D), the small form ``﹦`` (U+FE66) and their kin as the plain sign, so the
check looks at the text's NFKC normalisation, which maps every one of them to its ASCII sign.
Leading spaces and invisible format characters (zero-width space, BOM) are skipped too: they
hide a formula from the eye without stopping every spreadsheet from running it.
"""
from __future__ import annotations

import unicodedata

FORMULA_STARTS = ("=", "+", "-", "@", "\t", "\r", "\n")
# U+2212 MINUS SIGN is not folded by NFKC, but some spreadsheets take it for "-".
_SIGNS = frozenset("=+-@\u2212")


def is_formula(text: str) -> bool:
    folded = unicodedata.normalize("NFKC", text)
    if folded.startswith(FORMULA_STARTS):
        return True
    for ch in folded:  # the first visible character decides
        if ch.isspace() or unicodedata.category(ch) == "Cf":
            continue
        return ch in _SIGNS
    return False


def neutralise(value):
    """Text that a spreadsheet would read as a formula gets a leading single quote.

    Only strings: they are what participants typed (platform ids, gender_text); numbers, such as a
    confidence score of -5, are written as numbers and stay untouched.  The text itself is kept
    as typed (not normalised): only the quote is added.
    """
    if isinstance(value, str) and is_formula(value):
        return "'" + value
    return value
