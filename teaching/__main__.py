"""Command line: ``python -m teaching build --preset demo --out var/tables/demo``.

Sub-commands:
  build   build (or resume) a trajectory table from a preset, with a progress bar
  info    print a table's identity and a summary (strategy counts, d_reward check)
  sheet   draw every training example and test option of a teach output as one PNG
"""
from __future__ import annotations

import argparse
import sys
import time

import numpy as np
from tqdm import tqdm

from .core.build import PRESETS, build_table, customised, get_preset
from .core.candidates import SAMPLERS
from .core.table import TableError, TrajectoryTable


def summary(table: TrajectoryTable) -> str:
    lines = [
        f"table: domain={table.domain.name} preset={table.meta.get('preset')} envs={table.n_envs} "
        f"thetas={table.n_thetas} "
        f"hash={table.meta.get('content_hash', '')[:16]}",
        f"theta*: {[float(v) for v in table.thetas[0]]}",
        f"min d_reward: {float(table.d_reward().min()):.3g} (must be >= 0)",
        "theta* strategies per cluster:",
    ]
    star = np.asarray(table.strategy[:, 0])
    domain = table.domain
    for c, name in enumerate(domain.cluster_names):
        lines.append(f"  {name:32s} {int((star == c).sum()):6d}")
    cls = table.env_class
    lines.append("environments per class: "
                 + ", ".join(f"{n} {int((cls == i).sum())}" for i, n in enumerate(domain.class_names)))
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m teaching", description=__doc__.split("\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    b = sub.add_parser("build", help="build or resume a trajectory table")
    b.add_argument("--preset", required=True, help=f"one of: {', '.join(PRESETS)}")
    b.add_argument("--out", required=True, help="output directory")
    b.add_argument("--thetas", type=int, help="override the number of candidate thetas (>= 2)")
    b.add_argument("--theta-star", help="the robot's objective theta*: one negative weight per feature of the "
                   "preset's domain, written --theta-star=v1,v2,... (driving: closeness, acceleration, speed, "
                   "turning, goal; gridworld: carry moves, cart moves, mud, near dog; default: the domain's)")
    b.add_argument("--sampler", choices=SAMPLERS, help="override how the other thetas are drawn")
    b.add_argument("--seed", type=int, help="override the seed of the theta (and environment) sample")
    b.add_argument("--jobs", type=int, default=1,
                   help="worker processes (default 1: one process, every core as a thread); the paper "
                        "preset builds fastest with one per core; the table is the same either way")
    i = sub.add_parser("info", help="summarise a table")
    i.add_argument("path")
    s = sub.add_parser("sheet", help="contact sheet: every training example and test option, one PNG")
    s.add_argument("--table", required=True, help="trajectory table directory")
    s.add_argument("--teach", required=True, help="output directory of python -m teaching.teach")
    s.add_argument("--out", required=True, help="PNG file to write")
    s.add_argument("--columns", type=int, default=5, help="panels per row before a sequence wraps")
    s.add_argument("--dpi", type=int, default=140)
    args = parser.parse_args(argv)
    try:
        if args.command == "build":
            preset = get_preset(args.preset)
            if args.jobs < 1:
                raise ValueError(f"--jobs must be at least 1, got {args.jobs}")
            if args.thetas is not None and args.thetas < 2:
                raise ValueError(f"--thetas must be at least 2 (theta* and one other), got {args.thetas}")
            try:
                preset = customised(preset, n_thetas=args.thetas, theta_star=args.theta_star, sampler=args.sampler,
                                    seed=args.seed)
            except ValueError as exc:
                raise ValueError(f"--theta-star: {exc}") from None
            n = preset.env_ids().size
            start = time.time()
            with tqdm(total=n, unit="env", desc=f"building {preset.name}") as bar:
                def progress(done, total):
                    bar.update(done - bar.n)
                    bar.set_postfix(traj_s=f"{done * preset.n_thetas / (time.time() - start):.0f}")
                table = build_table(preset, args.out, progress, jobs=args.jobs)
            print(summary(table))
            print(f"built {n * preset.n_thetas:,} trajectories in {time.time() - start:.1f} s -> {args.out}")
        elif args.command == "sheet":
            # matplotlib loads only for this command
            from .core.sheet import make_sheet  # noqa: PLC0415

            if args.columns < 1 or args.dpi < 10:
                raise ValueError(f"--columns must be >= 1 and --dpi >= 10, got {args.columns} and {args.dpi}")
            n, no_tests = make_sheet(table_dir=args.table, teach_dir=args.teach, out=args.out,
                                     columns=args.columns, dpi=args.dpi)
            if no_tests:
                print(f"note: the teach output has no test set ({no_tests}); drew the training examples only")
            print(f"drew {n} panels -> {args.out}")
        else:
            print(summary(TrajectoryTable.load(args.path)))
    except (ValueError, TableError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
