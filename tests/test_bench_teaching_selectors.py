"""bench/teaching_selectors.py's generated section of docs/benchmarks.md: the bar's verdict is computed
from the figures (met / not met for SCOT and bec-scaffold on a paper-size table, nothing elsewhere),
and --json then --update-doc rewrite only the text between the markers."""
from __future__ import annotations

import json

from bench import teaching_selectors as bench
from teaching.domains.driving.synthetic import synthetic_table


def figures(tables: list[dict]) -> dict:
    return {"argv": "--table T", "date": "2026-01-01 00:00 UTC", "cpu_count": 2, "load_start": 0.5,
            "load_end": 1.5, "tables": tables}


def table(path: str, envs: int, thetas: int, rows: dict[str, float]) -> dict:
    return {"table": path, "shape": [envs, thetas, 5], "load_start": 0.5, "load_end": 1.0,
            "distances_seconds": 3.0, "waited_seconds": 0.0,
            "selectors": [{"name": n, "seconds": s, "length": 20, "load_start": 0.5, "load_end": 1.0}
                          for n, s in rows.items()]}


def row(md: str, path: str, name: str) -> str:
    [line] = [ln for ln in md.splitlines() if ln.startswith(f"| `{path}` |") and f"| {name} |" in ln]
    return line


def test_the_bar_is_met_or_not_from_the_figures_on_the_paper_table_only():
    paper = table("var/tables/paper", 21216, 1000, {"scot": 90.0, "bec-scaffold": 150.0, "highlights": 200.0})
    demo = table("var/tables/demo", 1200, 200, {"scot": 300.0, "bec-scaffold": 1.0})
    md = bench.markdown(figures([demo, paper]))
    assert md.startswith(bench.BEGIN) and md.endswith(bench.END)
    assert row(md, "var/tables/paper", "scot").endswith("≤ 120 s: **met** |")
    assert row(md, "var/tables/paper", "bec-scaffold").endswith("≤ 120 s: **not met** |")
    for path, name in (("var/tables/paper", "highlights"), ("var/tables/demo", "scot"),
                       ("var/tables/demo", "bec-scaffold")):
        assert row(md, path, name).endswith("|  |"), (path, name)  # no bar there
    assert "| 21,216 × 1,000 |" in row(md, "var/tables/paper", "scot")


def test_json_then_update_doc_rewrites_only_the_section(tmp_path):
    synthetic_table(120, 20, n_candidates=6, seed=3).save(tmp_path / "table")
    out = tmp_path / "figures.json"
    assert bench.main(["--table", f"{tmp_path / 'table'}:highlights,random", "--json", str(out)]) == 0
    fig = json.loads(out.read_text())
    assert fig["cpu_count"] and len(fig["tables"]) == 1
    assert [r["name"] for r in fig["tables"][0]["selectors"]] == ["highlights", "random"]
    assert fig["tables"][0]["shape"][:2] == [120, 20]
    doc = tmp_path / "benchmarks.md"
    doc.write_text(f"# before\n\n{bench.BEGIN}\nstale\n{bench.END}\n\n# after\n")
    assert bench.main(["--update-doc", str(out), str(doc)]) == 0
    text = doc.read_text()
    assert text.startswith("# before\n\n") and text.endswith("\n\n# after\n") and "stale" not in text
    assert text.count(bench.BEGIN) == 1 and "| highlights |" in text and "| random |" in text
