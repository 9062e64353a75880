"""What `make test` does before its two pytest runs start, on a machine nothing else is using yet.

    python -m tests.prebuild        # with $TEST_BUILDS_DIR set (make test makes it)

1. Compiles the planner's Numba kernels into their disk caches, twice side by side (one core each):
   for this CPU, and for the "other CPU" of the reproducibility test (tests/builds.py OTHER_CPU).
   In a fresh clone each is a cold compile of about a minute; inside the runs it would be paid on
   cores the other tests are competing for.  The build that compiles for this CPU is the `tiny`
   table itself, left where tests/conftest.py's tiny_table fixture looks for it (and marked built
   the way tests/builds.py built_in marks it), so no test builds it again; the one for the other CPU is
   the table the reproducibility test compares with it (tests/builds.py OTHER_CPU_TINY_TABLE), likewise.
2. Builds the demo table (tests/builds.py built_in, the directory tests/conftest.py's demo_table
   fixture reads), on both cores: the table a dozen tests of both runs wait for.
3. Meanwhile, collects the tests once (`pytest --collect-only`), so that pytest's assertion rewriting
   of every test module is written to __pycache__ before the four pytest processes of the runs (three
   workers and the shared-services run) start: each of them spent about 8 s of CPU rewriting and
   compiling them again (13.4 s to collect from source, 4.9 s from the written files).  `make test`
   lets Python write bytecode for this: the machine's PYTHONDONTWRITEBYTECODE=1 would keep it from it.

It prints how long each step took, so a CI log shows where its first minutes went.
"""
from __future__ import annotations

import functools
import os
import subprocess
import sys
import time
from pathlib import Path

from teaching.core.build import PRESETS, build_table
from tests.builds import (
    OTHER_CPU_TINY_TABLE,
    TINY_TABLE,
    build_tiny_as_other_cpu,
    built_in,
    mark_built,
    start_tiny_build,
    wait_build,
)


def compile_kernels(root: Path) -> None:
    """The tiny table for this CPU and for the other CPU, in two processes at once."""
    builds = {"this CPU": start_tiny_build(root / TINY_TABLE),
              "the other CPU": build_tiny_as_other_cpu(root, root / OTHER_CPU_TINY_TABLE)}
    for what, proc in builds.items():
        try:
            wait_build(proc, f"the tiny table for {what}")
        except RuntimeError as e:
            raise SystemExit(f"prebuild: compiling the kernels for {what} failed: {e}") from None
    mark_built(root, TINY_TABLE)
    mark_built(root, OTHER_CPU_TINY_TABLE)


def main() -> int:
    if not os.environ.get("TEST_BUILDS_DIR"):
        print("prebuild: set TEST_BUILDS_DIR to the directory the test runs share (make test does)",
              file=sys.stderr)
        return 2
    root = Path(os.environ["TEST_BUILDS_DIR"])
    start = time.perf_counter()
    collecting = start_collecting()
    compile_kernels(root)
    compiled = time.perf_counter()
    built_in(root, "demo-table", functools.partial(build_table, PRESETS["demo"]))
    done = time.perf_counter()
    print(f"prebuild: kernels compiled for this CPU and the other in {compiled - start:.0f} s, "
          f"the demo table built in {done - compiled:.0f} s")
    if collecting.wait() != 0:  # the runs collect again and say what went wrong, where it is read
        print(f"prebuild: collecting the tests failed (pytest exit {collecting.returncode})", file=sys.stderr)
    return 0


def start_collecting() -> subprocess.Popen:
    """`pytest --collect-only` in the background, its output discarded (the runs print their own)."""
    return subprocess.Popen([sys.executable, "-m", "pytest", "--collect-only", "-q", "-p", "no:cacheprovider"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


if __name__ == "__main__":
    sys.exit(main())
