"""check-domain: every registered domain passes it; each of five mistakes seeded into a real domain
(the gridworld, wrapped with one member altered) fails exactly one check with one line naming it; and a
domain lacking any member of a declared part is refused with the member's name."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from teaching.__main__ import main
from teaching.core import domain as registry
from teaching.core.checkdomain import CHECKS, check_domain, check_members, check_palette
from teaching.core.domain import REQUIRED_PARTS, ShowWayPart, domain_names, get_domain, part_members
from teaching.core.rewards import reward

ROOT = Path(__file__).resolve().parents[3]
# A tiny preset's 24 θ rarely give four options the domains' default distance apart; the app's tests
# accept 0.1 on tiny tables (tests/conftest.py TINY_TEST_SET), and so do these.
TINY_DISTANCE = 0.1


def tiny(domain):
    return min(domain.presets, key=lambda p: p.n_envs * p.n_thetas)


def results(domain) -> dict:
    return {r.check: r for r in check_domain(domain, tiny(domain), min_distance=TINY_DISTANCE)}


def members_result(domain):
    """check_domain on a domain that may lack its presets: every result, by check."""
    return {r.check: r for r in check_domain(domain)}


def failures(domain) -> list[tuple[str, str]]:
    return [(r.check, line) for r in results(domain).values() for line in r.failures]


class Altered:
    """A real domain with some members replaced; every other member is the real one's, so the checker
    sees the domain exactly as it is but for the seeded mistake."""

    def __init__(self, inner, **members):
        self._inner = inner
        self.__dict__.update(members)

    def __getattr__(self, name):
        return getattr(self._inner, name)


class Lacking(Altered):
    """A real domain with some members gone, as if its author had not written them."""

    def __init__(self, inner, *lacks):
        super().__init__(inner)
        self._lacks = frozenset(lacks)

    def __getattr__(self, name):
        if name in self._lacks:
            raise AttributeError(name)
        return getattr(self._inner, name)


@pytest.fixture(scope="module")
def grid():
    return get_domain("gridworld")


@pytest.mark.parametrize("name", domain_names())
def test_every_registered_domain_passes(name):
    found = results(get_domain(name))
    assert tuple(found) == CHECKS
    assert all(r.ok and r.summary for r in found.values()), [f for r in found.values() for f in r.failures]


@pytest.mark.parametrize("part, member", [(part, m) for part in REQUIRED_PARTS for m in part_members(part)],
                         ids=lambda v: v if isinstance(v, str) else v.__name__)
def test_a_domain_lacking_a_member_of_a_part_is_refused_with_its_name(grid, part, member):
    found = members_result(Lacking(grid, member))
    assert list(found) == ["members"]  # nothing else runs on a domain that cannot answer it
    [line] = found["members"].failures
    assert f"lacks '{member}' of {part.__name__}" in line
    assert f"domain {'Lacking' if member == 'name' else 'gridworld'!r} (Lacking)" in line
    assert "teaching/core/domain.py" in line


def test_the_optional_part_is_all_or_nothing():
    """The members check alone: a domain without the optional part passes it, and check_domain would go on to
    build a table of the taxi's own preset."""
    taxi = get_domain("taxi")
    assert "ShowWayPart not" in check_members(Lacking(taxi, "score_shown", "show_rules")).summary
    [line] = check_members(Lacking(taxi, "show_rules")).failures
    assert "lacks 'show_rules' of ShowWayPart" in line
    assert part_members(ShowWayPart) == ("score_shown", "show_rules")


def test_a_wrong_dtype(grid):
    def plan_chunk(env_ids, thetas, normalisers):
        out = grid.plan_chunk(env_ids, thetas, normalisers)
        return {**out, "d_euclid": out["d_euclid"].astype(np.float64)}  # NumPy's default, not the table's

    found = results(Altered(grid, plan_chunk=plan_chunk))
    [(check, line)] = [(r.check, f) for r in found.values() for f in r.failures]
    assert check == "plan_chunk"
    assert "'d_euclid' is float64, expected float32" in line and "astype(np.float32)" in line
    assert "test_check_domain.py" in line  # where the faulty plan_chunk is defined
    # the checks that read the arrays are skipped, not failed on arrays they cannot trust
    assert set(found) == {"members", "plan_chunk", "palette"}


def test_a_negative_d_reward(grid):
    def plan_chunk(env_ids, thetas, normalisers):
        """θ 1 gets the worst, under θ 1, of the environment's trajectories: the cross-θ step forgotten."""
        out = {k: v.copy() for k, v in grid.plan_chunk(env_ids, thetas, normalisers).items()}
        worst = np.argmin(reward(out["features"], thetas[1]), axis=1)
        for v in out.values():
            v[:, 1] = v[np.arange(len(v)), worst]
        return out

    [(check, line)] = failures(Altered(grid, plan_chunk=plan_chunk))
    assert check == "d_reward"
    assert "θ's own trajectory is worse under θ than another θ's" in line and "d_reward < 0" in line
    assert ", θ 1 by " in line and "reward()" in line


def test_a_page_key_the_payload_lacks(grid):
    [(check, line)] = failures(Altered(grid, page_keys=(*grid.page_keys, "legend")))
    assert check == "page_keys"
    assert "name ['legend'], which scene_payload(" in line
    assert "add them to scene_payload or drop them from page_keys" in line


def test_a_palette_colour_the_scene_reads_but_does_not_get(grid):
    palette = {k: v for k, v in grid.palette.items() if k != "path"}  # the legend draws no path
    [(check, line)] = failures(Altered(grid, palette=palette))
    assert check == "palette"
    # the path is drawn by the grid scene base the yard's scene imports
    assert line.startswith("static/studyapp/scenes/grid.js reads colour 'path' (--scene-path)")
    assert "gridworld's palette lacks" in line


def test_an_infeasible_test_cluster(grid):
    # the cart's yards have one way to carry by hand: no test there has four different options
    cart = grid.cluster_names.index("cart: carry by hand")
    [(check, line)] = failures(Altered(grid, test_clusters=(*grid.test_clusters, cart)))
    assert check == "test set"
    assert f"can test cluster {cart} 'cart: carry by hand'" in line
    assert "drop it from test_clusters" in line


def test_the_scene_files_are_read_without_a_browser(grid, tmp_path):
    """Names under any import alias, through a const array, camelCase and CSS var(); custom properties
    a stylesheet declares are not colours; a call whose names cannot be read is reported."""
    scenes = tmp_path / "static" / "studyapp" / "scenes"
    scenes.mkdir(parents=True)
    (scenes / "gridworld.js").write_text(
        'import { Layout } from "../labels.js";\nimport { colors as pal } from "../palette.js";\n'
        '// pal(["commented"]) is not read\nconst NAMES = ["free", "mudMark", "fooBar"];\n'
        'const c = pal(NAMES);\nconst d = pal(names());\nconst w = getPropertyValue("--scene-ref-w");\n')
    (scenes / "gridworld.css").write_text(
        ":root { --scene-ref-w: 144px; }\n.scene canvas { background: var(--scene-grid); color: var(--scene-ink); }\n")
    lines = check_palette(grid, tmp_path / "static" / "studyapp").failures
    assert len(lines) == 3, lines
    assert "static/studyapp/scenes/gridworld.js: pal(names()): cannot read" in lines[0]
    assert lines[1].startswith("static/studyapp/scenes/gridworld.js reads colour 'foo-bar' (--scene-foo-bar)")
    assert lines[2].startswith("static/studyapp/scenes/gridworld.css reads colour 'ink' (--scene-ink)")


def test_a_scene_on_a_base_module_reads_the_colours_of_both(grid, tmp_path):
    """A scene hands its NAMES to a base beside it, which calls colors(this.names) over its own and the
    scene's: both lists are read, each colour credited to the module that names it."""
    scenes = tmp_path / "static" / "studyapp" / "scenes"
    scenes.mkdir(parents=True)
    (scenes / "gridworld.js").write_text(
        'import { Base } from "./base.js";\nconst NAMES = ["free", "fooBar"];\n'
        'export class Scene extends Base { constructor() { super(NAMES); } }\n')
    (scenes / "base.js").write_text(
        'import { colors } from "../palette.js";\nconst NAMES = ["grid", "bazQux"];\n'
        'export class Base { begin() { this.c = colors(this.names); } }\n')
    lines = check_palette(grid, tmp_path / "static" / "studyapp").failures
    assert sorted(line.split(" reads ")[0] for line in lines) == [
        "static/studyapp/scenes/base.js", "static/studyapp/scenes/gridworld.js"], lines
    assert any("'baz-qux'" in line for line in lines) and any("'foo-bar'" in line for line in lines)


def test_an_installed_core_without_the_web_pages_says_the_palette_was_not_checked(grid, tmp_path):
    """`pip install .` brings the core, not static/: the palette check says it could not look, and names no
    scene the researcher should write."""
    result = check_palette(grid, tmp_path / "site-packages" / "static" / "studyapp")
    assert result.ok and result.summary.startswith("not checked: the web pages' scene files")


def test_the_command_exits_0_when_every_check_passes():
    proc = subprocess.run(
        [sys.executable, "-m", "teaching", "check-domain", "gridworld", "--preset", tiny(get_domain("gridworld")).name,
         "--min-option-distance", str(TINY_DISTANCE)],
        cwd=ROOT, env={**os.environ, "PYTHONPATH": str(ROOT)}, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, (proc.stdout, proc.stderr)
    assert [line.split(":")[0] for line in proc.stdout.splitlines()[1:-1]] == [f"ok    {c}" for c in CHECKS]
    assert f"gridworld: all {len(CHECKS)} checks pass" in proc.stdout
    assert "planning 48 of the 48 environments" in proc.stderr  # progress goes to stderr


def test_the_command_exits_1_with_one_line_per_failure(grid, monkeypatch, capsys):
    palette = {k: v for k, v in grid.palette.items() if k not in ("path", "text")}
    monkeypatch.setitem(registry._LOADED, "gridworld", Altered(grid, palette=palette))
    assert main(["check-domain", "gridworld", "--preset", tiny(grid).name,
                 "--min-option-distance", str(TINY_DISTANCE)]) == 1
    out = capsys.readouterr().out
    assert [line[:20] for line in out.splitlines() if line.startswith("FAIL")] == ["FAIL  palette: stati"] * 2
    assert f"gridworld: 1 of {len(CHECKS)} checks fail (palette)" in out


def test_the_command_names_each_missing_member_and_skips_the_rest(grid, monkeypatch, capsys):
    monkeypatch.setitem(registry._LOADED, "gridworld", Lacking(grid, "caption", "trajectory_dtype"))
    assert main(["check-domain", "gridworld"]) == 1
    out = capsys.readouterr().out
    fails = [line for line in out.splitlines() if line.startswith("FAIL")]
    assert len(fails) == 2 and "'trajectory_dtype' of PlannerPart" in fails[0] and "'caption' of PagesPart" in fails[1]
    assert "subclass teaching.core.base.BaseDomain, which gives it" in fails[1]  # BaseDomain has a caption
    assert "skip  plan_chunk: needs every member of the interface" in out
    assert f"1 of {len(CHECKS)} checks fail (members), {len(CHECKS) - 1} skipped" in out


@pytest.mark.parametrize("argv, needle", [
    (["check-domain", "vacuum"], f"unknown domain 'vacuum'; choose one of {', '.join(domain_names())}"),
    (["check-domain", "gridworld", "--preset", "tiny"], "unknown preset 'tiny' for domain gridworld; choose one of"),
    (["check-domain", "gridworld", "--envs", "0"], "--envs must be at least 1"),
])
def test_the_command_exits_2_for_bad_arguments(argv, needle, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and needle in err


def test_the_command_needs_a_domain(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["check-domain"])
    assert exc.value.code == 2
    assert "NAME" in capsys.readouterr().err
