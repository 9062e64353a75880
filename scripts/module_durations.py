"""Write tests/durations.json from the log of a pytest run made with ``--durations=0``.

    PYTEST_ADDOPTS=--durations=0 make test > log.txt 2>&1
    python scripts/module_durations.py log.txt

The file holds each test module's seconds (setup, call and teardown of its tests, summed over both of
`make test`'s runs), rounded to the second.  tests/conftest.py hands the modules to pytest-xdist's workers
longest first, so that no long module is left for the end while the other workers sit idle.  It decides
only the order: a stale or missing entry costs some of that, never a result.
"""
from __future__ import annotations

import json
import re
import sys
from collections import Counter
from pathlib import Path

OUT = Path(__file__).resolve().parents[1] / "tests" / "durations.json"
LINE = re.compile(r"^\s*([\d.]+)s (?:setup|call|teardown)\s+(tests/\S+?\.py)::")


def module_seconds(lines) -> dict[str, int]:
    seconds = Counter()
    for line in lines:
        match = LINE.match(line)
        if match:
            seconds[match.group(2)] += float(match.group(1))
    return {module: round(s) for module, s in sorted(seconds.items())}


def main(argv: list[str]) -> int:
    if len(argv) != 1:
        print(__doc__, file=sys.stderr)
        return 2
    seconds = module_seconds(Path(argv[0]).read_text(errors="replace").splitlines())
    if not seconds:
        print(f"error: {argv[0]} has no --durations=0 lines", file=sys.stderr)
        return 2
    OUT.write_text(json.dumps(seconds, indent=0) + "\n")
    print(f"{len(seconds)} modules, {sum(seconds.values())} s -> {OUT}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
