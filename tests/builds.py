"""Real tables the tests share, each built once per `make test` however many pytest processes need it.

pytest-free, so that tests/prebuild.py can fill the same directories before the test runs start.
"""
from __future__ import annotations

import fcntl
import os
import shutil
import subprocess
import sys
from pathlib import Path

from numpy._core._multiarray_umath import __cpu_features__


def built_in(root: Path, name: str, build) -> Path:
    """The directory root/name, filled by build(out) once and read-only afterwards.

    Whoever needs it first builds it while holding a lock on root/name.lock; the others wait and
    reuse it (so a 20-s table is not built once per xdist worker).  root/name.built marks a
    finished build: a build that raised leaves no marker, and the next caller starts it afresh.
    """
    out = root / name
    with open(root / f"{name}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # released when the file closes, also if build raises
        if not (root / f"{name}.built").exists():
            shutil.rmtree(out, ignore_errors=True)  # what a build that raised left half-written
            out.mkdir()
            build(out)
            mark_built(root, name)
    return out


def mark_built(root: Path, name: str) -> None:
    """root/name is finished: built_in reuses it from now on (tests/prebuild.py builds before any run)."""
    (root / f"{name}.built").touch()


# The `tiny` preset's table, shared by every test that reads it (tests/conftest.py tiny_table)
TINY_TABLE = "tiny-table"


# What another CPU changes: glibc's libm picks FMA/AVX2 variants of exp, sin, tan, ... at load time,
# NumPy picks AVX-512 loops for power and log10, Numba compiles for the host's instruction set and
# OpenBLAS picks its kernels by core type.  OTHER_CPU turns all of them off at once
# (tests/teaching/core/test_table.py builds a table under it).
NUMPY_AVX512 = [f for f in ("X86_V4", "AVX512_ICL", "AVX512_SPR") if __cpu_features__.get(f)]
OTHER_CPU = {"NUMBA_CPU_NAME": "generic", "GLIBC_TUNABLES": "glibc.cpu.hwcaps=-AVX2,-FMA,-AVX512F",
             "OPENBLAS_CORETYPE": "Prescott", **({"NPY_DISABLE_CPU_FEATURES": " ".join(NUMPY_AVX512)}
                                               if NUMPY_AVX512 else {})}


# The other CPU's Numba cache, a directory beside the shared tables
OTHER_CPU_NUMBA_CACHE = "numba-other-cpu"
# The `tiny` preset's table as the other CPU builds it (tests/prebuild.py compiles the other CPU's kernels by
# building it, and tests/teaching/core/test_table.py compares its hash with the native one's)
OTHER_CPU_TINY_TABLE = "tiny-table-other-cpu"


def start_tiny_build(out: Path, env: dict | None = None) -> subprocess.Popen:
    """`python -m teaching build --preset tiny --out out` as a researcher runs it (under env, if given), started in
    the background (the caller waits for it: wait_build); what it prints is kept beside the table (build_output)."""
    with open(out.parent / f"{out.name}.stdout", "w") as log:
        return subprocess.Popen([sys.executable, "-m", "teaching", "build", "--preset", "tiny", "--out", str(out)],
                                env=env, stdout=log, stderr=subprocess.PIPE, text=True)


def build_output(table: Path) -> str:
    """What the command that built `table` printed (start_tiny_build)."""
    return (table.parent / f"{table.name}.stdout").read_text()


def build_tiny_as_other_cpu(root: Path, out: Path) -> subprocess.Popen:
    """start_tiny_build as the other CPU runs it, with its Numba cache in root."""
    return start_tiny_build(out, other_cpu_env(os.environ, root / OTHER_CPU_NUMBA_CACHE))


def wait_build(proc: subprocess.Popen, what: str) -> None:
    """Wait for a build started by start_tiny_build; raise with its stderr if it failed."""
    _, err = proc.communicate()
    if proc.returncode != 0:
        raise RuntimeError(f"building {what} failed:\n{err}")


def other_cpu_env(base: dict, numba_cache: Path) -> dict:
    """`base` as another CPU would run it, with its own Numba cache: the kernels compiled for a generic
    x86-64 never mix with this CPU's."""
    return {**base, **OTHER_CPU, "NUMBA_CACHE_DIR": str(numba_cache)}
