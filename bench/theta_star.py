"""What theta* does in every environment of the grid (docs/calibration.md quotes this output).

    python bench/theta_star.py [--step 1]

Plans theta* alone (all strategy seeds, Newton to convergence) in every `step`-th environment
and prints, per class, how often each strategy appears and the behaviour checks of the planner tests,
measured from positions with their own thresholds (in a lane = centre within 3 ft of a lane
centre; left the centre lane = more than 6 ft from it), as a Markdown table.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from teaching.domains.driving.dynamics import rollout_np
from teaching.domains.driving.environments import CLASS_NAMES, N_ENVIRONMENTS, environment_class, get_environments
from teaching.domains.driving.features import default_normalisers
from teaching.domains.driving.planner import plan_chunk
from teaching.domains.driving.strategies import CLUSTER_NAMES
from teaching.domains.driving.world import THETA_STAR, world_fingerprint


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--step", type=int, default=1, help="plan every step-th environment (1 = the whole grid)")
    args = ap.parse_args()
    ids = np.arange(0, N_ENVIRONMENTS, args.step)
    t0 = time.perf_counter()
    out = plan_chunk(ids, THETA_STAR[None], default_normalisers())
    envs = get_environments(ids)
    cls, goal = environment_class(envs), envs.goal
    s = rollout_np(out["controls"][:, 0])
    x, h = s[..., 0], s[..., 2]
    labels = out["strategy"][:, 0]
    print(f"theta* in {len(ids):,} environments (world {world_fingerprint()}), planned in "
          f"{time.perf_counter() - t0:.0f} s\n")
    print("| class | environments | strategy counts |")
    print("|---|---|---|")
    for c, name in enumerate(CLASS_NAMES):
        m = cls == c
        counts = np.bincount(labels[m], minlength=len(CLUSTER_NAMES))
        shown = ", ".join(f"{CLUSTER_NAMES[k]} {counts[k]:,} ({counts[k] / m.sum():.1%})"
                          for k in np.flatnonzero(counts))
        print(f"| {name} | {m.sum():,} | {shown} |")
    merged = (np.abs(x[:, -1] - 12) <= 3) & (x.min(1) > -6)
    changed = np.abs(x).max(1) > 6
    at_centre = np.abs(x[:, -1, None] - np.array([-12.0, 0.0, 12.0])).min(1) <= 3
    late = (x >= 6).argmax(1) >= 17
    print("\n| check | measured |")
    print("|---|---|")
    print(f"| merge goal: ends in the right lane, never enters the left | {merged[goal == 0].mean():.2%} "
          f"of {int((goal == 0).sum()):,} |")
    print(f"| lane changes ending within 3 ft of a lane centre | {at_centre[changed].mean():.2%} of "
          f"{int(changed.sum()):,} |")
    print(f"| largest \\|x\\| (ft) | {np.abs(x).max():.3f} |")
    print(f"| largest \\|heading - pi/2\\| at the end (rad) | {np.abs(h[:, -1] - np.pi / 2).max():.3f} |")
    print(f"| other, forward: keeps its lane | {(~changed)[(cls == 3) & (goal == 1)].mean():.2%} |")
    print(f"| other, merge: merged | {merged[(cls == 3) & (goal == 0)].mean():.2%} |")
    print(f"| merging: enters the right lane only in the last 0.75 s | {late[cls == 0].mean():.1%} |")


if __name__ == "__main__":
    main()
