"""What every file of a table folder shares: the one-line refusal, a CSV read into its lines with its header
checked, a NumPy .npz read with its arrays' names checked, and the record of which line gave each
(environment, objective) pair."""
from __future__ import annotations

import csv
import zipfile
from pathlib import Path
from typing import NoReturn

import numpy as np

from ..core.schemacheck import did_you_mean


class TableFolderError(ValueError):
    """A table folder that cannot be used (one line: the file, the field, what is wrong)."""


def refuser(file: str):
    """fail(what): raise the TableFolderError "<file>: <what>"."""
    def fail(what: str) -> NoReturn:
        raise TableFolderError(f"{file}: {what}")

    return fail


def read_npz(path: Path, known: tuple[str, ...], required: tuple[str, ...], fail) -> dict[str, np.ndarray]:
    """{name: array} of the .npz at `path`: a zip of .npy arrays, every name one of `known`, each of `required`
    there, none needing pickle (a data file never runs code)."""
    if not zipfile.is_zipfile(path):
        fail("not a NumPy .npz file (a zip of .npy arrays, as numpy.savez writes it)")
    try:
        npz = np.load(path, allow_pickle=False)
    except (OSError, ValueError, zipfile.BadZipFile) as exc:
        fail(f"not a NumPy .npz file ({exc})")
    with npz:
        names = list(npz.files)
        for name in names:
            if name not in known:
                fail(f"array {name!r} is not one the format knows (one of {', '.join(known)})"
                     f"{did_you_mean(name, known)}")
        for name in required:
            if name not in names:
                fail(f"no array {name!r} (it holds: {', '.join(names) or 'nothing'})")
        arrays = {}
        for name in names:
            try:
                arrays[name] = npz[name]
            except (ValueError, OSError, zipfile.BadZipFile) as exc:  # an object array needs pickle: refused
                fail(f"array {name!r} cannot be read without running code or is damaged ({exc})")
    return arrays


def read_csv(path: Path, columns: tuple[str, ...], required: tuple[str, ...], fail) -> tuple[list[str], list]:
    """(header, [(line number, {column: text}), ...]) of the CSV at `path`: every column one of `columns`, each
    of `required` there, none twice, and one value per column on every line that is not empty."""
    try:
        with path.open(newline="", encoding="utf-8") as f:
            reader = csv.reader(f)
            header = [h.strip() for h in next(reader, [])]
            _check_header(header, columns, required, fail)
            lines = []
            for row in reader:
                if not any(row):
                    continue
                if len(row) != len(header):
                    fail(f"line {reader.line_num}: {len(row)} values, expected {len(header)} (one per column of "
                         f"line 1)")
                lines.append((reader.line_num, dict(zip(header, (c.strip() for c in row), strict=True))))
    except UnicodeDecodeError as exc:
        fail(f"not UTF-8 text ({exc.reason} at byte {exc.start})")
    except csv.Error as exc:  # a field over the csv module's limit
        fail(f"line {reader.line_num}: not CSV ({exc})")
    return header, lines


def _check_header(header: list[str], columns: tuple[str, ...], required: tuple[str, ...], fail) -> None:
    for name in header:
        if name not in columns:
            fail(f"line 1: column {name!r} is not one the format knows (one of {', '.join(columns)})"
                 f"{did_you_mean(name, columns)}")
    for name in required:
        if name not in header:
            fail(f"line 1: no column {name!r}")
    seen = set()
    for name in header:
        if name in seen:
            fail(f"line 1: column {name!r} given twice")
        seen.add(name)


class PairLines:
    """Which line of a CSV gave each (environment, objective) pair: each at most once, and at the end every
    one.  `said` words a repeat ("given", "listed"), `what` what a pair's line holds ("line", "video")."""

    def __init__(self, env_ids: np.ndarray, n_objectives: int, fail, said: str, what: str):
        self.env_ids, self.fail, self.said, self.what = env_ids, fail, said, what
        self.line = np.zeros((len(env_ids), n_objectives), np.int64)  # 0: none yet

    def take(self, i: int, k: int, line: int) -> None:
        if self.line[i, k]:
            self.fail(f"line {line}: environment {self.env_ids[i]}, objective {k} {self.said} twice (first on "
                      f"line {self.line[i, k]})")
        self.line[i, k] = line

    def check_complete(self) -> None:
        missing = np.argwhere(self.line == 0)
        if len(missing):
            i, k = missing[0]
            others = f" (and {len(missing) - 1} more pairs missing)" if len(missing) > 1 else ""
            self.fail(f"environment {self.env_ids[i]} has no {self.what} for objective {k}{others}")
