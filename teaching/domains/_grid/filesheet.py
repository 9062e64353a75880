"""The contact-sheet panels of a grid world from a file (teaching.core.sheet lays the page out).

Each panel is the world from above as its page draws it (static/studyapp/scenes/world.js): free
cells light, walls dark, each kind of cell in its file colour with its pattern (dots, a hatch, both,
by its place in the file), S the start, G a goal, D the object's destination, the object a square
where it first lies; the robot's path an orange line, thick while it holds the object.
"""
from __future__ import annotations

import matplotlib

matplotlib.use("Agg")  # figures are written to files; no display on servers

import numpy as np
from matplotlib.lines import Line2D
from matplotlib.patches import Patch, Rectangle

from ...core.sheet import render_rows, sheet_rows
from ...core.showtests import is_show

PATTERNS = ("....", "////", "..//")  # the scene's dots, hatch, both


def draw_world(ax, domain, env_id: int, controls: np.ndarray) -> None:
    """Environment `env_id` of `domain` (a FileGridDomain) and one stored trajectory on `ax`."""
    payload = domain.scene_payload(env_id)["world"]
    palette, kinds = domain.palette, list(payload["labels"])
    cells = payload["cells"]
    h, w = len(cells), len(cells[0])
    for r in range(h):
        for c in range(w):
            kind = cells[r][c]
            colour = palette["wall"] if kind == "wall" else palette[f"cell-{kind}"] if kind else palette["free"]
            hatch = PATTERNS[kinds.index(kind) % 3] if kind and kind != "wall" else None
            ax.add_patch(Rectangle((c, r), 1, 1, facecolor=colour, edgecolor=palette["grid"], linewidth=0.5,
                                   hatch=hatch, zorder=1))
    if isinstance(payload["object"], list):
        c, r = payload["object"]
        ax.add_patch(Rectangle((c + 0.25, r + 0.25), 0.5, 0.5, color=palette["object"], zorder=2))
    marks = [(payload["start"], "S"), *((g, "G") for g in payload["goals"])]
    if payload["destination"]:
        marks.append((payload["destination"], "D"))
    for (c, r), letter in marks:
        ax.text(c + 0.5, r + 0.5, letter, ha="center", va="center", fontsize=9, weight="bold",
                color=palette["text"], zorder=3)
    rows = np.asarray(domain.path_rows(domain.states(controls)))  # [col, row, holding]
    xy = rows[:, :2] + 0.5
    for k in range(len(rows) - 1):
        ax.plot(xy[k:k + 2, 0], xy[k:k + 2, 1], color=palette["path"], solid_capstyle="round", zorder=4,
                linewidth=3.5 if rows[k, 2] and rows[k + 1, 2] else 1.5)
    ax.set_xlim(0, w)
    ax.set_ylim(h, 0)
    ax.set_aspect("equal")
    ax.set_xticks([])
    ax.set_yticks([])


def _tests_line(tests) -> str:
    if tests and all(is_show(t) for t in tests):
        return "the participant shows the way; drawn: θ*'s, the way with no regret."
    return "options A-D in test_set.json's order."


def render_sheet(domain, *, table, conditions, tests, out, no_tests=None, columns: int = 5,
                 panel_width: float = 3.0, dpi: int = 140, caption: str = "") -> int:
    """Draw the sheet to the PNG `out`; returns the number of panels drawn."""
    rows = sheet_rows(table=table, conditions=conditions, tests=tests, columns=columns)
    ids = np.asarray(table.env_ids)
    world = domain.world

    def draw(ax, panel, k):
        controls = np.asarray(table.controls[panel.env_index, panel.theta_index])
        draw_world(ax, domain, int(ids[panel.env_index]), controls)

    header = [caption, f"{world.title} from above ({world.width} x {world.height} cells), one action per step. "
                       f"Training: θ*'s trajectory. Tests: {_tests_line(tests)}"]
    legend = [Patch(facecolor=domain.palette["wall"], label="wall"),
              *(Patch(facecolor=domain.palette[f"cell-{k}"], hatch=PATTERNS[i % 3], label=v.label)
                for i, (k, v) in enumerate(world.kinds.items())),
              Line2D([], [], color=domain.palette["path"], linewidth=1.5, label="path")]
    if world.obj:
        legend += [Patch(facecolor=domain.palette["object"], label=world.obj),
                   Line2D([], [], color=domain.palette["path"], linewidth=3.5, label=f"path, holding the {world.obj}")]
    return render_rows(rows=rows, draw=draw, out=out, columns=columns, panel_width=panel_width,
                       panel_height=panel_width * world.height / world.width, dpi=dpi, header=header,
                       legend=legend, no_tests=no_tests)
