"""Contact sheets: every training example and test option a participant will see, in one PNG.

    python -m teaching sheet --table var/tables/demo --teach var/teaching/demo --out sheet.png

One row per condition (its examples in the order shown, θ*'s trajectory in each; long sequences
wrap onto more rows), then one row per test environment (its 4 options in the order
test_set.json stores them, labelled A-D; a "show the way" test, which has no options, θ*'s trajectory:
the way a participant must show).  What is shared by every domain is here: reading and
checking the teach output, the rows and titles, the page layout.  Each domain draws its own
panels (its ``render_sheet``, e.g. teaching/domains/<name>/sheet.py).
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # figures are written to files; no display on servers

import matplotlib.pyplot as plt
import numpy as np

from .showtests import is_show
from .table import TrajectoryTable
from .teachout import TeachOutputError, check_against, read_teach

OPTION_LETTERS = "ABCD"


class SheetError(ValueError):
    """Inputs the sheet cannot be drawn from: reported as one line, exit status 2."""


@dataclass(frozen=True)
class Panel:
    """One drawing: θ `theta_index`'s trajectory in the table's environment row `env_index`."""

    env_index: int
    theta_index: int
    title: str


def cluster_name(domain, c: int) -> str:
    """The strategy cluster's name in `domain`, or 'cluster c' if it has none."""
    return domain.cluster_names[c] if 0 <= c < len(domain.cluster_names) else f"cluster {c}"


def load_teach(*, teach_dir, table) -> tuple[dict[str, list[int]], list[dict] | None, str | None]:
    """Read and check ``teach_dir`` (the output of ``python -m teaching teach``, teaching.core.teachout)
    against ``table``.

    Returns (conditions: name -> environment ids in showing order, tests: test_set.json's list or
    None, why there are no tests or None).  Raises SheetError when the directory is missing or
    malformed, or was made from another table (sequences.json's content hash differs).
    """
    try:
        output = read_teach(teach_dir)
        check_against(output, table)
    except TeachOutputError as exc:
        raise SheetError(str(exc)) from None
    return output.conditions, output.tests, output.no_tests


def sheet_rows(*, table, conditions, tests, columns: int, head=None) -> list[tuple[str, list[Panel]]]:
    """(row label, panels) for every condition (wrapped at `columns` panels) and every test.
    head(m): the first line of table row m's panel titles (default: its id and class)."""
    row_of = table.row_of
    cls = np.asarray(table.env_class)
    strat = np.asarray(table.strategy)
    domain = table.domain
    if head is None:
        def head(m: int) -> str:
            return f"env {int(table.env_ids[m])} · {domain.class_names[cls[m]]}"

    rows = []
    for name, ids in conditions.items():
        panels = [Panel(row_of[e], 0,
                        f"{k + 1}. {head(row_of[e])}\nθ* → {cluster_name(domain, int(strat[row_of[e], 0]))}")
                  for k, e in enumerate(ids)]
        if not panels:
            rows.append((f"{name}\n(no examples)", []))
        for lo in range(0, len(panels), columns):
            label = f"{name}\n{len(panels)} example{'s' * (len(panels) != 1)}" if lo == 0 else f"{name}\n(cont.)"
            rows.append((label, panels[lo:lo + columns]))
    for j, t in enumerate(tests or []):
        m = row_of[int(t["env_id"])]
        if is_show(t):
            shows = cluster_name(domain, int(strat[m, 0]))
            worse = f" · {t['share_worse']:.0%} of θ worse" if "share_worse" in t else ""
            label = cluster_name(domain, int(t.get("cluster", strat[m, 0]))).replace(": ", ":\n")
            rows.append((f"test {j + 1} · show\n{label}", [Panel(m, 0, f"{head(m)}\nθ* (θ0) → {shows}{worse}")]))
            continue
        panels = []
        for letter, o in zip(OPTION_LETTERS, t["options"], strict=False):
            th = int(o["theta_index"])
            who = "θ* (θ0)" if th == 0 else f"θ{th}"
            regret = f" · regret {o['regret']:.3g}" if "regret" in o and th != 0 else ""
            shows = cluster_name(domain, int(strat[m, th]))
            panels.append(Panel(m, th, f"{letter}. {head(m)}\n{who} → {shows}{regret}"))
        rows.append((f"test {j + 1}\n" + str(t.get("cluster_name", "")).replace(": ", ":\n"), panels))
    return rows


def render_rows(*, rows: list[tuple[str, list[Panel]]], draw: Callable, out, columns: int, panel_width: float,
                panel_height: float, dpi: int, header: list[str], legend: list, no_tests: str | None = None) -> int:
    """Lay `rows` out on one page and save it as the PNG `out`; returns the panels drawn.

    draw(ax, panel, k) draws the k-th panel (in row order) on its axes; panel_width, panel_height:
    inches; header: lines of text at the top; legend: matplotlib handles under them."""
    title_h, label_w, head_h = 0.38, 1.4, 1.0
    n_rows = max(len(rows), 1)
    fig_w = label_w + columns * (panel_width + 0.15)
    fig_h = head_h + n_rows * (panel_height + title_h) + (0.4 if no_tests else 0)
    fig = plt.figure(figsize=(fig_w, fig_h))
    k = 0
    for r, (label, ps) in enumerate(rows):
        top = fig_h - head_h - r * (panel_height + title_h) - title_h
        fig.text(0.1 / fig_w, (top - panel_height / 2) / fig_h, label, ha="left", va="center", fontsize=8,
                 weight="bold" if not label.endswith("(cont.)") else "normal")
        for c, p in enumerate(ps):
            ax = fig.add_axes(((label_w + c * (panel_width + 0.15)) / fig_w, (top - panel_height) / fig_h,
                               panel_width / fig_w, panel_height / fig_h))
            draw(ax, p, k)
            ax.set_title(p.title, fontsize=7.5, loc="left", pad=2, linespacing=1.15)
            k += 1
    if no_tests:
        fig.text(label_w / fig_w, 0.2 / fig_h, f"no test set in this teach output: {no_tests}", fontsize=8,
                 color="#b00020", va="center")
    fig.text(0.1 / fig_w, 1 - 0.1 / fig_h, "\n".join(header), ha="left", va="top", fontsize=7.5, linespacing=1.4)
    fig.legend(handles=legend, loc="upper left", ncol=4, fontsize=7.5, frameon=False,
               bbox_to_anchor=(0.05 / fig_w, 1 - 0.62 / fig_h))
    try:
        fig.savefig(out, dpi=dpi)
    finally:
        plt.close(fig)
    return k


def make_sheet(*, table_dir, teach_dir, out, **kwargs) -> tuple[int, str | None]:
    """Load and check the table and teach output, write the PNG `out` (drawn by the table's domain).

    Returns (panels drawn, why the teach output has no tests or None).  Raises SheetError
    (or teaching.core.table.TableError) for unusable inputs or an unwritable `out`.
    """
    table = TrajectoryTable.load(table_dir)
    conditions, tests, no_tests = load_teach(teach_dir=teach_dir, table=table)
    out = Path(out)
    if out.suffix.lower() != ".png":
        raise SheetError(f"--out must name a .png file, got {out}")
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        caption = (f"Contact sheet: table {table_dir} (domain {table.domain.name}, preset {table.meta.get('preset')}, "
                   f"hash {str(table.meta.get('content_hash'))[:16]}), teach output {teach_dir}")
        n = table.domain.render_sheet(table=table, conditions=conditions, tests=tests, out=out, no_tests=no_tests,
                                      caption=caption, **kwargs)
    except OSError as exc:
        where = f" ({exc.filename})" if exc.filename and str(exc.filename) != str(out) else ""
        raise SheetError(f"cannot write {out}: {exc.strerror or exc}{where}") from None
    return n, no_tests
