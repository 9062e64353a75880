"""Write the hallway robot's table folder (docs/importing.md): what a lab hands over from its own stack.

    .venv/bin/python examples/hallway/make_folder.py --out var/examples/hallway [--videos]

table.toml (the robot's features, θ*, the candidates, classes, strategies and the participants' texts),
features.npz (the features, classes and strategies of every trajectory) and paths.npz (the robot's poses
and the people's, every 0.25 s).  Seeded: the same folder every time.  With --videos also a clip of every
trajectory (videos.py: clips/ and the stimuli manifest stimuli.csv, named in table.toml).
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import planner  # this folder's own module

TEXTS = {
    "summary": "you watch a robot cross a hallway past people and answer questions about what it prefers",
    "instructions": [
        "A delivery robot crosses a hallway from left to right (seen from above). People walk there too. The "
        "robot cares about getting across quickly, about not coming close to people, about not going out of "
        "its way, and about keeping to the right as people do, but not equally.",
        "You will watch {n_training} example{training_plural} of what it does, then answer {n_tests} "
        "question{tests_plural} about what it would do in new situations.",
    ],
    "watch": "Watch how the robot (the light circle) gets past the people (the dark circles).",
    "question": "Which of these would this robot do?",
    "option": "way across",
}


def toml_value(v) -> str:
    return json.dumps(v, ensure_ascii=False)  # strings, numbers and lists of them read the same in TOML


def write_folder(out: Path, n_envs: int, n_candidates: int, seed: int, *, videos: bool = False,
                 jobs: int = 2) -> None:
    """Write the folder; with `videos` also every trajectory's clip and the manifest naming them, as the robot
    "hallway-video" (a name is one robot, and both tables may be served by one site)."""
    out.mkdir(parents=True, exist_ok=True)
    table = planner.plan(n_envs, n_candidates, seed)
    np.savez(out / "features.npz", env_id=table["env_id"], features=table["features"],
             env_class=table["env_class"], strategy=table["strategy"])
    np.savez(out / "paths.npz", env_id=table["env_id"], t=planner.T, robot=table["robot"], agents=table["agents"],
             obstacles=table["walls"])
    robot_name = "hallway-video" if videos else "hallway"
    lines = [f'name = "{robot_name}"', 'title = "A robot crossing a hallway"', 'data = "features.npz"',
             f"theta_star = {toml_value(list(planner.THETA_STAR))}",
             "candidates = [", *(f"  {toml_value(t.tolist())}," for t in table["thetas"][1:]), "]",
             f"classes = {toml_value(list(planner.CLASSES))}", "min_option_distance = 0.3",
             *(['stimuli = "stimuli.csv"'] if videos else []), "",
             "[paths]", 'file = "paths.npz"', 'unit = "m"', "scale = [1.0, 1.0]",
             f"view = {toml_value(list(planner.VIEW))}", "", "[texts]"]
    lines += [f"{key} = {toml_value(value)}" for key, value in TEXTS.items()] + [""]
    for name, unit, description in planner.FEATURES:
        lines += ["[[features]]", f"name = {toml_value(name)}", f"unit = {toml_value(unit)}",
                  f"description = {toml_value(description)}", ""]
    for name, cls in planner.STRATEGIES:
        lines += ["[[strategies]]", f"name = {toml_value(name)}", f"class = {toml_value(cls)}", ""]
    if videos:  # rendered before table.toml names their manifest
        from videos import write_videos  # noqa: PLC0415  this folder's own; matplotlib and ffmpeg only when asked

        write_videos(out, table, jobs=jobs)
    (out / "table.toml").write_text("\n".join(lines), encoding="utf-8")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", type=Path, required=True, help="the folder to write")
    ap.add_argument("--envs", type=int, default=300)
    ap.add_argument("--candidates", type=int, default=79, help="objectives besides θ*")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--videos", action="store_true", help="also render every trajectory's clip (ffmpeg)")
    ap.add_argument("--jobs", type=int, default=2, help="processes rendering clips")
    args = ap.parse_args()
    write_folder(args.out, args.envs, args.candidates, args.seed, videos=args.videos, jobs=args.jobs)
    print(f"wrote {args.out}: {args.envs} environments x {args.candidates + 1} objectives")


if __name__ == "__main__":
    main()
