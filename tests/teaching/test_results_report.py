"""scripts/results_report.py: docs/results.md generated from a table and its teach outputs."""
import importlib.util
import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

from teaching.core.selection import CONDITIONS
from teaching.domains.driving.synthetic import synthetic_table
from teaching.teach import main as teach_main
from tests.teaching.domains.worlds.shipped import shipped, teach_show

SCRIPT = Path(__file__).resolve().parents[2] / "scripts" / "results_report.py"
_spec = importlib.util.spec_from_file_location("results_report", SCRIPT)
report = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(report)

HEADINGS = ("# Results", "## θ*'s strategy per environment", "## Chosen hyperparameters", "## Sequences",
            "## Examples per strategy cluster", "## Ideal-user matrix", "## Test set", "## Exact IRL's tolerance",
            "## The paper table")

SELECTORS = ("--selector", "scot", "--selector", "highlights:k=3")


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    root = tmp_path_factory.mktemp("report")
    synthetic_table(200, 40, n_candidates=6, seed=8).save(root / "table")
    assert teach_main(["--table", str(root / "table"), "--out", str(root / "teach"), "--no-progress",
                       *SELECTORS]) == 0
    return root


@pytest.fixture(scope="module")
def generated(inputs):
    out = inputs / "docs" / "results.md"
    assert report.main(["--table", str(inputs / "table"), "--teach", str(inputs / "teach"), "--out", str(out),
                        "--planner-precision", "quoted verbatim: 42 %"]) == 0
    return out, out.read_text()


def test_every_section_and_identity(inputs, generated):
    out, text = generated
    for h in HEADINGS:
        assert re.search(rf"^{re.escape(h)}", text, re.M), h
    meta = json.loads((inputs / "table" / "meta.json").read_text())
    assert meta["content_hash"] in text and meta["world"] in text
    for cond in CONDITIONS:
        assert f"| {cond} |" in text, cond
    assert "python -m teaching teach --table" in text and "scripts/results_report.py" in text
    assert "quoted verbatim: 42 %" in text
    assert "has not been rebuilt" in text  # no paper table given
    for png in ("sim_users.png", "examples_shown.png"):
        assert (out.parent / "figures" / png).read_bytes()[:4] == b"\x89PNG"
        assert f"(figures/{png})" in text


def test_the_header_names_the_teach_command_with_its_selectors(inputs, generated):
    _, text = generated
    header = text.split("```")[1]
    assert (f"python -m teaching teach --table {inputs / 'table'} --out {inputs / 'teach'} "
            "--selector scot --selector highlights:k=3\n") in header


def test_the_matrix_shows_every_sequence_and_its_length(inputs, generated):
    _, text = generated
    section = text.split("## Ideal-user matrix")[1].split("\n## ")[0]
    seqs = json.loads((inputs / "teach" / "sequences.json").read_text())
    matrix = json.loads((inputs / "teach" / "matrix.json").read_text())
    names = matrix["extended_sequence_names"]
    assert {"scot", "highlights:k=3", "hierarchical"} <= set(names)
    for name in names:
        ids = {**seqs["model_sequences"], **seqs["conditions"]}[name]["env_ids"]
        label = name if name in matrix["sequence_names"] else "*{}*".format(name.replace("*", "\\*"))
        assert f"| {label} | {len(ids)} ({len(set(ids))}) | " in section, name
    # an added selector's P(θ*) is reported under the model it is scored by, not under its own name
    assert re.search(r"^\| scot \| .* \| [\d.]+ \(exact\) \|$", text, re.M)


def test_tolerance_rows_and_exact_sequence_match_teach_outputs(inputs, generated):
    _, text = generated
    section = text.split("## Exact IRL's tolerance")[1].split("\n## ")[0]
    rows = {eps: re.search(rf"^\| {re.escape(eps)} \| (\d+) \| ([\d, ]+) \|", section, re.M)
            for eps in ("0", "1e-07", "1e-06 (default)", "1e-05")}
    assert all(rows.values()), rows
    seqs = json.loads((inputs / "teach" / "sequences.json").read_text())
    exact = seqs["conditions"]["exact"]["env_ids"]
    default = rows["1e-06 (default)"]
    assert int(default.group(1)) == len(exact)
    assert [int(v) for v in default.group(2).split(", ")] == exact
    # the sequences table quotes the same ids, in order
    seq_row = re.search(r"^\| exact \| (\d+) \((\d+)\) \| (.*?) \|", text, re.M)
    assert [int(v) for v in re.findall(r"(\d+) \(", seq_row.group(3))] == exact


def test_paper_table_sections_are_reused(inputs, tmp_path):
    out = tmp_path / "results.md"
    assert report.main(["--table", str(inputs / "table"), "--teach", str(inputs / "teach"), "--out", str(out),
                        "--paper-table", str(inputs / "table"), "--paper-teach", str(inputs / "teach")]) == 0
    paper = out.read_text().split("## The paper table")[1]
    assert "### Exact IRL's tolerance" in paper and "has not been rebuilt" not in paper
    assert (tmp_path / "figures" / "paper_sim_users.png").exists()


def test_missing_teach_dir_is_one_line_error(inputs, tmp_path):
    proc = subprocess.run([sys.executable, str(SCRIPT), "--table", str(inputs / "table"),
                           "--teach", str(tmp_path / "nope"), "--out", str(tmp_path / "r.md")],
                          capture_output=True, text=True)
    assert proc.returncode == 2
    assert proc.stderr.startswith("error:") and proc.stderr.count("\n") == 1 and "Traceback" not in proc.stderr
    assert not (tmp_path / "r.md").exists()


def test_a_bench_section_is_carried_over_when_the_report_is_regenerated(inputs, tmp_path):
    """bench/closedloop.py writes its section into docs/results.md between markers; the report's own inputs
    cannot recompute it, so regenerating the report keeps it as it is."""
    out = tmp_path / "results.md"
    section = ("<!-- bench/closedloop.py: begin -->\n\n## Closed loop\n\n| a | 0.5 |\n\n"
               "<!-- bench/closedloop.py: end -->")
    out.write_text("# an older report\n\nstale text\n\n" + section)
    assert report.main(["--table", str(inputs / "table"), "--teach", str(inputs / "teach"), "--out", str(out)]) == 0
    text = out.read_text()
    assert "stale text" not in text and text.startswith("# Results")
    assert text.count(section) == 1 and text.endswith(section)


def test_the_grid_worlds_section_is_written_from_their_outputs_and_carried_over(inputs, tmp_path_factory, tmp_path):
    """scripts/world_results.py writes each shipped world's part from its table and `teach --tests show`
    output between its markers; rewriting it replaces only that section, and the report keeps it."""
    sys.path.insert(0, str(SCRIPT.parent))
    try:
        import world_results  # noqa: PLC0415  (a script beside results_report.py)
    finally:
        sys.path.remove(str(SCRIPT.parent))
    doc = tmp_path / "results.md"
    doc.write_text("# a report\n\nkept text\n")
    with shipped("taxi") as domain:
        table, teach = teach_show(tmp_path_factory, domain)
        tests = json.loads((teach / "test_set.json").read_text())
        for _ in range(2):  # the second run replaces the first's section
            assert world_results.main(["--world", str(table), str(teach), "--doc", str(doc)]) == 0
    text = doc.read_text()
    assert text.startswith("# a report\n\nkept text\n") and text.count(world_results.BEGIN) == 1
    assert "### Augmented taxi" in text and "--tests show" in text and "#### Ideal-user matrix" in text
    for t in tests:
        assert re.search(rf"\| {t['env_id']} \| {re.escape(domain.cluster_names[t['cluster']])} \| "
                         rf"{t['share_worse']:.3f} \|", text)
    section = text[text.index(world_results.BEGIN):]
    assert report.main(["--table", str(inputs / "table"), "--teach", str(inputs / "teach"), "--out", str(doc)]) == 0
    regenerated = doc.read_text()
    assert regenerated.startswith("# Results") and regenerated.count(section.strip()) == 1
