"""A table folder's stimuli manifest (docs/importing.md, "Videos"): one video per (environment, objective),
listed with its checksum, each one a video a participant's browser plays.

The manifest is a CSV with the columns ``env_id, objective, file, sha256``; ``file`` is a path inside the
folder.  Every pair of the data is listed exactly once (pairs whose trajectories are alike may share a file);
each distinct file is hashed and probed once with Debian's ``ffprobe``: a WebM of VP8, VP9 or AV1, or an MP4
of H.264 or AV1, the codecs every current browser plays.  Every refusal is one line naming the manifest's
line and column or the file.
"""
from __future__ import annotations

import hashlib
import json
import math
import re
import shutil
import subprocess
from dataclasses import dataclass
from pathlib import Path, PurePosixPath

import numpy as np

from .csvlines import PairLines, TableFolderError, read_csv, refuser

COLUMNS = ("env_id", "objective", "file", "sha256")
PLAYABLE = {".webm": ("vp8", "vp9", "av1"), ".mp4": ("h264", "av1")}
PROBE_SECONDS = 60  # a hang guard: probing a short clip takes well under a second


@dataclass(frozen=True, eq=False)
class Stimuli:
    files: tuple[str, ...]  # each distinct video, as the manifest writes its path
    which: np.ndarray  # (M, N) int32: the position in `files` of the video of objective k in environment m
    sha256: tuple[str, ...]  # each file's checksum, as checked
    seconds: tuple[float, ...]  # each file's length, as ffprobe reads it (0.0 where it cannot tell)


def read_stimuli(folder: Path, manifest: str, env_ids: np.ndarray, n_objectives: int) -> Stimuli:
    """The manifest `manifest` of `folder`, every pair of (env_ids x objectives) listed once, every file there,
    matching its checksum, and playable; a TableFolderError names the first mistake."""
    fail = refuser(manifest)
    row_of = {int(e): i for i, e in enumerate(env_ids)}
    which = np.full((len(env_ids), n_objectives), -1, np.int32)
    files: dict[str, tuple[int, str, int]] = {}  # path -> (position, sha256, the first line naming it)
    pairs = PairLines(env_ids, n_objectives, fail, said="listed", what="video")
    for line, cells in read_csv(folder / manifest, COLUMNS, COLUMNS, fail)[1]:
        i, k = _pair(cells, line, row_of, n_objectives, fail)
        pairs.take(i, k, line)
        file, digest = _file(cells, line, fail)
        if file in files and files[file][1] != digest:
            fail(f"line {line}, column sha256: {file} was given another checksum on an earlier line")
        which[i, k] = files.setdefault(file, (len(files), digest, line))[0]
    pairs.check_complete()
    seconds = tuple(_check_video(folder, file, digest, refuser(f"{manifest}: line {line}"))
                    for file, (_, digest, line) in files.items())
    return Stimuli(tuple(files), which, tuple(digest for _, digest, _ in files.values()), seconds)


def _pair(cells: dict, line: int, row_of: dict, n_objectives: int, fail) -> tuple[int, int]:
    try:
        env, k = int(cells["env_id"]), int(cells["objective"])
    except ValueError:
        fail(f"line {line}: env_id and objective must be whole numbers, got {cells.get('env_id')!r}, "
             f"{cells.get('objective')!r}")
    if env not in row_of:
        fail(f"line {line}, column env_id: environment {env} is not in the data")
    if not 0 <= k < n_objectives:
        fail(f"line {line}, column objective: {k}; 0 is θ*, 1..{n_objectives - 1} the candidates")
    return row_of[env], k


def _file(cells: dict, line: int, fail) -> tuple[str, str]:
    file, digest = cells.get("file", ""), cells.get("sha256", "").lower()
    pure = PurePosixPath(file)
    if not file or pure.is_absolute() or ".." in pure.parts or "\\" in file:
        fail(f"line {line}, column file: {file!r} must be a path inside this folder (no '..', not absolute)")
    if pure.suffix.lower() not in PLAYABLE:
        fail(f"line {line}, column file: {file!r}: a video is a .webm or an .mp4")
    if not re.fullmatch(r"[0-9a-f]{64}", digest):
        fail(f"line {line}, column sha256: {cells.get('sha256')!r} is not a SHA-256 (64 hexadecimal digits)")
    return file, digest


def _check_video(folder: Path, file: str, digest: str, fail) -> float:
    """The video `file`, present, matching `digest` and playable; returns its length in seconds."""
    path = folder / file
    if not path.is_file():
        fail(f"{file}: no such file in the folder")
    h = hashlib.sha256()
    with path.open("rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    if h.hexdigest() != digest:
        fail(f"{file}: its SHA-256 is {h.hexdigest()[:12]}…, the manifest says {digest[:12]}…: "
             f"the file changed since the manifest was written")
    codecs, seconds = probe(path)
    if not codecs:
        fail(f"{file}: not a video (ffprobe finds no video stream in it)")
    allowed = PLAYABLE[path.suffix.lower()]
    if codecs[0] not in allowed:
        fail(f"{file}: {codecs[0]} video in a {path.suffix}; browsers play {', '.join(allowed)} in a {path.suffix}")
    return seconds


def probe(path: Path) -> tuple[list[str], float]:
    """The codec names of the video streams of `path` ([] when it holds none or is not a media file) and its
    length in seconds (0.0 where the file does not say)."""
    ffprobe = shutil.which("ffprobe")
    if ffprobe is None:
        raise TableFolderError("ffprobe not found: install Debian's ffmpeg (make media-deps) to check videos")
    try:
        done = subprocess.run([ffprobe, "-v", "error", "-select_streams", "v", "-show_entries",
                               "stream=codec_name:format=duration", "-of", "json", str(path)],
                              capture_output=True, text=True, timeout=PROBE_SECONDS)
    except subprocess.TimeoutExpired:
        raise TableFolderError(f"{path.name}: ffprobe did not finish within {PROBE_SECONDS} s (a damaged file?)") \
            from None
    if done.returncode != 0:
        return [], 0.0
    found = json.loads(done.stdout or "{}")
    try:
        seconds = float(found.get("format", {}).get("duration", 0.0))
    except ValueError:
        seconds = 0.0
    return [s.get("codec_name", "") for s in found.get("streams", [])], seconds if math.isfinite(seconds) else 0.0
