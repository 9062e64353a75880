"""Grid worlds from a file (teaching/domains/worlds/*.toml): each shipped world's planned trajectories
are the best an independent brute force finds (tests/teaching/domains/worlds/brute.py) on every
environment of its tiny preset, for θ* and random θ, and replay to the counts the table stores; a new
world written only as a file goes through the core (build, teach); a file with a mistake gets one line
naming the field."""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pytest

from teaching.core.candidates import sample_thetas
from teaching.core.domain import get_domain, unregister
from teaching.core.sheet import make_sheet
from teaching.core.table import TrajectoryTable
from teaching.domains import WORLD_ERRORS, WORLDS, register_world_files
from teaching.domains._grid.filedomain import world_domain
from teaching.domains._grid.worldfile import WorldFileError, load_world
from tests.teaching.domains.worlds import brute, key_room

SHIPPED = sorted(WORLDS.glob("*.toml"))
OUT = Path(__file__).resolve().parents[4] / "test-output"  # what a researcher would look at


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.stem)
def test_every_planned_trajectory_is_the_brute_force_best(path):
    domain = get_domain(path.stem)  # registered: the fronts its tiny preset's sample planned are kept
    world = domain.world
    assert domain.fingerprint() == world_domain(path).fingerprint()
    n_envs, _ = world.presets["tiny"]
    envs = np.arange(domain.n_environments) if n_envs is None or n_envs >= domain.n_environments else \
        domain.stratified_sample(n_envs)
    thetas = sample_thetas(8, theta_star=domain.theta_star, seed=5)  # θ* and 7 drawn as a table draws them
    out = domain.plan_chunk(envs, thetas, np.ones(len(domain.feature_names)))
    checked, starts = 0, [domain.environment(env) for env in envs]
    best = {}  # (variant, start) -> (T,) the brute force's best, one memo for each variant's starts
    for variant in {v for v, _ in starts}:
        mine = [s for v, s in starts if v == variant]
        best.update(zip(((variant, s) for s in mine),
                        brute.best_rewards_from(world, variant, mine, thetas, world.max_moves), strict=True))
    for k, env in enumerate(envs):
        variant, start = starts[k]
        for j, theta in enumerate(thetas):
            rows = domain.path_rows(domain.states(out["controls"][k, j]))
            counts = brute.replay(world, variant, start, [(r, c, h) for c, r, h in rows])
            np.testing.assert_array_equal(counts, out["features"][k, j])
            assert counts @ theta == pytest.approx(best[variant, start][j], abs=1e-9), (path.stem, int(env), j)
            checked += 1
    assert checked == len(envs) * len(thetas)


def _write(tmp_path, text: str):
    path = tmp_path / "world.toml"
    path.write_text(text)
    return path


def test_a_world_written_only_as_a_file_is_built_and_taught(tmp_path_factory):
    assert len(key_room.PATH.read_text().splitlines()) < 40
    with key_room.registered() as domain:
        table_dir, teach_dir = key_room.built(tmp_path_factory)
        table = TrajectoryTable.load(table_dir)
        assert table.n_envs == domain.n_environments == 96
        # θ* wades where the puddle saves more than its cost in moves, else walks around
        assert {"puddle: wade", "puddle: walk around"} <= {domain.cluster_names[s] for s in np.unique(table.strategy)}
        taught = json.loads((teach_dir / "sequences.json").read_text())
        assert all(c["env_ids"] for c in taught["conditions"].values())
        tests = json.loads((teach_dir / "test_set.json").read_text())
        assert [t["cluster_name"] for t in tests] == ["puddle: wade"] and len(tests[0]["options"]) == 4


@pytest.mark.parametrize("change, message", [
    (('{ at = [4, 3] }]', '{ at = [4, 3], kind = "lava" }]'),
     "world.toml: optional[4].kind: unknown cell kind 'lava' (declared: wall, puddle, sand)"),
    (('{ name = "steps"', '{ name = "x", counts = "reach", at = [1, 2] },\n  { name = "steps"'),
     "world.toml: theta_star: needs one number per feature (5), got [15, -2, -1.5, -1]"),
    (("theta_star = [15, -2, -1.5, -1]", "theta_star = [15, 2, -1.5, -1]"),
     "world.toml: theta_star: the weight of 'puddles' is positive: a count that can grow without end would "
     "make the reward unbounded (only 'reach' and 'deliver' features may be rewards)"),
    (("{ at = [1, 5] }]", "{ at = [8, 5] }]"), "world.toml: starts[2].at: cell [8, 5] lies outside the 7 x 5 grid"),
    (("fixed = [", "fixed = [{ at = [6, 3] }, { at = [7, 2] }, { at = [7, 4] }, "),
     "world.toml: features[0].at: cell [7, 3] cannot be reached from any start"),
])
def test_a_mistake_in_a_file_gets_one_line_naming_the_field(tmp_path, change, message):
    old, new = change
    text = key_room.PATH.read_text()
    assert old in text
    with pytest.raises(WorldFileError) as err:
        world_domain(_write(tmp_path, text.replace(old, new)))
    assert str(err.value) == message


def test_a_file_that_is_not_toml_says_so(tmp_path):
    with pytest.raises(WorldFileError, match=r"^world.toml: not valid TOML: "):
        load_world(_write(tmp_path, "name = \n"))


@pytest.mark.parametrize("sampler", ["log-uniform", "sphere"])
def test_candidates_keep_theta_stars_signs_where_a_goal_is_a_reward(sampler):
    star = world_domain(WORLDS / "taxi.toml").theta_star  # delivered +26, tolls -3, steps -1
    thetas = sample_thetas(200, sampler, theta_star=star)
    assert (np.sign(thetas) == np.sign(star)).all()
    # and an all-cost θ* stays all costs
    cost = np.array([-1.0, -0.3, -2.5])
    np.testing.assert_array_equal(sample_thetas(50, sampler, theta_star=cost)[1:] < 0, True)


def test_a_world_from_a_file_has_a_contact_sheet(tmp_path_factory, tmp_path):
    with key_room.registered():
        table_dir, teach_dir = key_room.built(tmp_path_factory)
        n, no_tests = make_sheet(table_dir=table_dir, teach_dir=teach_dir, out=tmp_path / "sheet.png", dpi=80)
    taught = json.loads((teach_dir / "sequences.json").read_text())
    assert no_tests is None
    # a panel per training example of every condition, and the test's four options
    assert n == sum(len(c["env_ids"]) for c in taught["conditions"].values()) + 4
    image = plt.imread(tmp_path / "sheet.png")
    assert image.shape[0] > 300 and image.shape[1] > 600
    OUT.mkdir(exist_ok=True)
    shutil.copy(tmp_path / "sheet.png", OUT / "world_file_sheet.png")


def actions_of(rows: list, ended_by_exit: bool) -> list[str]:
    """[[col, row, holding]] per step -> the action names that make them (the test's own reading)."""
    names = {(1, 0): "right", (-1, 0): "left", (0, -1): "up", (0, 1): "down"}
    out = []
    for (c0, r0, h0), (c1, r1, h1) in zip(rows, rows[1:], strict=False):
        out.append(names[(c1 - c0, r1 - r0)] if (c0, r0) != (c1, r1) else "pickup" if h1 > h0 else "drop")
    return out + (["exit"] if ended_by_exit else [])


@pytest.mark.parametrize("name", ["taxi", "two-goal"])
def test_a_shown_trajectory_is_scored_by_its_regret_under_theta_star(name):
    domain = world_domain(WORLDS / f"{name}.toml")
    world = domain.world
    terminal = [i for i, f in enumerate(world.features) if f.terminal]
    thetas = sample_thetas(8, theta_star=domain.theta_star, seed=3)
    envs = np.arange(0, domain.n_environments, max(1, domain.n_environments // 12))
    out = domain.plan_chunk(envs, thetas, np.ones(len(domain.feature_names)))
    for k, env in enumerate(envs):
        best = brute.best_rewards(world, *domain.environment(env), domain.theta_star[None], world.max_moves)[0]
        for j in range(len(thetas)):
            rows = domain.path_rows(domain.states(out["controls"][k, j]))
            shown = actions_of(rows, ended_by_exit=not out["features"][k, j][terminal].any())
            score = domain.score_shown(int(env), shown)
            assert score["counts"] == out["features"][k, j].tolist()
            assert score["optimum"] == pytest.approx(best, abs=1e-9)
            assert score["regret"] == pytest.approx(best - out["features"][k, j] @ domain.theta_star, abs=1e-9)
            assert score["regret"] >= -1e-9 and score["optimal"] == (score["regret"] <= 1e-9)
            if j == 0:
                assert score["optimal"], (name, int(env))  # θ*'s own trajectory


@pytest.mark.parametrize("actions, message", [
    (["left", "left", "left", "up"], "action 4: up is not possible at [1, 1]"),  # into the wall at [1, 2]
    (["right"], "action 1: right is not possible at [4, 1]"),  # off the grid
    (["drop"], "action 1: drop is not possible at [4, 1]"),  # holds nothing yet
    (["pickup", "left"], "the actions stop before the episode ends (reach a goal, deliver, or exit)"),
    (["exit", "left"], "action 2: the episode ended at action 1"),
    (["jump"], "action 1: 'jump' is not one of right, up, down, left, pickup, drop, exit"),
])
def test_a_shown_trajectory_the_world_does_not_allow_is_refused_in_one_line(actions, message):
    taxi = world_domain(WORLDS / "taxi.toml")  # environment 0: no tolls, the taxi and passenger at [4, 1]
    with pytest.raises(ValueError) as err:
        taxi.score_shown(0, actions)
    assert str(err.value) == message
    assert taxi.score_shown(0, ["pickup", "left", "left", "left", "drop"])["optimal"]


def test_a_shown_way_is_bounded_by_the_domain_whoever_calls():
    """score_shown replays at most max_actions (the page's own bound, show_rules) for any caller, so a
    post of 10,001 actions costs the server one length check, not a replay."""
    taxi = world_domain(WORLDS / "taxi.toml")
    limit = taxi.show_rules(0)["max_actions"]
    assert limit == taxi.max_actions == 4 * taxi.world.max_moves
    with pytest.raises(ValueError) as err:
        taxi.score_shown(0, ["left"] * 10_001)
    assert str(err.value) == f"this way has 10001 actions, and at most {limit} can be shown"
    # the bound is on the count alone: a way of exactly `limit` actions is replayed (and refused for what it does)
    with pytest.raises(ValueError, match=r"^action 1: down is not possible at \[4, 1\]$"):
        taxi.score_shown(0, ["down"] * limit)  # the taxi starts on the bottom row


def test_a_world_file_named_in_teaching_worlds_is_built_and_checked_from_the_command_line(tmp_path):
    """No Python: the file's folder in TEACHING_WORLDS, and the command line knows its domain."""
    env = {**os.environ, "TEACHING_WORLDS": str(key_room.PATH.parent)}

    def run(*args):
        return subprocess.run([sys.executable, "-m", "teaching", *args], env=env, capture_output=True, text=True,
                              timeout=600)

    built = run("build", "--preset", "key-room-tiny", "--out", str(tmp_path / "table"))
    assert built.returncode == 0, built.stderr
    with key_room.registered():
        assert TrajectoryTable.load(tmp_path / "table").n_envs == 96
    checked = run("check-domain", "key-room")
    assert checked.returncode == 0 and "key-room: all 7 checks pass" in checked.stdout, checked.stdout + checked.stderr


def test_a_world_file_with_a_mistake_is_left_out_with_its_one_line(tmp_path):
    bad = _write(tmp_path, key_room.PATH.read_text().replace('theta_star = [15, -2', 'theta_star = [15, 2'))
    assert register_world_files(os.pathsep.join([str(bad), str(key_room.PATH)])) == ["key-room"]
    unregister("key-room")
    assert WORLD_ERRORS[-1] == ("world.toml: theta_star: the weight of 'puddles' is positive: a count that can grow "
                                "without end would make the reward unbounded (only 'reach' and 'deliver' features "
                                "may be rewards)")
    run = subprocess.run([sys.executable, "-m", "teaching", "check-domain", "key-room"], capture_output=True,
                         text=True, timeout=600, env={**os.environ, "TEACHING_WORLDS": str(bad)})
    assert run.returncode != 0 and "Traceback" not in run.stderr
    assert f"world file not registered: {WORLD_ERRORS[-1]}" in run.stderr
    taken = _write(tmp_path, key_room.PATH.read_text().replace('name = "key-room"', 'name = "gridworld"'))
    assert register_world_files(str(taken)) == []
    assert WORLD_ERRORS[-1] == "world.toml: name: 'gridworld' is already a domain's name"


def _theta_stars_counts(name: str, variant: int) -> list[int]:
    """θ*'s counts from the file's first start in `variant`."""
    domain = world_domain(WORLDS / f"{name}.toml")
    phi, _ = domain.front(domain.environment_id(variant, 0))
    return phi[int(np.argmax(phi @ domain.theta_star))].tolist()


def test_the_published_theta_star_behaves_as_lee_et_al_describe():
    # taxi (counts: delivered, tolls, steps; bit 7 the toll at [3, 1]; their start first in each pool):
    # one toll on the way is worth a 2-step detour (7 steps, no toll: the plan their code finds) ...
    assert _theta_stars_counts("taxi", 1 << 7) == [1, 0, 7]
    # ... but with a second toll at [3, 2] the way round is 4 steps longer, and it pays the one toll
    assert _theta_stars_counts("taxi", (1 << 4) | (1 << 7)) == [1, 1, 5]
    # two-goal with no walls: the goal worth 10.5 five steps away, not the one worth 7.25 six away
    assert _theta_stars_counts("two-goal", 0) == [0, 1, 5]
    # skateboard with no walls: fetch the board and ride (a ride costs 0.3 a move, a step 1)
    goal, board, steps = _theta_stars_counts("skateboard", 0)
    assert goal == 1 and board > 0 and steps < 10
