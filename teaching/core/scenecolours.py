"""The palette colours a domain's browser scene reads, found by reading its files, not by running them.

A scene (``static/studyapp/scenes/<name>.js``) names the colours it needs in one call to
``palette.js``'s ``colors(NAMES)``, in camelCase (``goalHatch`` is the page's ``--scene-goal-hatch``);
its stylesheet (``scenes/<name>.css``) may read ``var(--scene-<name>)`` too.  Custom properties a
stylesheet declares itself (the page's reference sizes) are not palette colours.  Reading the files
statically keeps the check free of a browser: a missing colour is otherwise an error only on the page.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

STATIC = Path(__file__).resolve().parents[2] / "static" / "studyapp"

_IMPORT = re.compile(r"import\s*\{([^}]*)\}\s*from\s*[\"'][^\"']*palette\.js[\"']")
_STRING = re.compile(r"[\"']([^\"'\s]+)[\"']")
_CSS_VAR = re.compile(r"var\(\s*--scene-([a-z0-9-]+)\s*[,)]")
_PROPERTY_LITERAL = re.compile(r"[\"'`]--scene-([a-z0-9-]+)[\"'`]")
_DECLARED = re.compile(r"(?:@property\s+|[{;\s])--scene-([a-z0-9-]+)\s*[:{]")
_COMMENT = re.compile(r"/\*.*?\*/|(?<![:\"'])//[^\n]*", re.S)


def kebab(name: str) -> str:
    """``goalHatch`` -> ``goal-hatch``: palette.js's mapping from a scene's name to its CSS property."""
    return re.sub(r"[A-Z]", lambda m: "-" + m.group(0).lower(), name)


@dataclass
class SceneColours:
    """What one scene reads: palette names (kebab-case) with the file that reads each, and the calls
    whose names could not be read statically."""

    reads: dict[str, str] = field(default_factory=dict)  # palette name -> file that reads it
    unreadable: list[str] = field(default_factory=list)  # "file: call" that passes no literal list
    missing_files: list[str] = field(default_factory=list)
    uses_palette: bool = False


def _without_comments(text: str) -> str:
    return _COMMENT.sub(" ", text)


def _aliases(js: str) -> list[str]:
    """The local names palette.js's `colors` is imported under (``colors as palette``)."""
    out = []
    for block in _IMPORT.findall(js):
        for part in block.split(","):
            words = part.split()
            if words and words[0] == "colors":
                out.append(words[-1])
    return out


def _call_arguments(js: str, alias: str) -> list[str]:
    """The argument text of every call ``alias(...)`` (not nested calls' parentheses)."""
    out = []
    for m in re.finditer(rf"(?<![\w$.]){re.escape(alias)}\s*\(", js):
        depth, i = 1, m.end()
        while i < len(js) and depth:
            depth += {"(": 1, ")": -1}.get(js[i], 0)
            i += 1
        out.append(js[m.end():i - 1].strip())
    return out


def _names(js: str, argument: str) -> list[str] | None:
    """The string literals of an array literal argument, or of the const/let/var array it names."""
    if argument.startswith("[") and argument.endswith("]"):
        return _STRING.findall(argument)
    if re.fullmatch(r"[A-Za-z_$][\w$]*", argument):
        m = re.search(rf"(?:const|let|var)\s+{re.escape(argument)}\s*=\s*\[([^\]]*)\]", js)
        if m:
            return _STRING.findall(m.group(1))
    return None


def scene_colours(name: str, static: Path = STATIC) -> SceneColours:
    """The palette names scenes/<name>.js and scenes/<name>.css read (missing files are reported)."""
    static = Path(static)
    out = SceneColours()
    js_path, css_path = static / "scenes" / f"{name}.js", static / "scenes" / f"{name}.css"
    declared: set[str] = set()
    for sheet in (static / "study.css", css_path):
        if sheet.exists():
            declared.update(_DECLARED.findall(_without_comments(sheet.read_text())))
    shown = _shown(static)
    if not js_path.exists():
        out.missing_files.append(shown(js_path))
    else:
        js = _without_comments(js_path.read_text())
        for alias in _aliases(js):
            out.uses_palette = True
            for argument in _call_arguments(js, alias):
                names = _names(js, argument)
                if names is None:
                    out.unreadable.append(f"{shown(js_path)}: {alias}({argument})")
                    continue
                for n in names:
                    out.reads.setdefault(kebab(n), shown(js_path))
        for n in _PROPERTY_LITERAL.findall(js) + _CSS_VAR.findall(js):
            if n not in declared:
                out.reads.setdefault(n, shown(js_path))
    if css_path.exists():
        for n in _CSS_VAR.findall(_without_comments(css_path.read_text())):
            if n not in declared:
                out.reads.setdefault(n, shown(css_path))
    return out


def _shown(static: Path):
    """A file's path as a message shows it: from the repository root when it lies under it."""
    root = static.parents[1] if len(static.parents) > 1 else static

    def show(path: Path) -> str:
        try:
            return path.relative_to(root).as_posix()
        except ValueError:
            return str(path)
    return show
