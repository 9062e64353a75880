"""Rewrite one bench's generated section of a document (docs/benchmarks.md) from its --json output."""
from __future__ import annotations

import argparse
import json
from collections.abc import Callable
from pathlib import Path


def add_doc_arguments(parser: argparse.ArgumentParser) -> None:
    """--json PATH (also write the figures there) and --update-doc JSON DOC (rewrite DOC's section from a --json
    output, without a run), as a bench that writes a section of docs/benchmarks.md takes them."""
    parser.add_argument("--json", metavar="PATH", help="also write the figures to PATH as JSON")
    parser.add_argument("--update-doc", nargs=2, metavar=("JSON", "DOC"), help="rewrite DOC's section from a --json "
                        "output; no run")


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
