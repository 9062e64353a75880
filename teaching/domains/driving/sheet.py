"""Contact sheet: every training example and test option a participant will see, in one PNG.

    python -m teaching sheet --table var/tables/demo --teach var/teaching/demo --out sheet.png

One row per condition (its examples in the order shown, θ*'s trajectory in each; long sequences
wrap onto more rows), then one row per test environment (its 4 options in the order
test_set.json stores them, labelled A-D).  Each panel is the road seen from above, driving left
to right (the right lane is at the bottom), drawn to scale: 1 ft along the road = 1 ft across,
and every panel shows the same stretch of road, so panels can be compared directly.  Colours
follow the study's canvas (static/studyapp/scene.js): yellow robot, gray other car, the goal
tinted blue (the right lane for "merge right", the centre lane ahead plus an arrow for "drive
forward").  Cars are drawn at a few moments, later ones more opaque (the paper's Fig. 2); the
orange line is the robot's path.  Coordinates are feet (DESIGN §2): x across, y forward.
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # figures are written to files; no display on servers

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.colors import to_rgba
from matplotlib.lines import Line2D
from matplotlib.patches import Patch, Polygon, Rectangle

from ...core.table import TrajectoryTable
from .environments import CLASS_NAMES, get_environments, other_car_states
from .strategies import CLUSTER_NAMES
from .world import GOAL_MERGE, GOAL_NAMES, WORLD

COLORS = {"grass": "#dfe9d8", "road": "#5b6068", "line": "#f4f4f4", "goal": "#2563eb",
          "robot": "#f5c518", "other": "#c9ccd1", "outline": "#1f2328", "trail": "#ff7a1a"}
ROAD_HALF = WORLD.road_half_width  # ft, three 12 ft lanes
MARGIN = 9.0  # ft of grass on either side of the road (notes about an off-view other car go there)
OPTION_LETTERS = "ABCD"


class SheetError(ValueError):
    """Inputs the sheet cannot be drawn from: reported as one line, exit status 2."""


@dataclass(frozen=True)
class Panel:
    """One drawing: θ `theta_index`'s trajectory in the table's environment row `env_index`."""

    env_index: int
    theta_index: int
    title: str


def cluster_name(c: int) -> str:
    """The strategy cluster's name (teaching.strategies.CLUSTER_NAMES), or 'cluster c' if it has none."""
    return CLUSTER_NAMES[c] if 0 <= c < len(CLUSTER_NAMES) else f"cluster {c}"


def _read_json(path: Path):
    try:
        return json.loads(path.read_text())
    except FileNotFoundError:
        raise SheetError(f"no teach output at {path.parent} ({path.name} missing; "
                         f"run python -m teaching.teach --table TABLE --out {path.parent})") from None
    except (OSError, ValueError) as exc:
        raise SheetError(f"{path} is unreadable or not valid JSON: {exc}") from None


def load_teach(*, teach_dir, table) -> tuple[dict[str, list[int]], list[dict] | None, str | None]:
    """Read and check ``teach_dir`` (the output of ``python -m teaching.teach``) against ``table``.

    Returns (conditions: name -> environment ids in showing order, tests: test_set.json's list or
    None, why there are no tests or None).  Raises SheetError when the directory is missing or
    malformed, or was made from another table (sequences.json's content hash differs).
    """
    teach_dir = Path(teach_dir)
    seqs = _read_json(teach_dir / "sequences.json")
    if not isinstance(seqs, dict) or not isinstance(seqs.get("conditions"), dict):
        raise SheetError(f"{teach_dir / 'sequences.json'} is not a teach output (no 'conditions')")
    made_from = (seqs.get("table") or {}).get("content_hash")
    ours = table.meta.get("content_hash")
    if made_from and made_from != ours:
        raise SheetError(f"teach output at {teach_dir} was made from another table (content hash "
                         f"{made_from[:16]} != {str(ours)[:16]}, the table's)")
    row_of = {int(e): i for i, e in enumerate(np.asarray(table.env_ids))}
    try:
        conditions = {str(k): [int(e) for e in v["env_ids"]] for k, v in seqs["conditions"].items()}
    except (TypeError, KeyError, ValueError):
        raise SheetError(f"{teach_dir / 'sequences.json'}: a condition has no list of env_ids") from None
    for name, ids in conditions.items():
        missing = [e for e in ids if e not in row_of]
        if missing:
            raise SheetError(f"condition {name!r} shows environments not in the table: {missing[:5]}")
    tests = _read_json(teach_dir / "test_set.json")
    if isinstance(tests, dict) and "error" in tests:
        return conditions, None, str(tests["error"])
    try:
        for t in tests:
            if row_of.get(int(t["env_id"])) is None or len(t["options"]) != 4:
                raise ValueError
            if any(not 0 <= int(o["theta_index"]) < table.n_thetas or not np.isfinite(float(o.get("regret", 0)))
                   for o in t["options"]):
                raise ValueError
    except (TypeError, KeyError, ValueError):
        raise SheetError(f"{teach_dir / 'test_set.json'} does not match the table (an environment it "
                         f"tests is not in the table, or its options are not 4 θ indices of it)") from None
    return conditions, tests, None


def sheet_rows(*, table, conditions, tests, columns: int) -> list[tuple[str, list[Panel]]]:
    """(row label, panels) for every condition (wrapped at `columns` panels) and every test."""
    row_of = {int(e): i for i, e in enumerate(np.asarray(table.env_ids))}
    cls = np.asarray(table.env_class)
    strat = np.asarray(table.strategy)
    goal = get_environments(np.asarray(table.env_ids)).goal

    def head(m: int) -> str:
        return f"env {int(table.env_ids[m])} · {CLASS_NAMES[cls[m]]} · {GOAL_NAMES[goal[m]]}"

    rows = []
    for name, ids in conditions.items():
        panels = [Panel(row_of[e], 0, f"{k + 1}. {head(row_of[e])}\nθ* → {cluster_name(int(strat[row_of[e], 0]))}")
                  for k, e in enumerate(ids)]
        if not panels:
            rows.append((f"{name}\n(no examples)", []))
        for lo in range(0, len(panels), columns):
            label = f"{name}\n{len(panels)} example{'s' * (len(panels) != 1)}" if lo == 0 else f"{name}\n(cont.)"
            rows.append((label, panels[lo:lo + columns]))
    for j, t in enumerate(tests or []):
        m = row_of[int(t["env_id"])]
        panels = []
        for letter, o in zip(OPTION_LETTERS, t["options"], strict=False):
            th = int(o["theta_index"])
            who = "θ* (θ0)" if th == 0 else f"θ{th}"
            regret = f" · regret {o['regret']:.3g}" if "regret" in o and th != 0 else ""
            panels.append(Panel(m, th, f"{letter}. {head(m)}\n{who} → {cluster_name(int(strat[m, th]))}{regret}"))
        rows.append((f"test {j + 1}\n" + str(t.get("cluster_name", "")).replace(": ", ":\n"), panels))
    return rows


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
    rows = sheet_rows(table=table, conditions=conditions, tests=tests, columns=columns)
    panels = [p for _, ps in rows for p in ps]
    idx = np.array([p.env_index for p in panels], dtype=np.int64)
    robot = np.asarray(table.states(idx, np.array([p.theta_index for p in panels], dtype=np.int64)))
    other = other_car_states(get_environments(np.asarray(table.env_ids)[idx]))
    goal = get_environments(np.asarray(table.env_ids)).goal
    ys = robot[..., 1] if len(panels) else np.zeros(1)
    window = (min(0.0, float(ys.min())) - 25.0, float(ys.max()) + 25.0)
    xs = np.abs(robot[..., 0]).max() if len(panels) else 0.0  # a table's cars stay on the road; others show
    across = float(np.clip(xs + WORLD.car_length / 2 + 2, ROAD_HALF + MARGIN, 3 * ROAD_HALF))
    panel_h = panel_width * 2 * across / (window[1] - window[0])
    title_h, label_w, head_h = 0.38, 1.4, 1.0
    n_rows = max(len(rows), 1)
    fig_w = label_w + columns * (panel_width + 0.15)
    fig_h = head_h + n_rows * (panel_h + title_h) + (0.4 if no_tests else 0)
    fig = plt.figure(figsize=(fig_w, fig_h))
    k = 0
    for r, (label, ps) in enumerate(rows):
        top = fig_h - head_h - r * (panel_h + title_h) - title_h
        fig.text(0.1 / fig_w, (top - panel_h / 2) / fig_h, label, ha="left", va="center", fontsize=8,
                 weight="bold" if not label.endswith("(cont.)") else "normal")
        for c, p in enumerate(ps):
            ax = fig.add_axes(((label_w + c * (panel_width + 0.15)) / fig_w, (top - panel_h) / fig_h,
                               panel_width / fig_w, panel_h / fig_h))
            draw_scene(ax, robot=robot[k], other=other[k], goal=int(goal[p.env_index]), window=window,
                       across=across, moments=moments)
            ax.set_title(p.title, fontsize=7.5, loc="left", pad=2, linespacing=1.15)
            k += 1
    if no_tests:
        fig.text(label_w / fig_w, 0.2 / fig_h, f"no test set in this teach output: {no_tests}", fontsize=8,
                 color="#b00020", va="center")
    fig.text(0.1 / fig_w, 1 - 0.1 / fig_h, "\n".join([
        caption,
        f"Driving left to right, right lane at the bottom. To scale (1 ft along = 1 ft across); every panel shows "
        f"y = {window[0]:.0f}..{window[1]:.0f} ft of road, x = ±{across:.0f} ft.",
        f"Cars at {len(np.unique(np.linspace(0, WORLD.horizon, moments).round()))} moments over "
        f"0..{WORLD.horizon * WORLD.dt:g} s, later = more opaque. Training: θ*'s trajectory. Tests: options A-D in "
        f"test_set.json's order (each participant sees them in a random order of their own)."]),
        ha="left", va="top", fontsize=7.5, linespacing=1.4)
    handles = [Patch(facecolor=COLORS["robot"], edgecolor=COLORS["outline"], label="robot car"),
               Patch(facecolor=COLORS["other"], edgecolor=COLORS["outline"], label="other car"),
               Line2D([], [], color=COLORS["trail"], linewidth=1.6, label="robot's path"),
               Patch(facecolor=COLORS["goal"], alpha=0.35,
                     label="goal: right lane (merge right) / centre lane ahead (drive forward)")]
    fig.legend(handles=handles, loc="upper left", ncol=4, fontsize=7.5, frameon=False,
               bbox_to_anchor=(0.05 / fig_w, 1 - 0.62 / fig_h))
    try:
        fig.savefig(out, dpi=dpi)
    finally:
        plt.close(fig)
    return k


def make_sheet(*, table_dir, teach_dir, out, **kwargs) -> tuple[int, str | None]:
    """Load and check the table and teach output, write the PNG `out`.

    Returns (panels drawn, why the teach output has no tests or None).  Raises SheetError
    (or teaching.table.TableError) for unusable inputs or an unwritable `out`.
    """
    table = TrajectoryTable.load(table_dir)
    conditions, tests, no_tests = load_teach(teach_dir=teach_dir, table=table)
    out = Path(out)
    if out.suffix.lower() != ".png":
        raise SheetError(f"--out must name a .png file, got {out}")
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        caption = (f"Contact sheet: table {table_dir} (preset {table.meta.get('preset')}, "
                   f"hash {str(table.meta.get('content_hash'))[:16]}), teach output {teach_dir}")
        n = render_sheet(table=table, conditions=conditions, tests=tests, out=out, no_tests=no_tests,
                         caption=caption, **kwargs)
    except OSError as exc:
        where = f" ({exc.filename})" if exc.filename and str(exc.filename) != str(out) else ""
        raise SheetError(f"cannot write {out}: {exc.strerror or exc}{where}") from None
    return n, no_tests
