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

from studyapp.models import Study
from teaching.api import APPROX_STAR, CONDITIONS, MODEL_NAMES


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
                                           widget=forms.CheckboxSelectMultiple)
    target_per_condition = forms.IntegerField(min_value=2, max_value=100_000, initial=30)
    recruitment = forms.ChoiceField(choices=Study.RECRUITMENTS, initial=Study.LINK)
    completion_code = forms.CharField(max_length=64, required=False,
                                      help_text="Prolific's completion code (required for Prolific).")
    approx_star = forms.ChoiceField(choices=[(m, m) for m in MODEL_NAMES], initial=APPROX_STAR,
                                    label="approx* (the model coverage-approx* augments)")
    seed = forms.IntegerField(min_value=0, initial=0, help_text="Seeds the random conditions and the test set.")

    def __init__(self, *args, tables: list[dict], **kwargs):
        super().__init__(*args, **kwargs)
        self.fields["table"].choices = [(t["path"], table_label(t)) for t in tables]

    def clean_slug(self):
        slug = self.cleaned_data["slug"]
        if Study.objects.filter(slug=slug).exists():
            raise forms.ValidationError(f"A study called {slug!r} exists already: choose another name.")
        return slug

    def clean(self):
        data = super().clean()
        if data.get("recruitment") == Study.PROLIFIC and not (data.get("completion_code") or "").strip():
            self.add_error("completion_code", "Prolific only accepts its study's own completion code: enter it.")
        return data
