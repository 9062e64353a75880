"""`bench/planner.py --reference hard`: a table against the hard-constraint reference.

teaching/domains/driving/reference_hard.py enforces the world's limits as hard constraints with its own
rollout, features, starts and SLSQP, so unlike teaching/domains/driving/reference.py it sees what the
planner's soft penalty costs.  This prints the default mode's optimality summary (share
within 1e-8 ... 1e-3, quantiles, worst gaps with env id / theta index) plus:

* the penalty offset: pairs with gap > 1e-6 where the reference presses against a limit
  (|x| = 12 or the lane-end band edge), the table's trajectory ends in the same lane and
  stays within 1.5 ft of it laterally at every step, and the table is strictly inside that
  limit (or outside it, infeasible): the same manoeuvre, kept off the limit by the penalty;
  the remaining pairs above 1e-6 are counted as "other" (another basin, or a trajectory
  handed over from another theta);
* the table's distance to |x| = 12 at the steps where the reference's constraint is active,
  and to the lane-end band edge where that is active (ft; negative = outside);
* both sides' constraint violations.

    python bench/planner.py --reference hard --table var/tables/demo --pairs 120 --jobs 2
"""
from __future__ import annotations

import sys
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np

from teaching.domains.driving.environments import get_environments, other_car_states
from teaching.domains.driving.reference_hard import ACTIVE, compare_pair

THRESHOLDS = (1e-8, 1e-7, 1e-6, 1e-5, 1e-4, 1e-3)
QUANTILES = (0.0, 0.01, 0.05, 0.25, 0.5, 0.75, 0.95, 0.99, 1.0)
SAME_BASIN_FT = 1.5  # max |x_ref - x_table| over the steps for "the same manoeuvre"


def _one(args):
    return compare_pair(*args)


def compare_table(table, pairs, n_jobs: int = 2, progress=True) -> list[dict]:
    """compare_pair for each (env_index, theta_index) row of pairs (P, 2), in n_jobs processes."""
    pairs = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
    envs = get_environments(np.asarray(table.env_ids)[pairs[:, 0]])
    oxy = other_car_states(envs)
    tasks = [(np.asarray(table.controls[m, n], np.float64), np.asarray(table.features[m, n], np.float64), oxy[i],
              int(envs.goal[i]), np.asarray(table.thetas[n], np.float64), np.asarray(table.normalisers))
             for i, (m, n) in enumerate(pairs)]
    out, t0 = [], time.perf_counter()
    with ProcessPoolExecutor(max(1, n_jobs)) as pool:
        for r in pool.map(_one, tasks, chunksize=1):
            out.append(r)
            if progress and len(out) % 10 == 0:
                print(f"  hard reference: {len(out)}/{len(tasks)} pairs, {time.perf_counter() - t0:.0f} s",
                      file=sys.stderr, flush=True)
    return out


def is_offset(r: dict) -> bool:
    """The gap is the penalty's offset: same manoeuvre, the reference on a limit, the table off it."""
    same = r["ref_lane"] == r["table_lane"] and r["max_dx"] <= SAME_BASIN_FT
    off_road = r["ref_road_active"] and (r["table_road_at_active"].min() > ACTIVE or r["table_violation_ft"] > 0)
    off_band = r["ref_lane_end_active"] and abs(r["table_lane_end"]) > ACTIVE
    return bool(same and (off_road or off_band))


def print_gaps(gap_quantiles: dict, within: dict) -> None:
    """The gap lines both optimality checks print (quantiles and shares within each threshold)."""
    print("  gap = (reference reward - table reward) / |theta|, normalised units; positive = table worse")
    print("  quantiles: " + ", ".join(f"{q}: {v:.2e}" for q, v in gap_quantiles.items()))
    print("  within:    " + ", ".join(f"{t}: {v:.2%}" for t, v in within.items()))


def summarise(results: list[dict], pairs, env_ids, seconds: float, n_jobs: int) -> dict:
    """Print the summary and return its figures (JSON-ready)."""
    pairs = np.asarray(pairs).reshape(-1, 2)
    gap = np.array([r["gap"] for r in results])
    within = {f"{t:.0e}": float(np.mean(gap <= t)) for t in THRESHOLDS}
    above = gap > 1e-6
    offset = np.array([is_offset(r) for r in results]) & above
    road_at = np.concatenate([r["table_road_at_active"] for r in results] or [np.zeros(0)])
    road_pair = np.array([r["table_road_at_active"].min() for r in results if r["ref_road_active"]])
    band = np.array([r["table_lane_end"] for r in results if r["ref_lane_end_active"]])
    tab_v = np.array([r["table_violation_ft"] for r in results])
    fig = {"pairs": len(results), "seconds": seconds, "jobs": n_jobs, "share_within": within,
           "gap_quantiles": {f"{q:g}": float(np.quantile(gap, q)) for q in QUANTILES},
           "above_1e6": int(above.sum()), "penalty_offset": int(offset.sum()),
           "other_above_1e6": int((above & ~offset).sum()),
           "ref_road_active_pairs": len(road_pair), "ref_lane_end_active_pairs": len(band),
           "ref_max_violation": float(max(r["ref_violation"] for r in results)),
           "ref_max_kkt": float(max(r["ref_kkt"] for r in results)),
           "table_infeasible_pairs": int(np.sum(tab_v > 1e-9)), "table_max_violation_ft": float(tab_v.max()),
           "table_max_violation_rad": float(max(r["table_violation_rad"] for r in results))}
    order = np.argsort(-gap)[:5]
    fig["worst"] = [{"gap": float(gap[i]), "env_id": int(env_ids[pairs[i, 0]]), "theta_index": int(pairs[i, 1]),
                     "offset": bool(offset[i])} for i in order]
    print(f"\noptimality on {len(results):,} random (E, theta) pairs against the HARD-constraint reference "
          f"(teaching/domains/driving/reference_hard.py; {seconds:.0f} s with {n_jobs} workers = "
          f"{seconds / len(results):.1f} s per pair):")
    print_gaps(fig["gap_quantiles"], within)
    print("  worst: " + "; ".join(f"{w['gap']:.2e} (env {w['env_id']}, theta {w['theta_index']}"
                                  f"{', offset' if w['offset'] else ''})" for w in fig["worst"]))
    print(f"  above 1e-6: {fig['above_1e6']} pairs, of which {fig['penalty_offset']} the penalty's offset "
          f"(same manoeuvre, reference on a limit, table off it or outside), {fig['other_above_1e6']} other "
          "(another basin or handed over from another theta)")
    if len(road_pair):
        fig["table_road_margin_at_active"] = {f"{q:g}": float(np.quantile(road_pair, q)) for q in QUANTILES}
        print(f"  reference on |x| = 12 in {len(road_pair)} pairs ({len(road_at)} steps); the table's 12 - |x| "
              "there, per pair (ft): " + ", ".join(f"{q}: {v:.3g}" for q, v in
                                                   fig["table_road_margin_at_active"].items()))
    if len(band):
        fig["table_lane_end_margin_at_active"] = {f"{q:g}": float(np.quantile(band, q)) for q in QUANTILES}
        print(f"  reference on the lane-end band edge in {len(band)} pairs; the table's margin there (ft): "
              + ", ".join(f"{q}: {v:.3g}" for q, v in fig["table_lane_end_margin_at_active"].items()))
    print(f"  the reference's answers: max violation {fig['ref_max_violation']:.1e}, max KKT residual "
          f"{fig['ref_max_kkt']:.1e}")
    print(f"  the table's trajectories: {fig['table_infeasible_pairs']} of {len(results)} outside a limit by "
          "> 1e-9 ft; "
          f"max {fig['table_max_violation_ft']:.2e} ft, heading {fig['table_max_violation_rad']:.2e} rad")
    return fig
