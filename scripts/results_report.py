"""Write docs/results.md from a trajectory table and the outputs of `python -m teaching teach`.

    .venv/bin/python scripts/results_report.py --table var/tables/demo --teach var/teaching/demo \
        --out docs/results.md [--figures docs/figures] [--planner-precision TEXT] \
        [--paper-table DIR --paper-teach DIR] [--gridworld-table DIR --gridworld-teach DIR]

Every number in the document comes from the table, the teach outputs, or a computation on the
table made here (the exact-IRL tolerance section); nothing is typed by hand.  Bad input (a
missing or corrupt table or teach directory, outputs made from another table) prints one
`error: ...` line and exits with status 2.
"""
from __future__ import annotations

import argparse
import datetime
import json
import os
import re
import shlex
import shutil
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from teaching.core.domain import get_domain, n_clusters  # noqa: E402
from teaching.core.evaluation import grid_cells  # noqa: E402
from teaching.core.learners import EXACT_TOLERANCE, MODEL_NAMES, Distances, make_model, p_theta_star  # noqa: E402
from teaching.core.selection import APPROX_STAR, COVERAGE_EPSILON, MIN_RISE, greedy, showable  # noqa: E402
from teaching.core.selectors import get_selector  # noqa: E402
from teaching.core.showtests import is_show  # noqa: E402
from teaching.core.table import TableError, TrajectoryTable  # noqa: E402

TOLERANCES = (0.0, 1e-7, 1e-6, 1e-5)
TEACH_FILES = ("sequences.json", "matrix.json", "examples_per_cluster.json", "test_set.json")
FIGURES = ("sim_users.png", "examples_shown.png")
GRIDWORLD_PRECISION = ("exact by construction: every non-dominated path of each yard, found by a "
                       "label-setting search and checked against brute-force enumeration and an independent "
                       "Dijkstra in tests/teaching/domains/gridworld/test_gridworld.py (docs/domains.md)")
EXIT_BAD_INPUT = 2


class ReportError(ValueError):
    """Bad input: reported in one line, exit status 2."""


def fmt_p(p) -> str:
    """A probability with enough digits that a value just below 1 does not print as 1."""
    p = float(p)
    if p == 1.0 or p == 0.0:
        return f"{p:g}"
    if p > 0.999:
        return f"{p:.{int(np.ceil(-np.log10(1 - p))) + 1}f}"
    return f"{p:.3g}"


def md_table(header, rows) -> list[str]:
    return ["| " + " | ".join(header) + " |", "|" + "---|" * len(header),
            *("| " + " | ".join(str(c) for c in r) + " |" for r in rows), ""]


def load_inputs(table_dir, teach_dir):
    """(table, {file stem: parsed JSON}); raises ReportError for anything unusable."""
    try:
        table = TrajectoryTable.load(table_dir)
    except TableError as exc:
        raise ReportError(str(exc)) from None
    teach_dir, data = Path(teach_dir), {}
    if not teach_dir.is_dir():
        raise ReportError(f"no teach outputs at {teach_dir} (run python -m teaching teach first)")
    missing = [n for n in TEACH_FILES + FIGURES if not (teach_dir / n).is_file()]
    if missing:
        raise ReportError(f"{teach_dir} lacks {', '.join(missing)} (run python -m teaching teach first)")
    for name in TEACH_FILES:
        try:
            data[name.split(".")[0]] = json.loads((teach_dir / name).read_text())
        except (OSError, ValueError) as exc:
            raise ReportError(f"{teach_dir / name} is unreadable: {exc}") from None
    made_from = data["sequences"].get("table", {}).get("content_hash")
    if made_from != table.meta.get("content_hash"):
        raise ReportError(f"{teach_dir} was made from another table (content hash {made_from}, "
                          f"table {table_dir} has {table.meta.get('content_hash')})")
    return table, data


def _param(hp) -> str:
    return f"{'τ' if hp['param'] == 'tau' else 'λ'} = {hp['value']:g}"


def section_identity(table, data) -> list[str]:
    meta, seq, planner = table.meta, data["sequences"], dict(table.meta.get("planner") or {})
    planner_s = ", ".join(f"{k} = {v}" for k, v in sorted(planner.items(), key=lambda kv: kv[0] != "version"))
    return [f"- **Table**: preset `{meta.get('preset')}`, {table.n_envs:,} environments × {table.n_thetas:,} θ "
            f"(θ* = theta 0, prior P(θ*) = 1/{table.n_thetas} = {fmt_p(1 / table.n_thetas)}), sampler "
            f"`{meta.get('sampler')}`, seed {meta.get('seed')}, built at {meta.get('built_at', '(not recorded)')}.",
            f"- **Content hash**: `{meta.get('content_hash')}`.",
            f"- **World fingerprint**: `{meta.get('world')}`.",
            f"- **Planner**: {planner_s or 'not recorded'}.",
            f"- **Feature normalisers**: {', '.join(f'{v:.6g}' for v in meta.get('normalisers', []))}.",
            f"- **Teach settings** (from `sequences.json`): seed {seq.get('seed')}, approx* = "
            f"`{seq.get('approx_star')}`, coverage ε = {seq.get('epsilon'):g}.", ""]


def section_strategies(table, h) -> list[str]:
    names, none = table.domain.cluster_names, n_clusters(table.domain)
    counts = np.bincount(np.asarray(table.strategy[:, 0], np.int64), minlength=none + 1)
    rows = [(c, names[c], f"{counts[c]:,}") for c in range(len(names))]
    n_show = int(showable(table).sum())
    return [f"{h} θ*'s strategy per environment", "", "Cluster of θ*'s own trajectory in each environment "
            "(`table.strategy[:, 0]`).", "", *md_table(("cluster", "strategy", "environments"), rows),
            f"{n_show:,} of {table.n_envs:,} environments are showable; in the other "
            f"{table.n_envs - n_show:,} θ* shows none of its class's strategies (label {none}), and "
            "they are never shown as examples or used as tests (`teaching.core.selection.showable`).", ""]


def section_hyper(data, h) -> list[str]:
    rows = []
    for name, hp in data["sequences"]["hyperparameters"].items():
        sweep = hp.get("sweep") or []
        chosen = "none" if hp["param"] is None else _param(hp)
        if hp["param"] is None:
            sweep_s = "no hyperparameter"
        elif not sweep:
            sweep_s = "fixed with --hyper" if hp.get("fixed") else "not swept (distance is 0 or ∞: no effect)"
        else:
            parts = []  # (values, description); consecutive values with the same outcome are merged
            for r in sweep:
                desc = (f"{r['n_examples']}/{r['n_unique']}, {fmt_p(r['p'][0])} → {fmt_p(r['p'][-1])}"
                        if r["p"] else "nothing improves P(θ*)")
                chosen_r = r["value"] == hp["value"]
                if parts and parts[-1][1] == desc and not chosen_r and not parts[-1][2]:
                    parts[-1][0].append(r["value"])
                else:
                    parts.append(([r["value"]], desc, chosen_r))
            sweep_s = "; ".join(("**{}**" if c else "{}").format(
                f"{v[0]:g}" + (f"…{v[-1]:g}" if len(v) > 1 else "") + f": {d}") for v, d, c in parts)
        rows.append((name, chosen, {True: "yes", False: "**no**", None: "—"}[hp.get("rule_met")], sweep_s))
    return [f"{h} Chosen hyperparameters", "",
            "Rule (`teaching.core.selection.choose_hyperparameter`): among grid values whose P(θ*) rises by "
            f"≥ {MIN_RISE:g} from after the first to after the last example, the one showing the most unique examples "
            "(ties: higher final P(θ*), then the smaller value). Sweep entries read "
            "value: examples/unique, P(θ*) after first → after last; the chosen value is in bold.", "",
            *md_table(("model", "chosen", "rule met", "sweep"), rows)]


def _env_label(table, env_id, index_of) -> str:
    m = index_of[env_id]
    c, domain = int(table.strategy[m, 0]), table.domain
    none = domain.class_names[table.env_class[m]] + ": none"
    return f"{env_id} ({domain.cluster_names[c] if c < n_clusters(domain) else none})"


def section_sequences(table, data, index_of, h) -> list[str]:
    seq = data["sequences"]

    def model_of(cond):
        s = seq["conditions"][cond]
        name = (get_selector(s["selector"]).scored_by(s["params"]) if "selector" in s else
                {"random": "exact", "coverage-approx*": seq["approx_star"],
                 "coverage-random": seq["approx_star"]}.get(cond, cond))
        hp = seq["hyperparameters"].get(name, {})
        return name if hp.get("param") is None or "strategy" in name else f"{name}, {_param(hp)}"

    rows = []
    for cond, s in seq["conditions"].items():
        ids, cov = s["env_ids"], set(s.get("added_for_coverage", []))
        envs = "<br>".join(_env_label(table, e, index_of) + (" *[coverage]*" if e in cov else "") for e in ids)
        final = fmt_p(s["p_theta_star"][-1]) if s["p_theta_star"] else "— (no example)"
        rows.append((cond, f"{len(ids)} ({len(set(ids))})", envs or "—", f"{final} ({model_of(cond)})"))
    return [f"{h} Sequences", "",
            "Environment ids in the order shown, each with θ*'s strategy there (class: strategy); P(θ*) after "
            "the last example under the condition's own model (random: exact IRL; coverage: approx*; an added "
            "selector: the model its selector scores by).", "",
            *md_table(("condition", "examples (unique)", "environments in order", "final P(θ*) (model)"), rows)]


def section_clusters(domain, data, fig_links, h) -> list[str]:
    grids = data["examples_per_cluster"]["grids"]
    cells = grid_cells(domain.class_of_cluster)  # each cluster's (row, column) in the grids
    rows = [(n, *(int(v) for v in np.asarray(g)[cells])) for n, g in grids.items()]
    return [f"{h} Examples per strategy cluster", "",
            "How many of each sequence's examples show θ* in each cluster (repeats counted).", "",
            *md_table(("sequence", *domain.cluster_names[:n_clusters(domain)]), rows),
            f"![examples shown per cluster]({fig_links['examples_shown.png']})", ""]


def section_matrix(data, fig_links, h) -> list[str]:
    mx, seq = data["matrix"], data["sequences"]
    users, base = mx["user_names"], set(mx["sequence_names"])
    paper = [i for i, u in enumerate(users) if u in MODEL_NAMES]  # the means are over the paper's users
    approx = [i for i in paper if users[i] != "exact"]
    ids = {**seq["model_sequences"], **seq["conditions"]}

    def length(name):
        return f"{len(ids[name]['env_ids'])} ({len(set(ids[name]['env_ids']))})"

    rows = [(name if name in base else "*{}*".format(name.replace("*", "\\*")), length(name),
             *(f"{v:.3f}" for v in r), f"{r[paper].mean():.3f}", f"{r[approx].mean():.3f}")
            for name, r in zip(mx["extended_sequence_names"], np.asarray(mx["extended_matrix"]), strict=False)]
    return [f"{h} Ideal-user matrix", "",
            "Entry = P_user(θ* | the sequence of the row), 3 decimals; beside each row, its sequence's length "
            "(unique examples in brackets). Rows in italics are not in the paper's figure (extended matrix): the "
            "coverage conditions and any selector added with `--selector`; the hierarchical learner (row and "
            "column) is the paper's Discussion's, not in its figure either, and the means leave it out. "
            "Users use the chosen τ/λ: "
            + ", ".join(f"`{m}`" for m in mx["models"].values()) + ".", "",
            *md_table(("sequence \\ user", "examples", *users, f"mean of the paper's {len(paper)}",
                       f"mean of {len(approx)} approximate"), rows),
            f"![ideal-user matrix]({fig_links['sim_users.png']})", ""]


def section_tests(domain, data, h) -> list[str]:
    tests = data["test_set"]
    head = [f"{h} Test set", ""]
    if isinstance(tests, dict):
        return head + [f"No test set on this table: {tests.get('error')}", ""]
    if tests and is_show(tests[0]):
        rows = [(t["env_id"], domain.cluster_names[t["cluster"]], f"{t['share_worse']:.3f}") for t in tests]
        return head + [
            "Show-the-way tests (`teach --tests show`, `teaching/core/showtests.py`): one environment per test "
            "cluster, in no training sequence, where θ* shows that cluster and at least the share below of the "
            "table's θ have a trajectory clearly worse for θ* (regret ≥ min_regret): the participant moves the "
            "robot there, and the way is scored by its regret under θ*.", "",
            *md_table(("env id", "cluster under test", "share of θ worse for θ*"), rows)]
    rows = [(*((t["env_id"], t["cluster_name"], t["rule"], f"{t['min_option_distance']:.3f}") if k == 0 else [""] * 4),
             "ABCD"[k], o["theta_index"], "**yes**" if o["is_theta_star"] else "no", domain.cluster_names[o["cluster"]],
             f"{o['regret']:.3g}") for t in tests for k, o in enumerate(t["options"])]
    n_relaxed = sum(t["rule"] == "relaxed" for t in tests)
    return head + [
        "One environment per cluster, in no training sequence; options in `test_set.json`'s order. "
        "Regret = θ*·φ(ξ^θ*) − θ*·φ(ξ^θ). Rule \"relaxed\" means no unused environment of that cluster had "
        "two θ taking the sibling strategy, so the two remaining options may come from either strategy of "
        f"the class (`teaching/core/testset.py`); {n_relaxed} of {len(tests)} tests use it.", "",
        *md_table(("env id", "cluster under test", "rule", "min option distance", "option", "θ index", "θ*",
                   "strategy", "regret"), rows)]


def tolerance_study(table, data, index_of, dist, tolerances=TOLERANCES) -> list[dict]:
    """Per ε: exact-IRL greedy sequence, P(θ*) of every condition, decisive single environments,
    share of (E, θ≠θ*) pairs that survive only because of the tolerance."""
    off = (dist.reward / dist.theta_norms)[:, 1:]  # normalised reward units, θ ≠ θ*
    eligible, ids, out = showable(table), np.asarray(table.env_ids), []
    for eps in tolerances:
        model = replace(make_model("exact"), tolerance=eps)
        lik = model.likelihood(dist)
        seq, _ = greedy(lik, eligible=eligible)
        decisive = lik[:, 1:].sum(1) == 0
        conds = {c: p_theta_star(model, dist, [index_of[e] for e in s["env_ids"]])
                 for c, s in data["sequences"]["conditions"].items()}
        out.append({"eps": eps, "envs": [int(i) for i in ids[seq.envs]], "conditions": conds,
                    "p": seq.p[-1] if seq.p else 1 / dist.shape[1], "decisive": int(decisive.sum()),
                    "decisive_showable": int((decisive & eligible).sum()), "negative": int((off < 0).sum()),
                    "tolerance_only": float(((off > 0) & (off <= eps)).mean()), "zero": float((off == 0).mean())})
    return out


def section_tolerance(rows, conditions, exact_envs, precision, h) -> list[str]:
    def eps_s(r):
        return f"{r['eps']:g}" + (" (default)" if r["eps"] == EXACT_TOLERANCE else "")

    summary = [(eps_s(r), len(r["envs"]), ", ".join(map(str, r["envs"])) or "—", fmt_p(r["p"]),
                f"{r['decisive']:,} ({r['decisive_showable']:,})", f"{100 * r['tolerance_only']:.4g} %")
               for r in rows]
    per_condition = [(c, *(fmt_p(r["conditions"][c]) for r in rows)) for c in conditions]
    moved = [c for c in conditions if len({round(r["conditions"][c], 12) for r in rows}) > 1]
    changed = [what for what, differs in (
        ("the exact-IRL greedy sequence", len({tuple(r["envs"]) for r in rows}) > 1),
        ("exact-IRL P(θ*) of the sequences of " + ", ".join(moved), bool(moved)),
        ("the number of decisive single environments", len({r["decisive"] for r in rows}) > 1)) if differs]
    eps_list = ", ".join(f"{r['eps']:g}" for r in rows)
    sentence = (f"Across ε ∈ {{{eps_list}}} " + (
        "only the share of tolerance-only pairs changes: on this table the tolerance decides none of "
        "these findings." if not changed else "these findings change: " + "; ".join(changed) + "."))
    neg, default = rows[0]["negative"], [r for r in rows if r["eps"] == EXACT_TOLERANCE]
    neg_s = (f"{100 * rows[0]['zero']:.4g} % of (E, θ≠θ*) pairs have d_reward = 0 exactly (θ's trajectory is "
             "θ*'s); " + (f"{neg:,} have d_reward < 0, which no ε ≥ 0 admits." if neg else "none has d_reward < 0."))
    if default:
        same = default[0]["envs"] == exact_envs
        neg_s += (" At the default ε the greedy sequence " + ("equals" if same else "**differs from**")
                  + " the exact condition's in `sequences.json`.")
    return [f"{h} Exact IRL's tolerance", "",
            "Exact IRL counts θ as consistent with an example when d_reward / |θ| ≤ ε (normalised reward units; "
            f"`teaching.core.learners.ExactIRL.tolerance`, default EXACT_TOLERANCE = {EXACT_TOLERANCE:g}). For each ε, "
            "computed here on this table: the exact-IRL greedy sequence over showable environments and its P(θ*); "
            "the single environments that alone leave P(θ*) = 1 (eliminate every other θ; showable ones in "
            "brackets); the share of (environment, θ≠θ*) pairs with 0 < d_reward/|θ| ≤ ε, which survive only "
            "because of the tolerance; and exact-IRL P(θ*) of every condition's sequence in `sequences.json`.", "",
            *md_table(("ε", "greedy length", "greedy env ids", "its P(θ*)", "decisive single envs",
                       "tolerance-only pairs"), summary),
            *md_table(("exact-IRL P(θ*) of", *(f"ε = {eps_s(r)}" for r in rows)), per_condition),
            sentence + " " + neg_s, "",
            f"Planner precision: {precision}" if precision else "Planner precision: not stated.", ""]


def table_sections(table_dir, teach_dir, out_dir, figures, prefix, h, precision) -> list[str]:
    table, data = load_inputs(table_dir, teach_dir)
    index_of = table.row_of
    figures.mkdir(parents=True, exist_ok=True)
    for name in FIGURES:
        shutil.copyfile(Path(teach_dir) / name, figures / (prefix + name))
    links = {n: Path(os.path.relpath(figures / (prefix + n), out_dir)).as_posix() for n in FIGURES}
    tol = tolerance_study(table, data, index_of, Distances(table))
    return (section_identity(table, data) + section_strategies(table, h) + section_hyper(data, h)
            + section_sequences(table, data, index_of, h) + section_clusters(table.domain, data, links, h)
            + section_matrix(data, links, h) + section_tests(table.domain, data, h)
            + section_tolerance(tol, list(data["sequences"]["conditions"]),
                                data["sequences"]["conditions"]["exact"]["env_ids"], precision, h))


def section_paper(args, out_dir, figures) -> list[str]:
    head = ["## The paper table", ""]
    why = ("no paper table was given to this report" if not args.paper_table else
           f"there is no table at {args.paper_table}" if not (Path(args.paper_table) / "meta.json").is_file() else
           "no teach outputs (--paper-teach) were given for it" if not args.paper_teach else None)
    if why is not None:
        return head + [f"The paper-scale table ({get_domain('driving').n_environments:,} environments) has not been "
                       "rebuilt under the "
                       f"current world and planner ({why}), so no paper-scale results are reported here; the "
                       "paper-scale results published before described an older world.", ""]
    try:
        return head + table_sections(args.paper_table, args.paper_teach, out_dir, figures, "paper_", "###",
                                     args.planner_precision)
    except ReportError as exc:
        return head + [f"No paper-scale results are reported: {exc}. The paper-scale results published before "
                       "described an older world.", ""]


def section_gridworld(args, out_dir, figures) -> list[str]:
    head = ["## The delivery gridworld", "",
            "The second domain (docs/domains.md): a delivery robot in a yard, 4 cost features, classes mud, dog, "
            "cart and other. Its table and teach outputs go through the same core as the car's.", ""]
    if not (args.gridworld_table and args.gridworld_teach):
        return head + ["No gridworld table was given to this report (--gridworld-table, --gridworld-teach).", ""]
    return head + table_sections(args.gridworld_table, args.gridworld_teach, out_dir, figures, "gridworld_", "###",
                                 GRIDWORLD_PRECISION)


def commands_of(table_dir, teach_dir) -> list[str]:
    """The build and teach commands behind a table and its teach outputs, the teach options read back from
    what the outputs record (seed, approx*, ε, fixed τ/λ, the test difficulty, every --selector)."""
    preset = json.loads((Path(table_dir) / "meta.json").read_text()).get("preset")
    seq = json.loads((Path(teach_dir) / "sequences.json").read_text())
    argv = ["--table", str(table_dir), "--out", str(teach_dir)]
    for key, default in (("seed", 0), ("approx_star", APPROX_STAR), ("epsilon", COVERAGE_EPSILON)):
        if seq.get(key, default) != default:
            argv += ["--" + key.replace("_", "-"), str(seq[key])]
    argv += [a for m, hp in seq["hyperparameters"].items() if hp.get("fixed")
             for a in ("--hyper", f"{m}={hp['value']}")]
    tests = json.loads((Path(teach_dir) / "test_set.json").read_text())
    if isinstance(tests, list) and tests and tests[0].get("difficulty"):
        argv += ["--test-difficulty", tests[0]["difficulty"]]
    if isinstance(tests, list) and tests and is_show(tests[0]):
        argv += ["--tests", "show"]
    argv += [a for label, c in seq["conditions"].items() if "selector" in c for a in ("--selector", label)]
    return [f".venv/bin/python -m teaching build --preset {preset} --out {table_dir}",
            ".venv/bin/python -m teaching teach " + shlex.join(argv)]


def build_report(args) -> str:
    out = Path(args.out)
    figures = Path(args.figures) if args.figures else out.parent / "figures"
    flags = ("table", "teach", "out", "figures", "planner_precision", "paper_table", "paper_teach",
             "gridworld_table", "gridworld_teach")
    argv = ["scripts/results_report.py"] + [a for f in flags if getattr(args, f)
                                             for a in ("--" + f.replace("_", "-"), getattr(args, f))]
    body = table_sections(args.table, args.teach, out.parent, figures, "", "##", args.planner_precision)
    pairs = [(args.table, args.teach), (args.paper_table, args.paper_teach),
             (args.gridworld_table, args.gridworld_teach)]
    commands = [c for t, o in pairs if t and o and (Path(t) / "meta.json").is_file()
                and (Path(o) / "sequences.json").is_file() for c in commands_of(t, o)]
    head = ["# Results: ideal-user analysis", "",
            "Generated by `scripts/results_report.py` from the table and the teach outputs; do not edit by hand. "
            f"Generated {datetime.datetime.now(datetime.UTC):%Y-%m-%d %H:%M} UTC with:", "", "```",
            *commands, ".venv/bin/python " + shlex.join(argv), "```", ""]
    return "\n".join(head + body + section_paper(args, out.parent, figures)
                     + section_gridworld(args, out.parent, figures))


BENCH_SECTION = re.compile(r"<!-- ((?:bench|scripts)/[\w.]+): begin -->.*?<!-- \1: end -->", re.S)


def bench_sections(old_report: Path) -> list[str]:
    """The sections another program wrote into the report between its markers (bench/closedloop.py,
    scripts/world_results.py), carried over as they are: the report's own inputs cannot recompute them, and
    that program rewrites them in place."""
    if not old_report.exists():
        return []
    return [m.group(0) for m in BENCH_SECTION.finditer(old_report.read_text())]


def parse_args(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--table", required=True)
    p.add_argument("--teach", required=True)
    p.add_argument("--out", required=True)
    p.add_argument("--figures", help="where to copy the figures (default: figures/ beside --out)")
    p.add_argument("--planner-precision", help="the planner's measured precision, quoted verbatim")
    p.add_argument("--paper-table")
    p.add_argument("--paper-teach")
    p.add_argument("--gridworld-table", help="a gridworld table (e.g. its demo preset) for a section of its own")
    p.add_argument("--gridworld-teach")
    return p.parse_args(argv)


def main(argv=None) -> int:
    args = parse_args(argv)
    try:
        text = "\n\n".join([build_report(args), *bench_sections(Path(args.out))])
        Path(args.out).parent.mkdir(parents=True, exist_ok=True)
        Path(args.out).write_text(text)
    except (ReportError, TableError, OSError, KeyError) as exc:
        why = f"a teach output lacks the field {exc} (made by another version?)" if isinstance(exc, KeyError) else exc
        print(f"error: {why}", file=sys.stderr)
        return EXIT_BAD_INPUT
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
