"""The command line's table-folder commands (``python -m teaching check-table DIR``, ``export-table`` and
``import-table``)."""
from __future__ import annotations

import argparse

from .folder import TableFolderError, read_folder

CHECK_HELP = "check a table folder of your own robot's data (docs/importing.md) and say what is wrong, in one line"
IMPORT_HELP = ("make a checked table folder the platform's table, which teach, the designer and studies use "
               "(docs/importing.md)")
EXPORT_HELP = "write a built table as a table folder (docs/importing.md): the format's example, from a robot we have"


def add_check_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("folder", metavar="DIR", help="a folder holding table.toml and its data file")


def check_command(args) -> int:
    """Exit 0 with a summary when the folder can be used, 1 with its first mistake when not."""
    try:
        folder = read_folder(args.folder)
    except TableFolderError as exc:
        print(f"error: {exc}")
        return 1
    m, n, d = folder.phi.shape
    print(f"{folder.name}: {m:,} environments x {n:,} objectives (θ* and {n - 1:,} candidates) x {d} features "
          f"({', '.join(folder.feature_names)})")
    print(f"classes: {', '.join(folder.classes) or 'none'}; strategies: {len(folder.strategies)}; distances: "
          f"{'given' if folder.distance is not None else 'not given'}")
    print(folder.optimality.describe() + (" (kept: keep_suboptimal = true)" if not folder.optimality.optimal else ""))
    return 0


def add_export_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("table", metavar="TABLE", help="a trajectory table directory (python -m teaching build)")
    parser.add_argument("--out", required=True, help="the folder to write (new or empty)")


def export_command(args) -> int:
    from ..core.table import TrajectoryTable  # noqa: PLC0415
    from .export import DATA, PATHS, export_table  # noqa: PLC0415

    try:
        out = export_table(TrajectoryTable.load(args.table), args.out)
    except FileExistsError as exc:
        raise ValueError(str(exc)) from None
    print(f"wrote {out}/table.toml, {out}/{DATA} and {out}/{PATHS}")
    return 0


def add_import_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("folder", metavar="DIR", help="a folder holding table.toml and its data file")
    parser.add_argument("--out", required=True, metavar="TABLE", help="the table directory to write (new or empty)")


def import_command(args, summary) -> int:
    """Exit 0 with the table's summary, 1 with the folder's first mistake (nothing written)."""
    from .convert import import_table  # noqa: PLC0415

    try:
        table = import_table(args.folder, args.out)
    except TableFolderError as exc:
        print(f"error: {exc}")
        return 1
    print(summary(table))
    print(f"imported {table.n_envs:,} environments x {table.n_thetas:,} objectives -> {args.out}")
    if table.meta["imported"]["keep_suboptimal"]:
        print(f"kept although not optimal (keep_suboptimal = true): {table.meta['imported']['optimality']}")
    return 0

