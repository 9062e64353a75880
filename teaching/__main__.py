"""Command line: ``python -m teaching build --preset demo --out var/tables/demo``.

Sub-commands (installed as a package, ``teaching`` is the same command):
  build   build (or resume) a trajectory table from a preset, with a progress bar
  info    print a table's identity and a summary (strategy counts, d_reward check)
  teach   teaching sequences, test set, ideal-user matrix and figures of a table (teaching/teach.py)
  sheet   draw every training example and test option of a teach output as one PNG
  check-domain  check a domain's contracts (its members, plan_chunk's arrays, d_reward, labels, page keys,
                palette, test-set feasibility): exit 0 when all pass, 1 when one fails, 2 for bad arguments
  check-table   check a table folder of a robot's own data (docs/importing.md): exit 0 when it can be
                used, 1 with its first mistake in one line
  export-table  write a built table as a table folder
  import-table  make a checked table folder the platform's table (with the robot it carries): exit 0, or 1
                with the folder's first mistake in one line
  benchmark     every selector x every learner x seeds on tables: learning curves, resumable
"""
from __future__ import annotations

import argparse
import sys
import time

import numpy as np
from tqdm import tqdm

from .benchmark import commands as benchmark_commands
from .core.build import PRESETS, build_table, customised, get_preset
from .core.candidates import SAMPLERS
from .core.checkdomain import CHECKS, DEFAULT_ENVS, check_domain, default_preset
from .core.domain import domain_names, get_domain
from .core.table import TableError, TrajectoryTable
from .core.testset import MIN_REGRET
from .importing import commands as folder_commands
from .teach import DESCRIPTION as TEACH_DESCRIPTION
from .teach import add_arguments as add_teach_arguments
from .teach import command as teach_command


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


def check_domain_command(args) -> int:
    """Run check-domain; 0 when every check passes, 1 when one fails (bad arguments raise ValueError)."""
    domain = get_domain(args.name)
    presets = {p.name: p for p in domain.presets} if hasattr(domain, "presets") else {}  # else: the members check says
    if hasattr(domain, "presets") and not presets:
        raise ValueError(f"{domain.name} has no presets to plan: check-domain checks a robot's planner, and a table "
                         "imported from a robot's own files was checked when it was imported (check-table)")
    if args.preset is not None and args.preset not in presets:
        raise ValueError(f"unknown preset {args.preset!r} for domain {domain.name}; choose one of {', '.join(presets)}")
    if args.envs < 1:
        raise ValueError(f"--envs must be at least 1, got {args.envs}")
    if args.min_option_distance is not None and not args.min_option_distance >= 0:
        raise ValueError(f"--min-option-distance must be >= 0, got {args.min_option_distance}")
    preset = presets[args.preset] if args.preset else default_preset(domain) if presets else None
    print(f"check-domain {domain.name}, " + (
        f"preset {preset.name} ({preset.n_envs:,} environments × {preset.n_thetas} θ), a sample of "
        f"{min(args.envs, preset.n_envs):,} environments" if preset else "no presets"), flush=True)
    start, results = time.time(), []
    for result in check_domain(domain, preset, n_envs=args.envs, min_regret=args.min_regret,
                               min_distance=args.min_option_distance,
                               log=lambda line: print(f"  ... {line}", file=sys.stderr, flush=True)):
        results.append(result)
        lines = [f"FAIL  {result.check}: {f}" for f in result.failures] or [f"ok    {result.check}: {result.summary}"]
        print("\n".join(lines), flush=True)
    done = {r.check for r in results}
    needs = "every member of the interface" if not results[0].ok else "plan_chunk's arrays in their shapes and dtypes"
    for check in CHECKS:
        if check not in done:
            print(f"skip  {check}: needs {needs}")
    failed = [r.check for r in results if not r.ok]
    took = f"{time.time() - start:.1f} s"
    if failed or len(done) < len(CHECKS):
        skipped = f", {len(CHECKS) - len(done)} skipped" if len(done) < len(CHECKS) else ""
        print(f"{domain.name}: {len(failed)} of {len(CHECKS)} checks fail ({', '.join(failed)}){skipped} ({took})")
        return 1
    print(f"{domain.name}: all {len(CHECKS)} checks pass ({took})")
    return 0


def _features_by_domain() -> str:
    """'driving: closeness, ...; gridworld: ...': each registered domain's features, in θ's order."""
    return "; ".join(f"{name}: {', '.join(f.replace('_', ' ') for f in get_domain(name).feature_names)}"
                     for name in domain_names())


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m teaching", description="Trajectory tables and teaching: "
                                     "build, info, teach, sheet, check-domain, check-table, export-table, "
                                     "import-table and benchmark.")
    sub = parser.add_subparsers(dest="command", required=True)
    b = sub.add_parser("build", help="build or resume a trajectory table")
    b.add_argument("--preset", required=True, help=f"one of: {', '.join(PRESETS)}")
    b.add_argument("--out", required=True, help="output directory")
    b.add_argument("--thetas", type=int, help="override the number of candidate thetas (>= 2)")
    b.add_argument("--theta-star", help="the robot's objective theta*: one negative weight per feature of the "
                   f"preset's domain, written --theta-star=v1,v2,... ({_features_by_domain()}; default: the domain's)")
    b.add_argument("--sampler", choices=SAMPLERS, help="override how the other thetas are drawn")
    b.add_argument("--seed", type=int, help="override the seed of the theta (and environment) sample")
    b.add_argument("--jobs", type=int, default=1,
                   help="worker processes (default 1: one process, every core as a thread); the paper "
                        "preset builds fastest with one per core; the table is the same either way")
    i = sub.add_parser("info", help="summarise a table")
    i.add_argument("path")
    add_teach_arguments(sub.add_parser("teach", help="teaching sequences, test set and ideal-user matrix of a table",
                                       description=TEACH_DESCRIPTION))
    s = sub.add_parser("sheet", help="contact sheet: every training example and test option, one PNG")
    s.add_argument("--table", required=True, help="trajectory table directory")
    s.add_argument("--teach", required=True, help="output directory of python -m teaching teach")
    s.add_argument("--out", required=True, help="PNG file to write")
    s.add_argument("--columns", type=int, default=5, help="panels per row before a sequence wraps")
    s.add_argument("--dpi", type=int, default=140)
    c = sub.add_parser(
        "check-domain", help="check a domain's contracts before building and teaching on it",
        description="Check a domain against the contracts the core and the study's pages rely on: every member "
                    "of the interface's parts (teaching/core/domain.py), plan_chunk's shapes and dtypes, d_reward "
                    ">= 0 (each θ's own trajectory the best under θ), labels in range, "
                    "page_keys against scene_payload, the palette against the colours its scene reads, and each "
                    "test cluster's test-set feasibility on the preset. Plans a small sample of the preset's "
                    f"environments (--envs, default {DEFAULT_ENVS}: seconds); the test-set search plans more of the "
                    "preset's environments only while a test cluster has no test environment. Every failure is one "
                    "line; exit 0 when all pass, 1 when any fails, 2 for bad arguments.")
    c.add_argument("name", metavar="NAME", help=f"the domain: one of {', '.join(domain_names())}")
    c.add_argument("--preset", help="one of the domain's presets (default: its second-smallest, the demo size)")
    c.add_argument("--envs", type=int, default=DEFAULT_ENVS,
                   help=f"environments sampled from the preset for the checks (default {DEFAULT_ENVS})")
    c.add_argument("--min-regret", type=float, default=MIN_REGRET, help="the test set's (as python -m teaching teach)")
    c.add_argument("--min-option-distance", type=float, default=None,
                   help="the test set's (as python -m teaching teach; default: the domain's). A tiny preset's few θ "
                        "rarely give options the default distance apart: the app's tests use 0.1 on them.")
    folder_commands.add_check_arguments(sub.add_parser("check-table", help=folder_commands.CHECK_HELP))
    folder_commands.add_export_arguments(sub.add_parser("export-table", help=folder_commands.EXPORT_HELP))
    folder_commands.add_import_arguments(sub.add_parser("import-table", help=folder_commands.IMPORT_HELP))
    benchmark_commands.add_arguments(sub.add_parser("benchmark", help=benchmark_commands.HELP))
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
        elif args.command == "check-domain":
            return check_domain_command(args)
        elif args.command == "teach":
            return teach_command(args)
        elif args.command == "check-table":
            return folder_commands.check_command(args)
        elif args.command == "export-table":
            return folder_commands.export_command(args)
        elif args.command == "import-table":
            return folder_commands.import_command(args, summary)
        elif args.command == "benchmark":
            return benchmark_commands.command(args)
        else:
            print(summary(TrajectoryTable.load(args.path)))
    except (ValueError, TableError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
