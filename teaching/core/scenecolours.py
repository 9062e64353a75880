"""The palette colours a domain's browser scene reads, found by reading its files, not by running them.

A scene (``static/studyapp/scenes/<name>.js``) names the colours it needs in one call to
``palette.js``'s ``colors(NAMES)``, in camelCase (``robotEdge`` is the page's ``--scene-robot-edge``);
its stylesheet (``scenes/<name>.css``) may read ``var(--scene-<name>)`` too.  A scene built on a base
module beside it (``import { GridScene } from "./grid.js"``) hands the base its ``const NAMES = [...]``,
and the base calls ``colors(this.names)`` over its own ``NAMES`` and the scene's: the scene's colours are
then every ``NAMES`` of the scene and of the modules it imports from ``scenes/``.  Custom properties a
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
_LOCAL_IMPORT = re.compile(r"import\s*\{[^}]*\}\s*from\s*[\"'](?:\./|/static/studyapp/scenes/)([\w.-]+\.js)[\"']")
_NAMES_CONST = re.compile(r"(?:const|let|var)\s+NAMES\s*=\s*\[([^\]]*)\]")
_COMMENT = re.compile(r"/\*.*?\*/|(?<![:\"'])//[^\n]*", re.S)


def kebab(name: str) -> str:
    """``robotEdge`` -> ``robot-edge``: palette.js's mapping from a scene's name to its CSS property."""
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


def _chain(js_path: Path, find) -> list[Path]:
    """The scene module and, depth first, every module it imports from the scenes' folder (its base):
    ``./grid.js`` or ``/static/studyapp/scenes/grid.js``, found by find("scenes/grid.js")."""
    seen: list[Path] = []
    todo = [js_path]
    while todo:
        path = todo.pop()
        if path in seen or not path.exists():
            continue
        seen.append(path)
        todo.extend(find(f"scenes/{name}") for name in _LOCAL_IMPORT.findall(_without_comments(path.read_text())))
    return seen


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


def static_roots(static: Path | tuple[Path, ...]) -> list[Path]:
    """The folders a page's static files are searched in, in order: ``static`` itself, or each of several."""
    return [Path(r) for r in ((static,) if isinstance(static, (str, Path)) else static)]


def scene_colours(name: str, static: Path | tuple[Path, ...] = STATIC) -> SceneColours:
    """The palette names scenes/<name>.js and scenes/<name>.css read (missing files are reported).

    static: the folder the page serves as /static/studyapp/, or several searched in order, as Django's
    static files finders search them (the first that has a file gives it): a test's own scene beside the
    project's."""
    roots = static_roots(static)
    static = roots[0]
    out = SceneColours()

    def find(relative: str) -> Path:
        return next((r / relative for r in roots if (r / relative).exists()), static / relative)

    js_path, css_path = find(f"scenes/{name}.js"), find(f"scenes/{name}.css")
    declared: set[str] = set()
    for sheet in (find("study.css"), css_path):
        if sheet.exists():
            declared.update(_DECLARED.findall(_without_comments(sheet.read_text())))
    shown = _shown(static)
    if not js_path.exists():
        out.missing_files.append(shown(js_path))
    else:
        modules = {path: _without_comments(path.read_text()) for path in _chain(js_path, find)}
        # the NAMES each module declares: what a base's colors(this.names) reads
        declared_names = {shown(path): _STRING.findall(m.group(1)) for path, js in modules.items()
                          for m in [_NAMES_CONST.search(js)] if m}
        for path, js in modules.items():
            for alias in _aliases(js):
                out.uses_palette = True
                for argument in _call_arguments(js, alias):
                    names = _names(js, argument)
                    if names is not None:
                        for n in names:
                            out.reads.setdefault(kebab(n), shown(path))
                    elif argument == "this.names" and declared_names:
                        for where, base_names in declared_names.items():
                            for n in base_names:
                                out.reads.setdefault(kebab(n), where)
                    else:
                        out.unreadable.append(f"{shown(path)}: {alias}({argument})")
            for n in _PROPERTY_LITERAL.findall(js) + _CSS_VAR.findall(js):
                if n not in declared:
                    out.reads.setdefault(n, shown(path))
    if css_path.exists():
        for n in _CSS_VAR.findall(_without_comments(css_path.read_text())):
            if n not in declared:
                out.reads.setdefault(n, shown(css_path))
    return out


def _shown(static: Path):
    """A file's path as a message shows it: from the repository root when it lies under it."""
    root = static.parents[1] if len(static.parents) > 1 else static

    def show(path: Path) -> str:
        for base in (STATIC.parents[1], root):  # the repository's own files by their repository path
            try:
                return path.resolve().relative_to(base.resolve()).as_posix()
            except ValueError:
                continue
        return str(path)
    return show
