"""One study condition's teaching sequence, and a study's simulated pilot, as a worker's JSON.

The selection itself is ``teaching.core.conditions.condition_sequence`` (the same
steps ``teach`` composes for all conditions), the pilot ``teaching.core.evaluation.study_matrix``
(teach.py's ideal-user matrix); this module only shapes their results for the job record and
the study.  No Django here.
"""
from __future__ import annotations

import numpy as np

from teaching.api import (
    APPROX_STAR,
    USER_NAMES,
    condition_params,
    has_hyperparameter,
    loop_pilot,
    pilot_predictions,
    study_matrix,
)
from teaching.api import condition_sequence as select


def condition_sequence(table, name: str, params: dict | None = None, **kwargs) -> dict:
    """The sequence of selector `name` (any of teaching's selector_names) run with `params`, as JSON-able
    data: env_ids (in the order shown), env_indices, p (P(θ*) after each example), prior, model,
    value (τ / λ), rule_met (the hyperparameter rule held), added_for_coverage (env ids), selector and
    params (every parameter it ran with).  Keyword arguments go to
    ``teaching.core.conditions.condition_sequence``."""
    seq, model, rule_met = select(table, name, params=params, **kwargs)
    ids = np.asarray(table.env_ids)
    value = model.value if has_hyperparameter(model) else None
    return {
        "condition": name,
        "env_ids": [int(i) for i in ids[seq.envs]],
        "env_indices": [int(i) for i in seq.envs],
        "p": [float(v) for v in seq.p],
        "prior": float(seq.prior),
        "model": model.name,
        "value": float(value) if value is not None else None,
        "rule_met": rule_met,
        "added_for_coverage": [int(ids[i]) for i in seq.added_for_coverage],
        "selector": name,
        "params": condition_params(name, params, kwargs.get("approx_star", APPROX_STAR)),
    }


def pilot_matrix(table, conditions: dict[str, list[int]], hyperparameters: dict | None = None,
                 test_set: list[dict] | None = None, closed_loops: dict | None = None) -> dict:
    """The simulated pilot of a study: P_user(θ*) after each condition's examples, for every ideal
    user (teach.py's matrix.json, restricted to exactly these conditions), and, given the study's
    `test_set`, what participants who learn as each user would choose in its tests.

    conditions: {name: environment *ids* in the order shown}; rows follow its order.
    hyperparameters: {model: τ or λ} for the users; a model not in it gets the paper's rule.
    Returns small JSON: conditions, users, matrix (rows x users), models (user -> "name(tau=...)"),
    prior (1 / number of θ: what a user who learned nothing assigns to θ*), and with a test set
    predicted (teaching's pilot_predictions: θ*'s option per test, P(option) per user and condition).
    closed_loops: {name: teaching's ClosedLoop}, rows after the others, each the average over simulated
    participants of every user run through the loop (teaching's loop_pilot); "closed_loop" then says how
    many per user and their lapse rate."""
    index = table.row_of
    missing = sorted({int(e) for ids in conditions.values() for e in ids} - set(index))
    if missing:
        raise ValueError(f"environments {missing[:10]} are not in the table")
    rows = {name: [index[int(e)] for e in ids] for name, ids in conditions.items()}
    matrix, models = study_matrix(table, rows, hyperparameters)
    pilot = {"conditions": list(rows), "users": list(USER_NAMES), "matrix": matrix.tolist(),
             "models": {u: str(models[u]) for u in USER_NAMES}, "prior": 1.0 / table.n_thetas}
    if test_set:
        pilot["predicted"] = pilot_predictions(table, models, rows, test_set)
    loops = {name: loop_pilot(loop, table, {u: models[u] for u in USER_NAMES}, test_set)
             for name, loop in (closed_loops or {}).items()}
    for name, row in loops.items():
        pilot["conditions"].append(name)
        pilot["matrix"].append([row["p"][u] for u in USER_NAMES])
        if test_set:
            for u in USER_NAMES:
                pilot["predicted"]["choice"][u][name] = row["choice"][u]
    if loops:
        pilot["closed_loop"] = {name: {"participants": r["participants"], "lapse": r["lapse"]}
                                for name, r in loops.items()}
    return pilot
