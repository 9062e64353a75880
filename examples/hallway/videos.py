"""The hallway robot's clips: one video per distinct (environment, robot path) of a table, and the stimuli
manifest that names the clip of every (environment, objective) (docs/importing.md, "Videos").

A lab hands over the videos its participants watch; this renders them with matplotlib and Debian's ffmpeg,
the scene drawn as the site's top-down scene draws it (static/studyapp/scenes/topdown.js): light ground, a
grid every metre, dark walls, the people as dark red discs, the robot a light disc with a blue outline and
its path so far behind it, the time at the bottom left and a 1 m scale bar at the bottom right.  Objectives
that take the same path in an environment share its clip, so each path is rendered once.  Every clip runs
the whole clock (planner.T), the poses interpolated linearly between the 0.25 s samples.

For speed the background (ground, grid, walls, the people's paths, the scale bar) is drawn once per
environment and only the moving artists are drawn over it (Agg blitting); the raw frames go straight to one
ffmpeg per clip (VP9 in WebM, realtime settings), and environments are spread over processes.  The files
are bit-exact, so the same table gives the same clips and checksums every time.
"""
from __future__ import annotations

import hashlib
import shutil
import subprocess
import sys
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Circle, Rectangle
from matplotlib.transforms import Bbox

sys.path.insert(0, str(Path(__file__).resolve().parent))

import planner  # this folder's own module

# the palette of imported robots' scenes (teaching/importing/robot.py), so the clips look like the site
GROUND, GRID, WALL, TEXT = "#f5f3ee", "#dedad0", "#5b5750", "#222222"
ROBOT, PATH, AGENT, AGENT_PATH = "#1f5fa8", "#6f9fd6", "#b03a2e", "#e6a39b"

WIDTH, HEIGHT, DPI = 320, 176, 100  # px; even both ways, as VP9's yuv420p needs
X0, X1, Y0, Y1 = planner.VIEW
SCALE = WIDTH / (X1 - X0)  # px per metre
VIEW_H = (Y1 - Y0) * SCALE  # px: the view on top; the strip under it holds the labels
STRIP = HEIGHT - VIEW_H
PT = 72 / DPI  # points per px
RADIUS = max(5.0, min(12.0, WIDTH / 40)) / SCALE  # m: the robot's disc (a person's is 0.8 of it), as topdown.js
FONT = 12 * PT  # px, as topdown.js's labels
_LABELS: dict[int, list] = {}  # fps -> each frame's time label as pixels: text is the slow thing to draw


def _ffmpeg(path: Path, fps: int) -> subprocess.Popen:
    return subprocess.Popen(
        ["ffmpeg", "-loglevel", "error", "-y", "-f", "rawvideo", "-pix_fmt", "rgba", "-s", f"{WIDTH}x{HEIGHT}",
         "-r", str(fps), "-i", "-", "-c:v", "libvpx-vp9", "-deadline", "realtime", "-cpu-used", "8",
         "-b:v", "0", "-crf", "32", "-pix_fmt", "yuv420p", "-threads", "1", "-an",
         "-fflags", "+bitexact", str(path)],
        stdin=subprocess.PIPE)


def _at(rows: np.ndarray, times: np.ndarray) -> np.ndarray:
    """(L, 2) poses every DT -> (F, 2) poses at `times`, linearly between samples."""
    return np.stack([np.interp(times, planner.T, rows[:, 0]), np.interp(times, planner.T, rows[:, 1])], axis=1)


def _scene(agents: np.ndarray, walls: np.ndarray):
    """The figure with the environment's background and the moving artists (hidden from the plain draw)."""
    fig = Figure(figsize=(WIDTH / DPI, HEIGHT / DPI), dpi=DPI, facecolor=GROUND)
    canvas = FigureCanvasAgg(fig)
    ax = fig.add_axes((0, STRIP / HEIGHT, 1, VIEW_H / HEIGHT))
    ax.set_axis_off()
    ax.set_xlim(X0, X1)
    ax.set_ylim(Y0, Y1)
    ax.vlines(np.arange(np.ceil(X0), X1 + 1e-9), Y0, Y1, colors=GRID, linewidths=PT, zorder=0)
    ax.hlines(np.arange(np.ceil(Y0), Y1 + 1e-9), X0, X1, colors=GRID, linewidths=PT, zorder=0)
    for x0, y0, x1, y1 in walls:
        ax.add_patch(Rectangle((x0, y0), x1 - x0, y1 - y0, facecolor=WALL, linewidth=0))
    for rows in agents:
        ax.plot(rows[:, 0], rows[:, 1], color=AGENT_PATH, linewidth=2 * PT, solid_capstyle="round")
    y = STRIP / 2 / HEIGHT
    right = (WIDTH - 6) / WIDTH
    fig.add_artist(Line2D([right - SCALE / WIDTH, right], [y, y], color=TEXT, linewidth=2 * PT))
    fig.text(right - (SCALE + 4) / WIDTH, y, "1 m", color=TEXT, fontsize=FONT, ha="right", va="center")
    path = ax.plot([], [], color=PATH, linewidth=3 * PT, solid_capstyle="round", solid_joinstyle="round",
                   animated=True)[0]
    people = [ax.add_patch(Circle((0, 0), 0.8 * RADIUS, facecolor=AGENT, edgecolor=GROUND, linewidth=1.5 * PT,
                                  animated=True)) for _ in agents]
    robot = ax.add_patch(Circle((0, 0), RADIUS, facecolor=GROUND, edgecolor=ROBOT,
                                linewidth=max(1.5, RADIUS * SCALE / 4) * PT, animated=True))
    label = fig.text(4 / WIDTH, y, "", color=TEXT, fontsize=FONT, va="center", animated=True)
    canvas.draw()
    return canvas, ax, canvas.copy_from_bbox(fig.bbox), path, people, robot, label


def _labels(canvas, background, label, times: np.ndarray, fps: int) -> list:
    """Each frame's time label, drawn once in a process and kept as pixels of the strip's left half (the same
    in every clip: the strip holds nothing else there)."""
    if fps not in _LABELS:
        box = Bbox.from_extents(0, 0, WIDTH // 2, int(STRIP))
        for t in times:
            canvas.restore_region(background)
            label.set_text(f"t = {t:.1f} s")
            canvas.figure.draw_artist(label)
            _LABELS.setdefault(fps, []).append(canvas.copy_from_bbox(box))
    return _LABELS[fps]


def _render_env(folder: Path, names: list[str], ways: np.ndarray, agents: np.ndarray, walls: np.ndarray,
                fps: int) -> list[str]:
    """Render the clip of each of one environment's distinct robot paths `ways` (J, L, 2) to folder/names[j];
    the files' SHA-256, in that order."""
    times = np.arange(int(round(planner.T[-1] * fps)) + 1) / fps
    canvas, ax, background, path, people, robot, label = _scene(agents, walls)
    people_at = [_at(rows, times) for rows in agents]
    labels = _labels(canvas, background, label, times, fps)
    done = np.searchsorted(planner.T, times, side="right")  # the samples already passed at each frame
    digests = []
    for name, rows in zip(names, ways, strict=True):
        robot_at = _at(rows, times)
        ffmpeg = _ffmpeg(folder / name, fps)
        for f in range(len(times)):
            canvas.restore_region(background)
            trail = np.vstack([rows[:done[f]], robot_at[f]])
            path.set_data(trail[:, 0], trail[:, 1])
            for disc, at in zip(people, people_at, strict=True):
                disc.set_center(at[f])
            robot.set_center(robot_at[f])
            for artist in (path, *people, robot):
                ax.draw_artist(artist)
            canvas.restore_region(labels[f])
            ffmpeg.stdin.write(canvas.buffer_rgba())
        ffmpeg.stdin.close()
        if ffmpeg.wait() != 0:
            raise RuntimeError(f"ffmpeg failed on {folder / name} (exit {ffmpeg.returncode})")
        with open(folder / name, "rb") as f:
            digests.append(hashlib.file_digest(f, "sha256").hexdigest())
    return digests


def write_videos(out: Path, table: dict, *, fps: int = 10, jobs: int = 2, progress: bool = True) -> int:
    """Render one clip per distinct (environment, robot path) of `table` (planner.plan's dict) into out/clips/,
    write out/stimuli.csv; return the number of clips rendered."""
    if shutil.which("ffmpeg") is None:
        raise RuntimeError("ffmpeg not found: install Debian's ffmpeg (make media-deps) to render the clips")
    out = Path(out)
    (out / "clips").mkdir(parents=True, exist_ok=True)
    for old in (out / "clips").glob("env*-way*.webm"):  # a previous run's clips, perhaps of other paths
        old.unlink()
    robot = table["robot"]
    n_objectives = robot.shape[1]
    tasks, way_of = [], []
    for m, env_id in enumerate(table["env_id"]):
        rows = np.ascontiguousarray(robot[m]).reshape(n_objectives, -1)
        keys = rows.view(np.dtype((np.void, rows.shape[1] * rows.itemsize))).ravel()  # each path's bytes
        _, first, inverse = np.unique(keys, return_index=True, return_inverse=True)
        order = np.argsort(first)  # ways numbered as they first appear: way0 is θ*'s
        rank = np.empty_like(order)
        rank[order] = np.arange(len(order))
        way_of.append(rank[inverse.ravel()])
        names = [f"clips/env{int(env_id)}-way{j}.webm" for j in range(len(order))]
        tasks.append((names, robot[m][first[order]], table["agents"][m], table["walls"][m]))
    total = sum(len(names) for names, *_ in tasks)
    digests, done = [None] * len(tasks), 0
    with ProcessPoolExecutor(max(1, jobs)) as pool:
        futures = {pool.submit(_render_env, out, *task, fps): m for m, task in enumerate(tasks)}
        for future in as_completed(futures):
            m = futures[future]
            digests[m] = future.result()
            done += len(digests[m])
            if progress:
                print(f"\rrendered {done}/{total} clips", end="\n" if done == total else "", file=sys.stderr,
                      flush=True)
    lines = ["env_id,objective,file,sha256"]
    for m, env_id in enumerate(table["env_id"]):
        names = tasks[m][0]
        lines += [f"{int(env_id)},{k},{names[j]},{digests[m][j]}" for k, j in enumerate(way_of[m])]
    (out / "stimuli.csv").write_text("\n".join(lines) + "\n", encoding="utf-8")
    return total
