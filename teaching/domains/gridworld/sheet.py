"""The delivery yard's contact-sheet panels (teaching.core.sheet lays the page out).

Each panel is the yard from above, one square per cell, row 0 at the top: brown mud, dark walls,
the dog (a red disc) with the cells next to it tinted red, the cart (a blue square), the start S
and the drop-off D.  The robot's path is an orange line, thin while it carries the parcel by hand
and thick once it pushes the cart.  Greyscale-safe: every kind of cell also carries a letter or a
hatch.
"""
from __future__ import annotations

import matplotlib

matplotlib.use("Agg")  # figures are written to files; no display on servers

import numpy as np
from matplotlib.lines import Line2D
from matplotlib.patches import Circle, Patch, Rectangle

from ...core.sheet import render_rows, sheet_rows
from .environments import get_yard
from .page import PALETTE
from .world import CART, DOG, GRID, MUD, WALL

COLORS = PALETTE  # the one palette: the page's canvas and legend draw with the same colours


def draw_yard(ax, *, yard, cells_visited: np.ndarray) -> None:
    """One yard and one path on `ax`; cells_visited: (L,) int cell indices (row * width + col)."""
    h, w = yard.cells.shape
    near = yard.near_dog()
    for r in range(h):
        for c in range(w):
            kind = yard.cells[r, c]
            plain = COLORS["near"] if near[r, c] else COLORS["free"]
            color = {MUD: COLORS["mud"], WALL: COLORS["wall"]}.get(kind, plain)
            ax.add_patch(Rectangle((c, r), 1, 1, facecolor=color, edgecolor=COLORS["grid"], linewidth=0.5,
                                   hatch="...." if kind == MUD else ("////" if near[r, c] else None), zorder=1))
            if kind == DOG:
                ax.add_patch(Circle((c + 0.5, r + 0.5), 0.36, color=COLORS["dog"], zorder=2))
                ax.text(c + 0.5, r + 0.5, "dog", ha="center", va="center", fontsize=5, color="white", zorder=3)
            elif kind == CART:
                ax.add_patch(Rectangle((c + 0.18, r + 0.18), 0.64, 0.64, color=COLORS["cart"], zorder=2))
                ax.text(c + 0.5, r + 0.5, "cart", ha="center", va="center", fontsize=5, color="white", zorder=3)
    for (r, c), letter in ((yard.start, "S"), (yard.goal, "D")):
        ax.text(c + 0.5, r + 0.5, letter, ha="center", va="center", fontsize=9, weight="bold",
                color=COLORS["text"], zorder=3)
    cells = [int(v) for v in cells_visited]
    path = [cells[0]] + [b for a, b in zip(cells, cells[1:], strict=False) if b != a]
    xy = np.array([(v % w + 0.5, v // w + 0.5) for v in path])
    fetched = next((k for k, v in enumerate(path) if yard.cells[v // w, v % w] == CART), len(path))
    ax.plot(xy[:fetched + 1, 0], xy[:fetched + 1, 1], color=COLORS["path"], linewidth=1.5, zorder=4,
            solid_capstyle="round")
    if fetched < len(path) - 1:
        ax.plot(xy[fetched:, 0], xy[fetched:, 1], color=COLORS["path"], linewidth=3.5, zorder=4,
                solid_capstyle="round")
    ax.set_xlim(0, w)
    ax.set_ylim(h, 0)
    ax.set_aspect("equal")
    ax.set_xticks([])
    ax.set_yticks([])


def render_sheet(*, table, conditions, tests, out, no_tests=None, columns: int = 5, panel_width: float = 3.0,
                 dpi: int = 140, caption: str = "") -> int:
    """Draw the sheet to the PNG `out`; returns the number of panels drawn."""
    rows = sheet_rows(table=table, conditions=conditions, tests=tests, columns=columns)
    ids = np.asarray(table.env_ids)

    def draw(ax, panel, k):
        draw_yard(ax, yard=get_yard(int(ids[panel.env_index])),
                  cells_visited=np.asarray(table.controls[panel.env_index, panel.theta_index]))

    header = [caption,
              f"The yard from above ({GRID.width} x {GRID.height} cells): the robot carries the parcel from S to "
              f"D, one cell per move. Training: θ*'s path. Tests: options A-D in test_set.json's order."]
    legend = [Patch(facecolor=COLORS["mud"], hatch="....", label="mud"),
              Patch(facecolor=COLORS["near"], hatch="////", label="next to the dog"),
              Patch(facecolor=COLORS["wall"], label="wall"),
              Patch(facecolor=COLORS["cart"], label="cart"),
              Line2D([], [], color=COLORS["path"], linewidth=1.5, label="path, carrying by hand"),
              Line2D([], [], color=COLORS["path"], linewidth=3.5, label="path, pushing the cart")]
    return render_rows(rows=rows, draw=draw, out=out, columns=columns, panel_width=panel_width,
                       panel_height=panel_width * GRID.height / GRID.width, dpi=dpi, header=header,
                       legend=legend, no_tests=no_tests)
