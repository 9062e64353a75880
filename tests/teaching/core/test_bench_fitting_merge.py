"""bench/fitting.py --merge: runs of disjoint generators joined into the figures one run of them all
would write (the documented recovery table of docs/bench_fitting.json, split in two and joined back),
and runs that do not belong together refused."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
BENCH = ROOT / "bench" / "fitting.py"


def split(recovery: dict, generators: list[str]) -> dict:
    """The part of a full run's figures that a --generators run of `generators` would hold."""
    index = [list(recovery["generators"]).index(g) for g in generators]
    part = {k: recovery[k] for k in ("table", "reps", "lapse")}
    part["generators"] = {g: recovery["generators"][g] for g in generators}
    part["sizes"] = {}
    for n, s in recovery["sizes"].items():
        share = len(generators) / len(recovery["generators"])
        part["sizes"][n] = {"seconds": s["seconds"] * share, "fitted": s["fitted"],
                            "confusion": [s["confusion"][i] for i in index],
                            "confused": [c for c in s["confused"] if c[0] in generators],
                            **{k: {g: s[k][g] for g in generators if g in s[k]}
                               for k in ("unfitted", "ties", "recovered", "lapse_recovered", "value_recovered",
                                         "median_lapse", "median_value")}}
    return part


def documented() -> dict:
    """The documented full run's recovery figures (ties, where that run predates them: none)."""
    full = json.loads((ROOT / "docs" / "bench_fitting.json").read_text())["recovery"]
    for s in full["sizes"].values():
        s.setdefault("ties", {g: [] for g in full["generators"]})
    return full


def run(tmp_path, *parts: dict, out: str = "merged.json"):
    files = []
    for k, part in enumerate(parts):
        files.append(tmp_path / f"part{k}.json")
        files[-1].write_text(json.dumps({"recovery": part}))
    return subprocess.run([sys.executable, str(BENCH), "--merge", *map(str, files), "--json", str(tmp_path / out)],
                          capture_output=True, text=True, timeout=300)


def test_split_runs_merge_into_the_full_runs_figures(tmp_path):
    full = documented()
    names = list(full["generators"])
    done = run(tmp_path, split(full, names[:2]), split(full, names[2:]))
    assert done.returncode == 0, done.stderr[-2000:]
    merged = json.loads((tmp_path / "merged.json").read_text())["recovery"]
    for n, s in full["sizes"].items():
        got = merged["sizes"][n]
        assert abs(got.pop("seconds") - s["seconds"]) < 1e-6 * s["seconds"]
        assert got == {k: v for k, v in s.items() if k != "seconds"}
    assert list(merged["generators"]) == names


def test_runs_that_do_not_belong_together_are_refused(tmp_path):
    full = documented()
    names = list(full["generators"])
    overlapping = run(tmp_path, split(full, names[:3]), split(full, names[2:]))
    assert overlapping.returncode != 0 and "disjoint generators" in overlapping.stderr
    other_table = {**split(full, names[3:]), "table": "0" * 64}
    mixed = run(tmp_path, split(full, names[:3]), other_table)
    assert mixed.returncode != 0 and "differ in table" in mixed.stderr
    assert not (tmp_path / "merged.json").exists()
