"""An imported robot's contact sheet (``python -m teaching sheet``): every training example and test option as
participants see it.  A robot shown by its videos: each panel the last frame of the trajectory's video (read by
Debian's ffmpeg).  A robot drawn from its recorded paths: each panel drawn from above as the participants'
top-down scene draws it (static/studyapp/scenes/topdown.js): the environment's view, a light grid, the obstacles
(dark), the other agents' paths (faint) and where they start (dark discs), the robot's path from its start (a
light ring) to its end (a light disc).  Rows and layout are teaching.core.sheet's; only the panels are drawn here.
"""
from __future__ import annotations

import io
import shutil
import subprocess

import numpy as np
from matplotlib.image import imread
from matplotlib.lines import Line2D
from matplotlib.patches import Rectangle

from ..core.sheet import SheetError, render_rows, sheet_rows

FRAME_SECONDS = 60  # a hang guard: reading one frame takes well under a second


def render_sheet(*, domain, table, conditions, tests, out, no_tests, caption, columns, dpi) -> int:
    rows = sheet_rows(table=table, conditions=conditions, tests=tests, columns=columns)
    if domain.videos:
        return _video_sheet(domain=domain, table=table, rows=rows, out=out, no_tests=no_tests, caption=caption,
                            columns=columns, dpi=dpi)
    c = domain.palette

    def draw(ax, panel, _k):
        env_id = int(table.env_ids[panel.env_index])
        scene = domain.scene_payload(env_id)
        x0, x1, y0, y1 = scene["bounds"]
        ax.set_facecolor(c["ground"])
        ax.set_xlim(x0, x1)
        ax.set_ylim(y0, y1)
        ax.set_aspect("equal")
        ax.grid(color=c["grid"], linewidth=0.6)
        ax.tick_params(labelsize=6, length=2)
        for x0_, y0_, x1_, y1_ in scene["obstacles"]:
            ax.add_patch(Rectangle((x0_, y0_), x1_ - x0_, y1_ - y0_, facecolor=c["obstacle"], linewidth=0))
        for agent in scene["agents"]:
            a = np.asarray(agent)
            ax.plot(a[:, 0], a[:, 1], color=c["agent-path"], linewidth=1.5)
            ax.plot(*a[0], "o", color=c["agent"], markersize=6)
        robot = np.asarray(domain.path_rows(table.states(panel.env_index, panel.theta_index)))
        ax.plot(robot[:, 0], robot[:, 1], color=c["path"], linewidth=2)
        ax.plot(*robot[0], "o", markerfacecolor="none", markeredgecolor=c["robot"], markersize=7)
        ax.plot(*robot[-1], "o", markerfacecolor=c["ground"], markeredgecolor=c["robot"], markeredgewidth=2,
                markersize=8)

    legend = [Line2D([], [], color=c["path"], linewidth=2, label="the robot's path"),
              Line2D([], [], marker="o", linestyle="", markerfacecolor=c["ground"], markeredgecolor=c["robot"],
                     label="the robot at its end (ring: its start)"),
              Line2D([], [], color=c["agent-path"], marker="o", markerfacecolor=c["agent"],
                     markeredgecolor=c["agent"], label="another agent: its path, and where it starts")]
    unit = domain.paths["unit"] if domain.paths else ""
    header = [caption, f"{domain.title}: seen from above, axes in {unit or 'the table units'}; "
                       "each panel one trajectory of the table"]
    return render_rows(rows=rows, draw=draw, out=out, columns=columns, panel_width=2.6, panel_height=1.5, dpi=dpi,
                       header=header, legend=legend, no_tests=no_tests)


def _video_sheet(*, domain, table, rows, out, no_tests, caption, columns, dpi) -> int:
    """Each panel the last frame of its trajectory's video."""
    def draw(ax, panel, _k):
        shown = domain.stimulus(int(table.env_ids[panel.env_index]), panel.theta_index, None)
        ax.imshow(last_frame(domain.media_file(shown["video"])))
        ax.set_axis_off()

    header = [caption, f"{domain.title}: each panel the last frame of one trajectory's video"]
    return render_rows(rows=rows, draw=draw, out=out, columns=columns, panel_width=2.6, panel_height=1.5, dpi=dpi,
                       header=header, legend=[], no_tests=no_tests)


def last_frame(path) -> np.ndarray:
    """(H, W, 3 or 4) the last frame of the video at `path`, as ffmpeg decodes it."""
    ffmpeg = shutil.which("ffmpeg")
    if ffmpeg is None:
        raise SheetError("ffmpeg not found: install Debian's ffmpeg (make media-deps) to draw a sheet of videos")
    try:
        done = subprocess.run([ffmpeg, "-v", "error", "-sseof", "-0.5", "-i", str(path), "-update", "1", "-frames:v",
                               "1", "-f", "image2pipe", "-vcodec", "png", "-"], capture_output=True,
                              timeout=FRAME_SECONDS)
    except subprocess.TimeoutExpired:
        raise SheetError(f"{path}: ffmpeg did not read its last frame within {FRAME_SECONDS} s") from None
    if done.returncode != 0 or not done.stdout:
        raise SheetError(f"{path}: ffmpeg could not read its last frame ({done.stderr.decode().strip()[:200]})")
    return imread(io.BytesIO(done.stdout), format="png")
