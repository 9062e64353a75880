"""The participant scripts' German catalog is complete: every text the scripts show (a literal
gettext("...") or ngettext("...", "...", n) in static/studyapp/) has a German translation, so a German
study's pages never fall back to English mid-sentence."""
from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PO = ROOT / "locale" / "de" / "LC_MESSAGES" / "djangojs.po"
SCRIPTS = ROOT / "static" / "studyapp"
# a JavaScript string literal in double quotes (the scripts write their texts so)
STRING = r'"((?:[^"\\]|\\.)*)"'
CALL = re.compile(rf"\b(?:gettext\(\s*{STRING}|ngettext\(\s*{STRING}\s*,\s*{STRING})")


def unquote(text: str) -> str:
    """A quoted string's text (JavaScript's and a .po file's escapes of a quote and a backslash)."""
    return re.sub(r"\\(.)", r"\1", text)


def catalog() -> dict[str, list[str]]:
    """msgid (and msgid_plural) -> its msgstr(s), the header left out."""
    entries = {}
    for block in PO.read_text(encoding="utf-8").split("\n\n"):
        if "#, fuzzy" in block:
            entries.setdefault("#fuzzy", []).append(block)
        fields, key = {}, None
        for line in block.splitlines():
            m = re.match(r"^(msgid|msgid_plural|msgstr(?:\[\d+\])?) (\".*\")$", line)
            if m:
                key = m.group(1)
                fields[key] = ""
                line = m.group(2)
            elif not line.startswith('"') or key is None:
                continue
            fields[key] += unquote(line[1:-1])
        if fields.get("msgid"):
            strs = [v for k, v in fields.items() if k.startswith("msgstr")]
            entries[fields["msgid"]] = strs
            if "msgid_plural" in fields:
                entries[fields["msgid_plural"]] = strs
    return entries


def script_texts() -> set[str]:
    found = set()
    for path in SCRIPTS.rglob("*.js"):
        if path.name == "i18n.js":
            continue
        for match in CALL.finditer(path.read_text(encoding="utf-8")):
            found.update(unquote(g) for g in match.groups() if g is not None)
    return found


def test_every_message_has_a_german_translation_and_none_is_fuzzy():
    entries = catalog()
    assert "#fuzzy" not in entries, entries.get("#fuzzy")
    assert entries
    empty = [msgid for msgid, strs in entries.items() if not strs or not all(s.strip() for s in strs)]
    assert not empty, empty


def test_every_text_the_scripts_show_is_in_the_catalog():
    texts = script_texts()
    assert "Show trail" in texts and "goal" in texts  # the scan finds the scripts' calls
    missing = sorted(texts - set(catalog()))
    assert not missing, f"run makemessages -d djangojs and translate: {missing}"


def test_named_placeholders_survive_translation():
    """A translation keeps every %(name)s of its English, so interpolate fills it."""
    for msgid, strs in catalog().items():
        names = set(re.findall(r"%\(\w+\)s", msgid))
        for translated in strs:
            assert set(re.findall(r"%\(\w+\)s", translated)) == names, (msgid, translated)
