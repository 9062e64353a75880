"""``python -m teaching benchmark --table TABLE [--table ...] --out DIR``: every selector x every learner x seeds
on each table, resumable, and a summary per table (stdout and DIR/summary.md)."""
from __future__ import annotations

import argparse
import json
from pathlib import Path

from tqdm import tqdm

HELP = "every selector x every learner x several seeds on tables: learning curves, resumable (docs/benchmark.md)"


def add_arguments(parser: argparse.ArgumentParser, out_default=None) -> None:
    """The command's arguments; out_default: a default results folder (else --out is required)."""
    parser.add_argument("--table", action="append", required=True, metavar="TABLE",
                        help="a trajectory table directory (give several to benchmark several)")
    parser.add_argument("--out", required=out_default is None, default=out_default, metavar="DIR",
                        help="the results folder (a rerun resumes it)"
                             + ("" if out_default is None else f"; default {out_default}"))
    parser.add_argument("--seeds", type=int, default=10, help="seeds per (selector, learner) (default 10)")
    parser.add_argument("--selector", action="append", metavar="NAME",
                        help="only this selector (repeatable; default: every registered one)")
    parser.add_argument("--learner", action="append", metavar="NAME",
                        help="only this learner model (repeatable; default: every one)")
    parser.add_argument("--hyper", action="append", metavar="MODEL=VALUE",
                        help="fix a learner model's τ / λ (repeatable), e.g. the value `fit_models` found; the others "
                             "are chosen by the paper's rule on each table")
    parser.add_argument("--leaderboard", metavar="PAGE.md",
                        help="also write the leaderboard page there, its figures under figures/leaderboard/ beside it")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")


def plan(args) -> list[tuple[str, object, list]]:
    """(table path, table, its cells) for each --table, as the arguments ask; ValueError (one line) for a bad one."""
    from ..core.learners import parse_hyperparameters  # noqa: PLC0415  (the command's own imports, as build's)
    from ..core.table import TrajectoryTable  # noqa: PLC0415
    from .cells import plan_cells  # noqa: PLC0415

    hyper = parse_hyperparameters(args.hyper or [])
    tables = [(path, TrajectoryTable.load(path)) for path in args.table]
    return [(path, table, plan_cells(table.meta["content_hash"], selectors=args.selector, learners=args.learner,
                                     seeds=args.seeds, hyper=hyper)) for path, table in tables]


def write_summary(out: Path, done: list[tuple[str, object, list[dict]]], leaderboard=None) -> str:
    """summary.md and summary.json in `out`, and each table's board in out/tables/ (board.py), from (table path,
    table, its results) of each table; the leaderboard page too if one is named.  Returns the summary's Markdown."""
    from .board import board, write_board  # noqa: PLC0415  (the command's own imports, as build's)
    from .summary import markdown, mismatch_markdown, read_costs  # noqa: PLC0415

    text, summary, costs, boards = [], {}, read_costs(out), []
    for path, table, results in done:
        boards.append(board(path, table, results, costs, out))
        write_board(out, boards[-1][0])
        rows = boards[-1][1]
        title = f"{table.domain.name}: {path} ({table.n_envs:,} environments x {table.n_thetas:,} objectives)"
        text.append(markdown(rows, title))
        matrix = mismatch_markdown(rows)
        if matrix:
            text.append("Mismatch matrix (Lage et al.): mean P(θ*) at the end of the sequence built for one learner "
                        "model (rows) as another learns it (columns); the diagonal in bold.\n\n" + matrix)
        summary[str(path)] = [r.__dict__ for r in rows]
    (out / "summary.md").write_text("\n".join(text), encoding="utf-8")
    (out / "summary.json").write_text(json.dumps(summary, indent=1, default=str), encoding="utf-8")
    if leaderboard:
        from .leaderboard import write_leaderboard  # noqa: PLC0415  (matplotlib, only when a page is asked for)

        write_leaderboard(leaderboard, boards)
    return "\n".join(text)


def command(args) -> int:
    from .run import run_cells, timed  # noqa: PLC0415

    out = Path(args.out)
    planned = plan(args)
    done = []
    for path, table, cells in planned:
        with tqdm(total=len(cells), unit="cell", desc=f"benchmark {table.meta.get('preset')}",
                  disable=args.no_progress) as bar:
            def compute(table=table, cells=cells, bar=bar):
                return run_cells(table, cells, out, progress=lambda n, total: bar.update(n - bar.n))
            done.append((path, table, timed(out, table.meta["content_hash"], cells, "in one process", compute)))
    print(write_summary(out, done, args.leaderboard))
    print(f"wrote {out}/summary.md and {out}/summary.json ({sum(len(c) for *_, c in planned):,} cells)"
          + (f" and {args.leaderboard}" if args.leaderboard else ""))
    return 0
