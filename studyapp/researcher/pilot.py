"""A study's simulated pilot: what the researcher sees before opening a study.

* The ideal-user matrix for exactly the study's conditions: P_user(θ*) after a condition's
  examples, for each of the paper's simulated learners.  The study job computes it on the worker
  when it freezes the test set (precompute/sequences.py::pilot_matrix, teach.py's own matrix) and
  stores it as small JSON in ``study.source["pilot"]``.  A study made by `create_study` from
  `python -m teaching teach` output takes the rows of its conditions from that output's
  matrix.json (studies.spec_from_teach).
* What participants who learn by each learner model would score in each condition:
  the study job stores, with the matrix, each model's P(option) in every test after each condition's
  examples (teaching's pilot_predictions); the page turns it into the expected accuracy and mean
  confidence score at the lapse rate the researcher picks (teaching's predicted_scores), with no table.
* A power table: participants per condition needed to detect the paper's reported effects, the
  researcher's own effect size, and the effects the chosen learner model predicts between this study's
  conditions (the analysis' planned comparisons), at the α and power they choose (analysis/power.py,
  statsmodels' TTestIndPower), and whether the study's target per condition gets there.
"""
from __future__ import annotations

import numpy as np
from django import forms

from teaching.api import APPROX_STAR, predicted_scores

from ..analysis.comparisons import default_comparisons
from ..analysis.power import (
    ALPHA_MAX,
    ALPHA_MIN,
    D_MAX,
    D_MIN,
    PAPER_EFFECTS,
    POWER_MAX,
    cohens_d,
    power_problem,
    power_table,
)
from ..models import Study
from .studies import PILOT_KEY

YOUR_EFFECT = "your effect size"
SYMBOLS = {"tau": "τ", "lambda": "λ"}
DEFAULT_EFFECT = PAPER_EFFECTS[0]  # approx* vs exact: the default of the researcher's effect size
# The lapse rate the pilot's learners start from: a uniform guess in one test of ten (the researcher may change it).
DEFAULT_LAPSE = 0.1
# Between conditions, the model-predicted effects: the analysis' planned comparisons and, where a study has
# it, the hierarchical learner's condition against approx*.
MODEL_COMPARISONS = (*default_comparisons(APPROX_STAR), ("hierarchical", APPROX_STAR))


# --- the stored matrix (the study job stores it: studies.store_pilot) ----------------------------
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


# --- what learners of each model would score ----------------------------------------------------
def stored_predictions(study: Study) -> dict | None:
    """The pilot's stored choices as arrays: {"star": (T,), "choice": {user: {condition: (T, K)}}}, or None
    when the study has none (an older pilot, or one without tests) or they do not fit together."""
    pilot = (study.source or {}).get(PILOT_KEY) or {}
    try:
        predicted = pilot["predicted"]
        star = np.asarray(predicted["theta_star_option"], np.int64)
        choice = {u: {c: np.asarray(by_name[c], np.float64) for c in pilot["conditions"]}
                  for u, by_name in predicted["choice"].items()}
        if any(p.ndim != 2 or p.shape[0] != len(star) for by_name in choice.values() for p in by_name.values()):
            return None
    except (KeyError, TypeError, ValueError):
        return None
    return {"star": star, "choice": choice, "conditions": list(pilot["conditions"])}


def predicted_by_condition(stored: dict, user: str, lapse: float) -> dict:
    """{condition: PredictedScores} of `user`'s learners at this lapse rate."""
    return {c: predicted_scores(p, stored["star"], lapse) for c, p in stored["choice"][user].items()}


def predicted_rows(stored: dict | None, lapse: float) -> dict | None:
    """The predictions laid out for the page: users, and one row per condition with each user's expected
    accuracy and mean confidence score, marking that user's best condition (by score; none if all tie)."""
    if stored is None:
        return None
    users = list(stored["choice"])
    scores = {u: predicted_by_condition(stored, u, lapse) for u in users}
    # a user's best condition, unless every condition ties (as in the matrix above)
    means = {u: [s.mean for s in scores[u].values()] for u in users}
    best = {u: max(m) if max(m) > min(m) else None for u, m in means.items()}
    return {"users": users, "lapse": lapse, "tests": len(stored["star"]),
            "rows": [{"condition": c, "cells": [{"accuracy": scores[u][c].accuracy, "mean": scores[u][c].mean,
                                                 "best": scores[u][c].mean == best[u]} for u in users]}
                     for c in stored["conditions"]]}


def model_effects(stored: dict | None, user: str | None, lapse: float) -> list[dict]:
    """The effects `user`'s learners predict between this study's conditions (MODEL_COMPARISONS that it
    has): power_table's `predicted` rows, d = Cohen's d of the predicted mean confidence scores."""
    if stored is None or user not in stored["choice"]:
        return []
    scores = predicted_by_condition(stored, user, lapse)
    rows = []
    for a, b in MODEL_COMPARISONS:
        if a in scores and b in scores:
            sa, sb = scores[a], scores[b]
            rows.append({"comparison": f"{a} vs {b}, predicted by {user}",
                         "d": cohens_d(sa.mean, sa.sd, sb.mean, sb.sd),
                         "source": f"predicted for {user} learners with lapse rate {lapse:g}: mean score "
                                   f"{sa.mean:.2f} ± {sa.sd:.2f} vs {sb.mean:.2f} ± {sb.sd:.2f}"})
    return rows


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

    lapse = forms.FloatField(label="Learners' lapse rate ε", initial=DEFAULT_LAPSE, min_value=0, max_value=1,
                             required=False,  # empty: the default
                             error_messages=_bounded("The lapse rate", 0, 1, "0.1"),
                             help_text="The chance that a simulated learner guesses a test at random.")
    model = forms.ChoiceField(label="Learner model", required=False,
                              help_text="Whose predicted effects between this study's conditions to plan for.")

    def __init__(self, *args, users: list[str] = (), **kwargs):
        super().__init__(*args, **kwargs)
        self.fields["model"].choices = [(u, u) for u in users]
        self.fields["model"].initial = APPROX_STAR if APPROX_STAR in users else (users[0] if users else None)

    def clean(self):
        data = super().clean()
        if data.get("lapse") is None and "lapse" not in self.errors:
            data["lapse"] = DEFAULT_LAPSE
        if not data.get("model") and "model" not in self.errors:
            data["model"] = self.fields["model"].initial
        alpha, power = data.get("alpha"), data.get("power")
        if alpha is not None and power is not None and power_problem(power, alpha):
            self.add_error("power", f"Power must be above α ({alpha:g}): at a vanishing effect a test's power "
                                    "is α itself, so no number of participants reaches less.")
        return data


def smallest_target(study: Study) -> int:
    """The fewest participants any condition aims for: what a comparison between two conditions gets."""
    return min((c.target_count for c in study.conditions.all()), default=study.target_per_condition)


def power_rows(*, alpha: float, power: float, d: float, n: int, predicted: list[dict] = ()) -> list[dict]:
    """power_table's rows (the paper's effects, then `d`, then the model-`predicted` ones), each saying
    whether n per condition is enough (a predicted effect too small to plan for: None)."""
    rows = power_table(alpha=alpha, power=power, n_per_condition=n, effects={YOUR_EFFECT: d}, predicted=predicted)
    for row in rows:
        row["reached"] = None if row["needed"] is None else n >= row["needed"]
    return rows


def power_context(study: Study, query, stored: dict | None) -> dict:
    """The power form (bound to the page's GET parameters when it sent any, else its defaults), its table
    (with the chosen learner model's predicted effects where the study has predictions) and the predicted
    scores at the chosen lapse rate, or the form's messages."""
    users = list(stored["choice"]) if stored else []
    sent = any(name in query for name in PowerForm.base_fields)
    form = PowerForm(query if sent else None, users=users)
    if sent and not form.is_valid():
        return {"power_form": form, "power_rows": None, "predicted": None}
    values = form.cleaned_data if sent else {name: f.initial for name, f in form.fields.items()}
    n = smallest_target(study)
    # within the form's bounds a sample size always exists (analysis/power.py)
    predicted = model_effects(stored, values["model"], values["lapse"])
    rows = power_rows(alpha=values["alpha"], power=values["power"], d=values["d"], n=n, predicted=predicted)
    return {"power_form": form, "power_rows": rows, "power_n": n, "power_values": values,
            "power_reached": all(r["reached"] is not False for r in rows),
            "predicted": predicted_rows(stored, values["lapse"])}


def pilot_context(study: Study, query) -> dict:
    """Everything the "Simulated pilot" section of the study's page shows."""
    return {"pilot": pilot_matrix_rows(study), **power_context(study, query, stored_predictions(study))}
