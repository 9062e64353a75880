"""The tables a study can be built on: those built under TABLES_DIR (read from their meta.json) as the
designer lists them, and the form that builds another on the workers from a preset."""
from __future__ import annotations

import json
from pathlib import Path

from django import forms

from teaching.api import PRESETS, SAMPLERS, default_domain_name, domain_names, get_domain, register_table_robot

from .jobs import table_preset, tables_dir


def built_tables(root: Path | None = None) -> list[dict]:
    """Every published table under `root` (TABLES_DIR): path and identity from its meta.json
    (read only: verifying a paper table's hash would take a minute per page view)."""
    root = Path(root or tables_dir())
    out = []
    for meta_path in sorted(root.glob("*/meta.json")):
        try:
            meta = json.loads(meta_path.read_text())
            shape = meta["shape"]
            domain = meta.get("domain") or default_domain_name()  # a table built before domains: the default's
            if domain not in domain_names():
                register_table_robot(meta_path.parent)  # an imported table carries its robot (TableError if broken)
            if domain not in domain_names():
                continue  # a table of a domain this installation does not have
            out.append({"path": str(meta_path.parent), "preset": meta.get("preset", "?"), "domain": domain,
                        "features": get_domain(domain).feature_names,
                        "envs": int(shape["envs"]), "thetas": int(shape["thetas"]),
                        "theta_star": meta.get("theta_star"), "hash": str(meta.get("content_hash", ""))[:16],
                        "built_at": meta.get("built_at", "")})
        except (OSError, ValueError, KeyError, TypeError):
            continue  # not a finished table (a build in progress, a stray directory)
    return out


def table_label(t: dict) -> str:
    """e.g. "demo: 1,200 environments × 200 θ, θ* = (closeness -64, ...), hash ..." (θ*'s feature names
    are its domain's)."""
    star = ", ".join(f"{name} {v:g}" for name, v in zip(t["features"], t["theta_star"] or [], strict=False))
    return f"{t['preset']}: {t['envs']:,} environments × {t['thetas']:,} θ, θ* = ({star}), hash {t['hash']}"


def table_choices(tables: list[dict]) -> list:
    """The designer's table list, grouped by domain (the study's domain is its table's)."""
    groups: dict[str, list] = {}
    for t in tables:
        groups.setdefault(t["domain"], []).append((t["path"], table_label(t)))
    return [(f"{domain} ({len(items)} table{'s' if len(items) > 1 else ''})", items)
            for domain, items in groups.items()]


def preset_choices() -> list:
    """Every domain's presets, grouped by domain, with θ*'s length and feature names."""
    out = []
    for domain in domain_names():
        d = get_domain(domain)
        items = [(n, f"{n}: {p.n_envs:,} environments × {p.n_thetas:,} θ") for n, p in PRESETS.items()
                 if p.domain == domain]
        out.append((f"{domain}: θ* has {len(d.feature_names)} weights ({', '.join(d.feature_names)})", items))
    return out


class TableBuildForm(forms.Form):
    """A table to build on the workers: a preset, optionally changed (its own name then)."""
    preset = forms.ChoiceField(choices=preset_choices, initial="demo",
                               help_text="The domain and size to start from; the fields below change it (the "
                                         "table then gets a name of its own).")
    envs = forms.IntegerField(required=False, min_value=4, label="Environments (optional)",
                              error_messages={"min_value": "A table needs at least 4 environments."},
                              help_text="How many environments, 4 to all of the domain's; empty: the preset's.")
    thetas = forms.IntegerField(required=False, min_value=2, label="Number of θ (optional)",
                                error_messages={"min_value": "A table needs at least 2 θ: θ* and one other."},
                                help_text="How many candidate objectives, θ* included, at least 2 (empty: the "
                                          "preset's).")
    theta_star = forms.CharField(required=False, label="θ* (optional)",
                                 help_text="One negative weight per feature of the preset's domain, comma-separated "
                                           "(see the preset list; default: the domain's θ*).")
    sampler = forms.ChoiceField(required=False, choices=[("", "the preset's")] + [(s, s) for s in SAMPLERS],
                                help_text="How the other θ are drawn around θ*.")
    seed = forms.IntegerField(required=False, min_value=0, label="Seed (optional)",
                              error_messages={"min_value": "A seed is a whole number, 0 or more."},
                              help_text="Seeds the θ and environment samples (empty: the preset's).")

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.fields["envs"].help_text += " (" + "; ".join(  # how many each registered domain has
            f"{name}: {get_domain(name).n_environments:,}" for name in domain_names()) + ")"

    OVERRIDES = ("envs", "thetas", "seed", "sampler", "theta_star")

    def clean(self):
        """Every bad value is said under its own field, all at once (each override is checked alone
        by jobs.table_preset, the command's rules)."""
        data = super().clean()
        if not data.get("preset"):
            return data
        overrides = {k: data.get(k) if data.get(k) not in ("", None) else None for k in self.OVERRIDES}
        for name, value in overrides.items():
            if value is None or name in self.errors:
                continue
            try:
                table_preset(data["preset"], **{name: value})
            except ValueError as exc:
                self.add_error(name, str(exc).removeprefix("theta*: ").replace("theta*", "θ*"))
        if not self.errors:
            try:
                data["built"] = table_preset(data["preset"], **overrides)
            except ValueError as exc:
                self.add_error(None, str(exc))
        return data
