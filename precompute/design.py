"""The study designer's form: pick a built table (its identity shown), the conditions and the
study's settings; "Build" runs selection and the test set on the workers (precompute/study.py).

The study is built closed: the researcher previews every condition on its dashboard page, then
opens it there.
"""
from __future__ import annotations

import json
from pathlib import Path

from django import forms
from django.conf import settings

from studyapp.analysis.conditions import aliased_pairs
from studyapp.models import Study
from studyapp.studies import TEXT_FIELDS
from teaching.api import (
    APPROX_STAR,
    CONDITIONS,
    MIN_OPTION_DISTANCE,
    MIN_REGRET,
    MODEL_NAMES,
    N_ENVIRONMENTS,
    PRESETS,
    SAMPLERS,
    TableError,
    TrajectoryTable,
    parse_hyperparameters,
)

from .jobs import table_preset


def tables_dir() -> Path:
    return Path(settings.TABLES_DIR)


def built_tables(root: Path | None = None) -> list[dict]:
    """Every published table under `root` (TABLES_DIR): path and identity from its meta.json
    (read only: verifying a paper table's hash would take a minute per page view)."""
    root = Path(root or tables_dir())
    out = []
    for meta_path in sorted(root.glob("*/meta.json")):
        try:
            meta = json.loads(meta_path.read_text())
            shape = meta["shape"]
            out.append({"path": str(meta_path.parent), "preset": meta.get("preset", "?"),
                        "envs": int(shape["envs"]), "thetas": int(shape["thetas"]),
                        "theta_star": meta.get("theta_star"), "hash": str(meta.get("content_hash", ""))[:16],
                        "built_at": meta.get("built_at", "")})
        except (OSError, ValueError, KeyError, TypeError):
            continue  # not a finished table (a build in progress, a stray directory)
    return out


def table_label(t: dict) -> str:
    star = ", ".join(f"{v:g}" for v in t["theta_star"] or [])
    return f"{t['preset']}: {t['envs']:,} environments × {t['thetas']:,} θ, θ* = ({star}), hash {t['hash']}"


class StudyDesignForm(forms.Form):
    table = forms.ChoiceField(help_text="A table built with python -m teaching build, or by a table job.")
    slug = forms.SlugField(max_length=50, help_text="The study's URL: /s/SLUG/.")
    name = forms.CharField(max_length=200, required=False, help_text="Title for researchers (default: the slug).")
    conditions = forms.MultipleChoiceField(choices=[(c, c) for c in CONDITIONS], initial=list(CONDITIONS),
                                           widget=forms.CheckboxSelectMultiple, required=False)
    target_per_condition = forms.IntegerField(min_value=2, max_value=100_000, initial=30)
    recruitment = forms.ChoiceField(choices=Study.RECRUITMENTS, initial=Study.LINK)
    completion_code = forms.CharField(max_length=64, required=False,
                                      help_text="Prolific's completion code (required for Prolific).")
    approx_star = forms.ChoiceField(choices=[(m, m) for m in MODEL_NAMES], initial=APPROX_STAR,
                                    label="approx* (the model coverage-approx* augments)")
    seed = forms.IntegerField(min_value=0, initial=0, help_text="Seeds the random conditions and the test set.")
    hyperparameters = forms.CharField(
        required=False, label="Fixed τ / λ (optional)",
        help_text="MODEL=VALUE, comma-separated, e.g. det-euclidean=0.5, prob-reward=2: these models use the "
                  "value given instead of the paper's rule (the largest τ, or smallest λ, that still teaches θ*).")
    hand_picked_name = forms.SlugField(required=False, max_length=40, initial="hand-picked",
                                       label="Hand-picked condition: name")
    hand_picked_env_ids = forms.CharField(
        required=False, label="Hand-picked condition: environment ids",
        help_text="Optional: environment ids of the table, comma-separated, shown in this order as one more "
                  "condition.")
    min_regret = forms.FloatField(min_value=0, initial=MIN_REGRET, label="Test set: minimum θ*-regret",
                                  help_text="Each wrong option is at least this much worse for θ* (reward units).")
    min_distance = forms.FloatField(min_value=0, initial=MIN_OPTION_DISTANCE, label="Test set: minimum distance",
                                    help_text="The four options are at least this far apart (scaled state units; "
                                              "0.5 is about 6 ft on average).")

    def __init__(self, *args, tables: list[dict], **kwargs):
        super().__init__(*args, **kwargs)
        self.fields["table"].choices = [(t["path"], table_label(t)) for t in tables]
        # The consent page's texts, declared once on the Study model.
        self.fields.update(forms.fields_for_model(Study, fields=TEXT_FIELDS))

    def clean_hyperparameters(self):
        text = self.cleaned_data["hyperparameters"].strip()
        try:
            return parse_hyperparameters([t.strip() for t in text.split(",") if t.strip()])
        except ValueError as exc:
            raise forms.ValidationError(str(exc)) from None

    def clean_hand_picked_env_ids(self):
        text = self.cleaned_data["hand_picked_env_ids"].strip()
        try:
            return [int(t) for t in text.replace(",", " ").split()]
        except ValueError:
            raise forms.ValidationError("Give whole environment ids, separated by commas.") from None

    def clean_slug(self):
        slug = self.cleaned_data["slug"]
        if Study.objects.filter(slug=slug).exists():
            raise forms.ValidationError(f"A study called {slug!r} exists already: choose another name.")
        return slug

    def clean(self):
        data = super().clean()
        if data.get("recruitment") == Study.PROLIFIC and not (data.get("completion_code") or "").strip():
            self.add_error("completion_code", "Prolific only accepts its study's own completion code: enter it.")
        ids = data.get("hand_picked_env_ids")
        if ids:
            name = data.get("hand_picked_name") or "hand-picked"
            data["hand_picked_name"] = name
            chosen = list(data.get("conditions") or [])
            aliased = aliased_pairs([*chosen, name])
            if name in chosen:
                self.add_error("hand_picked_name", f"{name!r} is already one of the chosen conditions.")
            elif aliased:  # the analysis would pool the two as one group
                first = aliased[0][0]
                self.add_error("hand_picked_name", f"{name!r} is another name of the chosen condition {first!r}: "
                                                   "choose a name of its own.")
            elif data.get("table"):
                self._check_in_table(data["table"], ids)
        elif not data.get("conditions") and "conditions" not in self.errors:
            self.add_error("conditions", "Choose at least one condition, or give a hand-picked one.")
        return data

    def _check_in_table(self, table_path: str, ids: list[int]) -> None:
        try:
            table = TrajectoryTable.load(table_path, verify=False)
        except (TableError, OSError, ValueError) as exc:
            self.add_error("table", f"Cannot read this table: {exc}")
            return
        missing = sorted(set(ids) - {int(e) for e in table.env_ids})
        if missing:
            self.add_error("hand_picked_env_ids", f"Not in this table: {', '.join(map(str, missing[:10]))}"
                           f"{' ...' if len(missing) > 10 else ''} (it has {table.n_envs:,} environments).")


class TableBuildForm(forms.Form):
    """A table to build on the workers: a preset, optionally changed (its own name then)."""
    preset = forms.ChoiceField(choices=[(n, f"{n}: {p.n_envs:,} environments × {p.n_thetas:,} θ")
                                        for n, p in PRESETS.items()], initial="demo")
    envs = forms.IntegerField(required=False, min_value=4, max_value=N_ENVIRONMENTS, label="Environments (optional)")
    thetas = forms.IntegerField(required=False, min_value=2, label="Number of θ (optional)")
    theta_star = forms.CharField(required=False, label="θ* (optional)",
                                 help_text="5 negative weights, v1,v2,v3,v4,v5 (default: the paper's).")
    sampler = forms.ChoiceField(required=False, choices=[("", "the preset's")] + [(s, s) for s in SAMPLERS])
    seed = forms.IntegerField(required=False, min_value=0, label="Seed (optional)")

    def clean(self):
        data = super().clean()
        if self.errors:
            return data
        try:
            data["built"] = table_preset(data["preset"], envs=data.get("envs"), thetas=data.get("thetas"),
                                         seed=data.get("seed"), sampler=data.get("sampler") or None,
                                         theta_star=data.get("theta_star") or None)
        except ValueError as exc:
            raise forms.ValidationError(str(exc)) from None
        return data
