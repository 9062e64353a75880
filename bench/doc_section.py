"""Rewrite one bench's generated section of a document (docs/benchmarks.md) from its --json output."""
from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path


def rewrite_section(json_path: Path, doc: Path, begin: str, end: str, markdown: Callable[[dict], str],
                    what: str) -> None:
    """Replace doc's text from the `begin` marker to the `end` marker with markdown(figures)."""
    fig = json.loads(Path(json_path).read_text())
    text = Path(doc).read_text()
    if begin not in text or end not in text:
        raise SystemExit(f"{doc} has no {begin} ... {end} markers")
    start, stop = text.index(begin), text.index(end) + len(end)
    Path(doc).write_text(text[:start] + markdown(fig) + text[stop:])
    print(f"rewrote the {what} section of {doc} from {json_path}")
