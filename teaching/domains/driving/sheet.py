"""The car's contact-sheet panels (teaching.core.sheet lays the page out).

Each panel is the road seen from above, driving left to right (the right lane is at the bottom),
drawn to scale: 1 ft along the road = 1 ft across, and every panel shows the same stretch of road,
so panels can be compared directly.  Colours are the study canvas's, from the one palette
(``page.PALETTE``): yellow robot, dark gray other car, the goal tinted blue (the right lane for
"merge right", the centre lane ahead plus an arrow for "drive forward").  Cars are drawn at a few
moments, later ones more opaque (the paper's Fig. 2); the orange line is the robot's path.  Coordinates are feet
(DESIGN §2): x across, y forward.
"""
from __future__ import annotations

import matplotlib

matplotlib.use("Agg")  # figures are written to files; no display on servers

import numpy as np
from matplotlib.colors import to_rgba
from matplotlib.lines import Line2D
from matplotlib.patches import Patch, Polygon, Rectangle

from ...core.sheet import render_rows, sheet_rows
from .environments import CLASS_NAMES, get_environments, other_car_states
from .page import PALETTE
from .world import GOAL_MERGE, GOAL_NAMES, WORLD

# the one palette (page.PALETTE: the page's canvas and legend draw with the same colours)
COLORS = {**{k: PALETTE[k] for k in ("grass", "road", "line", "goal", "robot", "other", "outline")},
          "trail": PALETTE["path"]}
ROAD_HALF = WORLD.road_half_width  # ft, three 12 ft lanes
MARGIN = 9.0  # ft of grass on either side of the road (notes about an off-view other car go there)


def _car(ax, *, x: float, y: float, heading: float, color: str, alpha: float, z: float) -> None:
    """A WORLD.car_length × car_width rectangle centred at world (x, y) ft, heading in rad (π/2 = forward)."""
    fwd = np.array([np.sin(heading), -np.cos(heading)])  # world (cos h, sin h) on the page (u=y, v=-x)
    side = np.array([-fwd[1], fwd[0]])
    c = np.array([y, -x])
    hl, hw = WORLD.car_length / 2, WORLD.car_width / 2
    corners = [c + a * hl * fwd + b * hw * side for a, b in ((1, 1), (1, -1), (-1, -1), (-1, 1))]
    ax.add_patch(Polygon(corners, closed=True, facecolor=to_rgba(color, alpha),
                         edgecolor=to_rgba(COLORS["outline"], 0.35 + 0.65 * alpha),
                         linewidth=0.6, zorder=z))
    nose = c + 0.62 * hl * fwd  # a dark windscreen marks the front
    ax.add_patch(Polygon([nose + 0.12 * hl * fwd + 0.7 * hw * side, nose + 0.12 * hl * fwd - 0.7 * hw * side,
                          nose - 0.12 * hl * fwd - 0.7 * hw * side, nose - 0.12 * hl * fwd + 0.7 * hw * side],
                         facecolor=to_rgba("#1e283c", 0.6 * alpha), linewidth=0, zorder=z + 0.01))


def draw_scene(ax, *, robot: np.ndarray, other: np.ndarray, goal: int, window: tuple[float, float],
               across: float = ROAD_HALF + MARGIN, moments: int = 5) -> None:
    """Draw one drive on `ax`: the road over y in `window` (ft) and |x| <= `across` (ft), the goal,
    the robot's path, and both cars at `moments` evenly spaced steps (first faint, last opaque).

    robot: (T+1, 5) states [x, y, heading, v, steer]; other: (T+1, 2) positions [x, y]; goal: 0 merge
    right, 1 drive forward.  The page shows u = y to the right and v = -x up (right lane at the bottom).
    """
    lo, hi = window
    ax.set_facecolor(COLORS["grass"])
    ax.add_patch(Rectangle((lo, -ROAD_HALF), hi - lo, 2 * ROAD_HALF, color=COLORS["road"], zorder=1))
    w = WORLD.lane_width
    if goal == GOAL_MERGE:  # the right lane, x in [w/2, 3w/2] -> v in [-3w/2, -w/2]
        ax.add_patch(Rectangle((lo, -ROAD_HALF), hi - lo, w, color=COLORS["goal"], alpha=0.35, zorder=1.5))
    else:  # the centre lane ahead of the start, and an arrow at the far end
        ax.add_patch(Rectangle((0, -w / 2), hi, w, color=COLORS["goal"], alpha=0.35, zorder=1.5))
        ax.add_patch(Polygon([(hi - 2, 0), (hi - 14, 5), (hi - 14, -5)], color=COLORS["goal"], zorder=1.6))
    for v in (-ROAD_HALF + 0.5, ROAD_HALF - 0.5):
        ax.plot([lo, hi], [v, v], color=COLORS["line"], linewidth=0.8, zorder=2)
    for v in (-w / 2, w / 2):
        ax.plot([lo, hi], [v, v], color=COLORS["line"], linewidth=0.6, dashes=(6, 8), zorder=2)
    ax.plot(robot[:, 1], -robot[:, 0], color=COLORS["trail"], linewidth=1.4, zorder=3, solid_capstyle="round")
    last = len(robot) - 1
    steps = np.unique(np.linspace(0, last, moments).round().astype(int))
    for k in steps:
        a = 0.25 + 0.75 * k / last
        _car(ax, x=other[k, 0], y=other[k, 1], heading=np.pi / 2, color=COLORS["other"], alpha=a, z=4 + k / 100)
        _car(ax, x=robot[k, 0], y=robot[k, 1], heading=robot[k, 2], color=COLORS["robot"], alpha=a, z=5 + k / 100)
    off = {}  # the other car off the drawn road at the start or end: an arrow in its lane, a note in the grass
    for k, when in ((0, "start"), (last, "end")):
        if not lo <= other[k, 1] <= hi:
            d = other[k, 1] - robot[k, 1]
            off.setdefault(1 if other[k, 1] > hi else -1, []).append(
                f"{when}: {abs(d):.0f} ft {'ahead' if d > 0 else 'behind'}")
    ov = -other[0, 0]
    for side, notes in off.items():
        tip = hi - 1 if side > 0 else lo + 1
        ax.add_patch(Polygon([(tip, ov), (tip - 9 * side, ov + 4.5), (tip - 9 * side, ov - 4.5)],
                             facecolor=COLORS["other"], edgecolor=COLORS["outline"], linewidth=0.6, zorder=6))
        ax.text(tip, ROAD_HALF + MARGIN / 2, f"other car off view {'→' if side > 0 else '←'} " + ", ".join(notes),
                ha="right" if side > 0 else "left", va="center", fontsize=5.5, color="#111", zorder=7)
    ax.set_xlim(lo, hi)
    ax.set_ylim(-across, across)
    ax.set_aspect("equal")
    ax.set_xticks([])
    ax.set_yticks([])


def render_sheet(*, table, conditions: dict[str, list[int]], tests: list[dict] | None, out,
                 no_tests: str | None = None, columns: int = 5, panel_width: float = 5.0, dpi: int = 140,
                 moments: int = 5, caption: str = "") -> int:
    """Draw the sheet to the PNG `out`; returns the number of panels drawn
    (sum of sequence lengths + 4 × number of tests).

    conditions: name -> environment ids (must be in `table`); tests: test_set.json's list (or None)
    with `no_tests` saying why there are none; columns: panels per row before a sequence wraps;
    panel_width: inches; moments: how many instants the cars are drawn at.
    """
    ids = np.asarray(table.env_ids)
    cls, goal = np.asarray(table.env_class), get_environments(ids).goal

    def head(m: int) -> str:
        return f"env {int(ids[m])} · {CLASS_NAMES[cls[m]]} · {GOAL_NAMES[goal[m]]}"

    rows = sheet_rows(table=table, conditions=conditions, tests=tests, columns=columns, head=head)
    panels = [p for _, ps in rows for p in ps]
    idx = np.array([p.env_index for p in panels], dtype=np.int64)
    robot = np.asarray(table.states(idx, np.array([p.theta_index for p in panels], dtype=np.int64)))
    other = other_car_states(get_environments(ids[idx]))
    ys = robot[..., 1] if len(panels) else np.zeros(1)
    window = (min(0.0, float(ys.min())) - 25.0, float(ys.max()) + 25.0)
    xs = np.abs(robot[..., 0]).max() if len(panels) else 0.0  # a table's cars stay on the road; others show
    across = float(np.clip(xs + WORLD.car_length / 2 + 2, ROAD_HALF + MARGIN, 3 * ROAD_HALF))

    def draw(ax, panel, k):
        draw_scene(ax, robot=robot[k], other=other[k], goal=int(goal[panel.env_index]), window=window,
                   across=across, moments=moments)

    header = [
        caption,
        f"Driving left to right, right lane at the bottom. To scale (1 ft along = 1 ft across); every panel shows "
        f"y = {window[0]:.0f}..{window[1]:.0f} ft of road, x = ±{across:.0f} ft.",
        f"Cars at {len(np.unique(np.linspace(0, WORLD.horizon, moments).round()))} moments over "
        f"0..{WORLD.horizon * WORLD.dt:g} s, later = more opaque. Training: θ*'s trajectory. Tests: options A-D in "
        f"test_set.json's order (each participant sees them in a random order of their own)."]
    legend = [Patch(facecolor=COLORS["robot"], edgecolor=COLORS["outline"], label="robot car"),
              Patch(facecolor=COLORS["other"], edgecolor=COLORS["outline"], label="other car"),
              Line2D([], [], color=COLORS["trail"], linewidth=1.6, label="robot's path"),
              Patch(facecolor=COLORS["goal"], alpha=0.35,
                    label="goal: right lane (merge right) / centre lane ahead (drive forward)")]
    return render_rows(rows=rows, draw=draw, out=out, columns=columns, panel_width=panel_width,
                       panel_height=panel_width * 2 * across / (window[1] - window[0]), dpi=dpi, header=header,
                       legend=legend, no_tests=no_tests)
