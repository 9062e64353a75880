"""Numba's disk cache for the planner's kernels follows every kernel module's source and the world.

Numba keys a function's cache entry on that function's own file, but the kernels inline one another
across kernels.py, newton.py, qp.py, constrained.py and detmath.py, and freeze world.py's constants:
an edit to one file must not load stale machine code compiled from the others (docs/decisions.md,
"Numba's cache is keyed by the world")."""
from __future__ import annotations

import shutil
from pathlib import Path

import teaching
from teaching.domains.driving import kernels


def test_the_cache_directory_changes_with_any_kernel_source_and_the_world(tmp_path):
    copies = []
    for path in kernels.KERNEL_MODULES:
        copy = tmp_path / f"{len(copies)}.py"
        shutil.copy(path, copy)
        copies.append(copy)
    first = kernels.kernel_cache_dir("base", "world-a", copies)
    assert first == kernels.kernel_cache_dir("base", "world-a", copies)  # stable
    assert first.startswith("base/numba-")
    assert kernels.kernel_cache_dir("base", "world-b", copies) != first
    for copy in copies:  # one comment added to any one module is a new directory
        original = copy.read_bytes()
        copy.write_bytes(original + b"# an edit\n")
        assert kernels.kernel_cache_dir("base", "world-a", copies) != first, copy
        copy.write_bytes(original)
    assert kernels.kernel_cache_dir("base", "world-a", copies) == first


def test_every_module_that_compiles_kernels_is_hashed():
    """A new module of Numba kernels must join the list the cache key is made of (a module of its
    own cache, like detmath.py's leaf functions, is in it too: the planner's kernels inline them)."""
    package = Path(teaching.__file__).parent
    compiling = {path.resolve() for path in package.rglob("*.py") if "@njit" in path.read_text()}
    assert compiling == {Path(path).resolve() for path in kernels.KERNEL_MODULES}
