"""A study's simulated pilot (issue 13): what the researcher sees before opening a study.

* The ideal-user matrix for exactly the study's conditions: P_user(θ*) after a condition's
  examples, for each of the paper's simulated learners.  The study job computes it on the worker
  when it freezes the test set (precompute/sequences.py::pilot_matrix, teach.py's own matrix) and
  stores it as small JSON in ``study.source["pilot"]``.  A study made by `create_study` from
  `python -m teaching.teach` output takes the rows of its conditions from that output's
  matrix.json (studies.spec_from_teach).
* A power table: participants per condition needed to detect the paper's reported effects and
  the researcher's own effect size, at the α and power they choose (analysis/power.py,
  statsmodels' TTestIndPower), and whether the study's target per condition gets there.
"""
from __future__ import annotations

from django import forms

from .analysis.power import ALPHA_MAX, ALPHA_MIN, D_MAX, D_MIN, PAPER_EFFECTS, POWER_MAX, power_problem, power_table
from .models import Study

PILOT_KEY = "pilot"
YOUR_EFFECT = "your effect size"
SYMBOLS = {"tau": "τ", "lambda": "λ"}
DEFAULT_EFFECT = PAPER_EFFECTS[0]  # approx* vs exact: the default of the researcher's effect size


# --- the stored matrix ---------------------------------------------------------------------------
def store_pilot(study: Study, pilot: dict) -> None:
    """Keep the simulated pilot with the study (its source JSON), replacing an older one."""
    study.source = {**(study.source or {}), PILOT_KEY: pilot}
    study.save(update_fields=["source"])


def pilot_matrix_rows(study: Study) -> dict | None:
    """The stored matrix laid out for the page: users (with τ / λ), and one row per condition with
    each user's P(θ*) and whether it is that user's best condition.  None if the study has none."""
    pilot = (study.source or {}).get(PILOT_KEY)
    try:
        users, matrix = list(pilot["users"]), [[float(v) for v in row] for row in pilot["matrix"]]
        conditions = list(pilot["conditions"])
        if len(matrix) != len(conditions) or any(len(row) != len(users) for row in matrix):
            return None
    except (KeyError, TypeError, ValueError):
        return None
    # a user's best condition, unless every condition ties (then none stands out)
    best = [max(col) if max(col) > min(col) else None for col in zip(*matrix, strict=True)] if matrix else []
    models = pilot.get("models") or {}
    return {"users": [{"name": u, "model": models.get(u, u), "value": hyperparameter_label(u, models.get(u, u))}
                      for u in users],
            "prior": pilot.get("prior"), "from": pilot.get("from", "study job"),
            "rows": [{"condition": c, "cells": [{"p": v, "best": v == b} for v, b in zip(row, best, strict=True)]}
                     for c, row in zip(conditions, matrix, strict=True)]}


def hyperparameter_label(user: str, model: str) -> str:
    """ "det-euclidean(tau=0.5)" -> "τ = 0.5" (teaching's str of a model); "" for a model without one."""
    if not (model.startswith(f"{user}(") and model.endswith(")")):
        return ""
    param, _, value = model[len(user) + 1:-1].partition("=")
    return f"{SYMBOLS.get(param, param)} = {value}"


# --- the power table ------------------------------------------------------------------------------
def _bounded(label: str, low: float, high: float, example: str) -> dict:
    between = f"{label} must lie between {low:g} and {high:g}."
    return {"invalid": f"{label} must be a number, e.g. {example}.", "required": f"{label} is needed, e.g. {example}.",
            "min_value": between, "max_value": between}


class PowerForm(forms.Form):
    """α, power and the researcher's effect size (a GET form on the study's page), within the bounds
    analysis/power.py sets for the `power` command too: inside them a sample size always exists."""

    alpha = forms.FloatField(label="α (two-sided)", initial=0.05, min_value=ALPHA_MIN, max_value=ALPHA_MAX,
                             error_messages=_bounded("α", ALPHA_MIN, ALPHA_MAX, "0.05"))
    power = forms.FloatField(label="Power", initial=0.8, max_value=POWER_MAX,  # and above α: clean()
                             error_messages={**_bounded("Power", 0, POWER_MAX, "0.8"),
                                             "max_value": f"Power must be at most {POWER_MAX:g}."})
    d = forms.FloatField(label="Your effect size (Cohen's d)", initial=round(DEFAULT_EFFECT.d, 3),
                         min_value=D_MIN, max_value=D_MAX,
                         error_messages=_bounded("The effect size d", D_MIN, D_MAX, "0.5"),
                         help_text=f"Default: the paper's {DEFAULT_EFFECT.comparison} (Welch p = {DEFAULT_EFFECT.p:g} "
                                   f"with {DEFAULT_EFFECT.n1} + {DEFAULT_EFFECT.n2} participants).")

    def clean(self):
        data = super().clean()
        alpha, power = data.get("alpha"), data.get("power")
        if alpha is not None and power is not None and power_problem(power, alpha):
            self.add_error("power", f"Power must be above α ({alpha:g}): at a vanishing effect a test's power "
                                    "is α itself, so no number of participants reaches less.")
        return data


def smallest_target(study: Study) -> int:
    """The fewest participants any condition aims for: what a comparison between two conditions gets."""
    return min((c.target_count for c in study.conditions.all()), default=study.target_per_condition)


def power_rows(*, alpha: float, power: float, d: float, n: int) -> list[dict]:
    """power_table's rows (the paper's effects, then `d`), each saying whether n per condition is enough."""
    rows = power_table(alpha=alpha, power=power, n_per_condition=n, effects={YOUR_EFFECT: d})
    for row in rows:
        row["reached"] = n >= row["needed"]
    return rows


def power_context(study: Study, query) -> dict:
    """The power form (bound to the page's GET parameters when it sent any, else its defaults)
    and its table, or the form's messages."""
    sent = any(name in query for name in PowerForm.base_fields)
    form = PowerForm(query if sent else None)
    if sent and not form.is_valid():
        return {"power_form": form, "power_rows": None}
    values = form.cleaned_data if sent else {name: f.initial for name, f in form.fields.items()}
    n = smallest_target(study)
    # within the form's bounds a sample size always exists (analysis/power.py)
    rows = power_rows(alpha=values["alpha"], power=values["power"], d=values["d"], n=n)
    return {"power_form": form, "power_rows": rows, "power_n": n, "power_values": values,
            "power_reached": all(r["reached"] for r in rows)}


def pilot_context(study: Study, query) -> dict:
    """Everything the "Simulated pilot" section of the study's page shows."""
    return {"pilot": pilot_matrix_rows(study), **power_context(study, query)}
