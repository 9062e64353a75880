"""One study condition's teaching sequence as a worker's JSON result.

The selection itself is ``teaching.selection.condition_sequence`` (the same
steps ``teach`` composes for all conditions); this module only shapes its
result for the job record.  No Django here.
"""
from __future__ import annotations

import numpy as np

from teaching.api import condition_sequence as select
from teaching.api import has_hyperparameter


def condition_sequence(table, name: str, **kwargs) -> dict:
    """The sequence of condition `name` (one of teaching.selection.CONDITIONS) as JSON-able data:
    env_ids (in the order shown), env_indices, p (P(θ*) after each example), prior, model,
    value (τ / λ), rule_met (the hyperparameter rule held), added_for_coverage (env ids).
    Keyword arguments go to ``teaching.selection.condition_sequence``."""
    seq, model, rule_met = select(table, name, **kwargs)
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
    }
