"""Does a domain keep the contracts the core and the study's pages rely on?  (``python -m teaching check-domain``)

Each check plans what it needs itself (no table is built or read) and reports either one summary
line or one line per failure, each saying what is wrong, where, and what to do:

* **members**: every member of the interface's three parts (teaching.core.domain: WorldPart, PlannerPart,
  PagesPart) and all or none of the optional ShowWayPart, one line per missing member naming it and its
  part; the other checks need them, so they run only when this passes;
* **plan_chunk**: the four arrays' shapes and dtypes (Domain.plan_chunk), finite values, and each
  θ*-trajectory's distance to itself 0;
* **d_reward**: every θ's own trajectory is at least as good under θ as every other θ's in that
  environment, compared through :func:`teaching.core.rewards.reward` (exactly, as the learners do:
  d_reward >= 0 is its case against θ*'s);
* **labels**: strategy labels in 0..C and of the environment's own class, environment classes,
  class_of_cluster and test_clusters in range;
* **page_keys**: every page key is in each scene_payload, page_scene carries no other, both JSON;
* **palette**: every colour the scene's files read (teaching.core.scenecolours) and every legend
  swatch is in the palette;
* **test set**: on the preset's Θ, each test cluster has an environment where the real test-set
  selection (:func:`teaching.core.testset.select_test_set`) finds its four options.  The search
  runs on the sample first and then over the preset's other environments, a chunk at a time, until
  every test cluster has one: feasibility is the preset's, not the sample's.

Pure (no Django); the domain is any object with the Domain interface, so a test can wrap a real
one with one thing altered.
"""
from __future__ import annotations

import inspect
import json
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .base import BaseDomain
from .domain import OPTIONAL_PARTS, REQUIRED_PARTS, has_part, missing_members, part_members, shows_the_way
from .rewards import reward
from .scenecolours import STATIC, scene_colours, static_roots
from .showtests import MIN_SHARE, eligible_rows
from .table import TrajectoryTable
from .testset import MIN_REGRET, select_test_set

CHECKS = ("members", "plan_chunk", "d_reward", "labels", "page_keys", "palette", "test set")
DEFAULT_ENVS = 48  # planned for the checks but the test set's search: seconds for either built-in domain
ROOT = Path(__file__).resolve().parents[2]


@dataclass(frozen=True)
class Result:
    check: str
    failures: tuple[str, ...]  # one actionable line each; empty when the check passes
    summary: str = ""  # what passed, one line

    @property
    def ok(self) -> bool:
        return not self.failures


def default_preset(domain):
    """The preset checked when none is named: the domain's second-smallest (its demo size), or its only
    one.  The smallest is usually a tiny test table, too small for a test set at the default distance."""
    presets = sorted(domain.presets, key=lambda p: (p.n_envs * p.n_thetas, p.name))
    return presets[min(1, len(presets) - 1)]


def where(domain, member: str) -> str:
    """The file that defines `member` of `domain` (a method's own module, else the domain's class)."""
    target = getattr(domain, member, None)
    for obj in (getattr(target, "__func__", None), type(domain)):
        try:
            path = Path(inspect.getsourcefile(obj)).resolve()
        except (TypeError, OSError):
            continue
        try:
            return path.relative_to(ROOT).as_posix()
        except ValueError:
            return str(path)
    return type(domain).__name__


def expected_arrays(domain, n: int, n_thetas: int) -> dict:
    """name -> (shape, dtype) of plan_chunk's output for n environments and n_thetas objectives."""
    d = len(domain.feature_names)
    return {"controls": ((n, n_thetas, *domain.trajectory_shape), np.dtype(domain.trajectory_dtype)),
            "features": ((n, n_thetas, d), np.dtype(np.float64)),
            "strategy": ((n, n_thetas), np.dtype(np.int8)), "d_euclid": ((n, n_thetas), np.dtype(np.float32))}


def check_members(domain) -> Result:
    """Every member of each required part, and all or none of an optional one: one line per missing member."""
    name = getattr(domain, "name", type(domain).__name__)
    fails = []
    for part, lacks in missing_members(domain).items():
        role = part.__doc__.split(":")[0].split(".")[0].strip()
        for member in lacks:
            default = ("subclass teaching.core.base.BaseDomain, which gives it, or "
                       if hasattr(BaseDomain, member) else "")
            fails.append(f"domain {name!r} ({type(domain).__name__}) lacks '{member}' of {part.__name__} ({role}): "
                         f"{default}define it as teaching/core/domain.py {part.__name__} declares it")
    if fails:
        return Result("members", tuple(fails))
    parts = ", ".join(f"{p.__name__} ({len(part_members(p))})" for p in REQUIRED_PARTS)
    optional = ", ".join(f"{p.__name__} {'too' if has_part(domain, p) else 'not'}" for p in OPTIONAL_PARTS)
    return Result("members", (), f"every member of {parts} is there; the optional {optional}")


def check_arrays(domain, out, env_ids: np.ndarray, n_thetas: int) -> Result:
    at = f"{domain.name}.plan_chunk ({where(domain, 'plan_chunk')})"
    if not isinstance(out, dict):
        return Result("plan_chunk", (f"{at} returned {type(out).__name__}, not a dict: return "
                                     f"{{'controls', 'features', 'strategy', 'd_euclid'}} as NumPy arrays",))
    fails = []
    for name, (shape, dtype) in expected_arrays(domain, len(env_ids), n_thetas).items():
        a = out.get(name)
        if not isinstance(a, np.ndarray):
            fails.append(f"{at} returned no array '{name}' (got {type(a).__name__}): return {name} {shape} {dtype}")
        elif a.shape != shape:
            fails.append(f"{at}: '{name}' has shape {a.shape}, expected {shape} (n environments, N θ"
                         f"{', *trajectory_shape' if name == 'controls' else ''}"
                         f"{', D features' if name == 'features' else ''}): return it in that shape")
        elif a.dtype != dtype:
            fails.append(f"{at}: '{name}' is {a.dtype}, expected {dtype}"
                         f"{' (the domain trajectory_dtype)' if name == 'controls' else ''}: "
                         f"return {name}.astype(np.{dtype.name})")
    if not fails:
        for name in ("features", "d_euclid"):
            bad = ~np.isfinite(out[name])
            if bad.any():
                e = int(np.argwhere(bad)[0][0])
                fails.append(f"{at}: '{name}' has {int(bad.sum())} values that are not finite (first in environment "
                             f"{int(env_ids[e])}): every trajectory needs finite {name}")
        d = out["d_euclid"]
        if np.any(d < 0) or np.any(d[:, 0] != 0):
            fails.append(f"{at}: 'd_euclid' must be >= 0 and 0 for θ* (column 0), got min {float(d.min()):.3g} and "
                         f"max |d_euclid[:, 0]| {float(np.abs(d[:, 0]).max()):.3g}: measure each trajectory's "
                         f"euclidean_distance to θ*'s")
    if fails:
        return Result("plan_chunk", tuple(fails))
    shapes = ", ".join(f"{k} {out[k].shape} {out[k].dtype}" for k in expected_arrays(domain, 0, 0))
    return Result("plan_chunk", (), shapes)


def check_d_reward(domain, out, env_ids, thetas) -> Result:
    """Under each θ, its own trajectory against every θ's of the environment, through reward()."""
    thetas = np.asarray(thetas, np.float64)
    features = np.asarray(out["features"], np.float64)
    n_bad, n_star, worst = 0, 0, (0.0, 0, 0, 0)
    for e in range(len(env_ids)):
        r = reward(features[e][None, :, :], thetas[:, None, :])  # (θ, whose trajectory)
        gap = np.diagonal(r)[:, None] - r
        n_bad += int((gap < 0).any(axis=1).sum())
        n_star += int((gap[:, 0] < 0).sum())  # the table's d_reward, θ's own against θ*'s
        i, j = np.unravel_index(int(np.argmin(gap)), gap.shape)
        if gap[i, j] < worst[0]:
            worst = (float(gap[i, j]), int(env_ids[e]), int(i), int(j))
    pairs = len(env_ids) * len(thetas)
    if n_bad:
        gap, env, i, j = worst
        return Result("d_reward", (
            f"{domain.name}.plan_chunk ({where(domain, 'plan_chunk')}): in {n_bad:,} of {pairs:,} (environment, θ) "
            f"pairs θ's own trajectory is worse under θ than another θ's, d_reward < 0 (worse than θ*'s) in "
            f"{n_star:,}; worst: environment {env}, θ {i} by {-gap:.3g} against θ {j}'s: give each θ the best under "
            f"reward() (teaching/core/rewards.py, its summation order) of every θ's trajectory in the environment",))
    return Result("d_reward", (), f"in all {pairs:,} (environment, θ) pairs θ's own trajectory is the best under θ of "
                                  f"the environment's {len(thetas)}")


def check_labels(domain, out, env_ids) -> Result:
    fails = []
    at = where(domain, "plan_chunk")
    coc = np.asarray(domain.class_of_cluster)
    C, K = len(coc), len(domain.class_names)
    if len(domain.cluster_names) != C + 1:
        fails.append(f"{domain.name}: cluster_names has {len(domain.cluster_names)} names for {C} clusters "
                     f"(class_of_cluster): name the C clusters, then 'no strategy' ({where(domain, 'name')})")
    if coc.size and (coc.min() < 0 or coc.max() >= K):
        fails.append(f"{domain.name}: class_of_cluster {coc.tolist()} names a class outside 0..{K - 1} "
                     f"(class_names): fix it ({where(domain, 'name')})")
    bad = [c for c in domain.test_clusters if not 0 <= c < C]
    if bad:
        fails.append(f"{domain.name}: test_clusters {list(domain.test_clusters)} has {bad} outside 0..{C - 1}: "
                     f"name real clusters ({where(domain, 'name')})")
    cls = np.asarray(domain.environment_class(np.asarray(env_ids)))
    if cls.shape != (len(env_ids),) or cls.size and (cls.min() < 0 or cls.max() >= K):
        fails.append(f"{domain.name}.environment_class ({where(domain, 'environment_class')}) gave shape {cls.shape}, "
                     f"values {sorted(set(cls.ravel().tolist()))[:8]}: give (n,) classes in 0..{K - 1}")
    s = np.asarray(out["strategy"])
    outside = (s < 0) | (s > C)
    if outside.any():
        e, t = np.argwhere(outside)[0]
        fails.append(f"{domain.name}.plan_chunk ({at}): {int(outside.sum())} strategy labels outside 0..{C} (first: "
                     f"{int(s[e, t])} in environment {int(env_ids[e])}, θ {int(t)}): label clusters 0..{C - 1}, {C} "
                     f"for none")
    elif not fails:
        labelled = s < C
        other = labelled & (coc[np.minimum(s, C - 1)] != cls[:, None])
        if other.any():
            e, t = np.argwhere(other)[0]
            fails.append(f"{domain.name}.plan_chunk ({at}): {int(other.sum())} trajectories labelled with another "
                         f"class's cluster (first: environment {int(env_ids[e])} of class "
                         f"'{domain.class_names[cls[e]]}', θ {int(t)}, '{domain.cluster_names[s[e, t]]}'): label "
                         f"it {C} (none of its class's strategies) or fix environment_class")
    if fails:
        return Result("labels", tuple(fails))
    seen = np.bincount(s.ravel().astype(np.int64), minlength=C + 1)
    return Result("labels", (), f"strategy labels in 0..{C} of the environment's class ({int((seen[:C] > 0).sum())} "
                                f"of {C} clusters seen), classes in 0..{K - 1}")


def check_page_keys(domain, out, env_ids) -> Result:
    at = where(domain, "scene_payload")
    fails = []
    keys = tuple(domain.page_keys)
    for e, env in enumerate(env_ids):
        payload = domain.scene_payload(int(env))
        if not isinstance(payload, dict):
            fails.append(f"{domain.name}.scene_payload ({at}) returned {type(payload).__name__} for environment {env}: "
                         f"return a dict")
            break
        lacking = [k for k in keys if k not in payload]
        if lacking:
            fails.append(f"{domain.name}: page_keys {list(keys)} name {lacking}, which scene_payload({int(env)}) lacks "
                         f"(it has {sorted(payload)}): add them to scene_payload or drop them from page_keys ({at})")
            break
        extra = sorted(set(domain.page_scene(payload)) - set(keys))
        if extra:
            fails.append(f"{domain.name}.page_scene ({where(domain, 'page_scene')}) carries {extra}, not among "
                         f"page_keys {list(keys)}: a participant's page may carry page_keys only")
            break
        try:
            json.dumps(payload)
            json.dumps(domain.path_rows(domain.states(out["controls"][e, 0])))
        except (TypeError, ValueError) as exc:
            fails.append(f"{domain.name}: scene_payload or path_rows of environment {int(env)} is not JSON ({exc}): "
                         f"return lists, numbers and strings ({at})")
            break
    if fails:
        return Result("page_keys", tuple(fails))
    return Result("page_keys", (), f"{', '.join(keys)} in every scene_payload of {len(env_ids)} environments")


def check_palette(domain, static: Path | tuple[Path, ...] = STATIC) -> Result:
    """static: as scene_colours takes it (a folder, or several searched in order)."""
    roots = static_roots(static)
    if not any(r.is_dir() for r in roots):  # the core installed as a package, without the web pages
        return Result("palette", (), f"not checked: the web pages' scene files ({roots[0]}) come with a clone of the "
                                     "repository, not with the installed core")
    palette = set(domain.palette)
    at = where(domain, "palette")
    scene = scene_colours(domain.scene, static)
    fails = [f"{domain.name}: no scene {path}: write the domain's scene (docs/domains.md, The web side)"
             for path in scene.missing_files]
    fails += [f"{call}: cannot read which colours this call names: pass palette.js's colors() an array literal or a "
              f"const array of names" for call in scene.unreadable]
    if not scene.missing_files and not scene.uses_palette:
        fails.append(f"static/studyapp/scenes/{domain.scene}.js does not import colors from ../palette.js: read the "
                     f"scene's colours from the domain's palette")
    for name, path in sorted(scene.reads.items()):
        if name not in palette:
            fails.append(f"{path} reads colour '{name}' (--scene-{name}), which {domain.name}'s palette lacks: add "
                         f"'{name}' to the palette ({at}) or stop reading it")
    for entry in domain.texts.legend:
        for role in ("fill", "edge", "hatch"):
            colour = getattr(entry, role)
            if colour and colour not in palette:
                fails.append(f"{domain.name}: legend swatch '{entry.label}' has {role} '{colour}', which the palette "
                             f"lacks: add it to the palette or name a palette colour ({where(domain, 'texts')})")
    if fails:
        return Result("palette", tuple(fails))
    return Result("palette", (), f"the {len(scene.reads)} colours the scene reads and the legend's swatches are "
                                 f"among the palette's {len(palette)}")


@dataclass
class _SampleTable(TrajectoryTable):
    """Planned environments as a table of `checked` (the domain object under check, not the registry's)."""

    checked: object = None

    @property
    def domain(self):
        return self.checked


@dataclass
class _Narrowed:
    """`domain` seen with only the test clusters still to find."""

    inner: object
    test_clusters: tuple = field(default_factory=tuple)

    def __getattr__(self, name):
        return getattr(self.inner, name)


def _table(domain, out, env_ids, thetas, normalisers) -> _SampleTable:
    return _SampleTable(thetas=thetas, env_ids=np.asarray(env_ids, np.int64), normalisers=normalisers,
                        checked=domain, **{k: out[k] for k in expected_arrays(domain, 0, 0)})


def check_test_set(domain, preset, order, first, thetas, normalisers, min_regret, min_distance,
                   log: Callable[[str], None]) -> Result:
    """Each test cluster's feasibility on the preset: `first` is the plan of order[:len], the rest is planned
    a chunk at a time while some cluster has no test environment.  A domain that scores a shown way
    (``score_shown``) may test a cluster by asking to show the way (teaching.core.showtests) where no
    environment has four options to choose among."""
    distance = domain.min_option_distance if min_distance is None else min_distance
    shows = shows_the_way(domain)
    found, found_show, shown, done = {}, {}, {c: 0 for c in domain.test_clusters}, 0
    out = first
    while True:
        ids = order[done:done + len(out["strategy"])]
        table = _table(_Narrowed(domain, tuple(c for c in domain.test_clusters if c not in found)), out, ids, thetas,
                       normalisers)
        star, cls = np.asarray(table.strategy[:, 0]), table.env_class
        for c in shown:
            shown[c] += int(((star == c) & (cls == domain.class_of_cluster[c])).sum())
        for test in select_test_set(table, [], seed=preset.seed, min_regret=min_regret, min_distance=distance,
                                    skip_missing=True):
            found[test["cluster"]] = test
        for c, rows in (eligible_rows(table, [], min_regret) if shows else {}).items():
            if rows and c not in found_show:
                found_show[c] = int(ids[rows[0][0]])
        done += len(ids)
        missing = [c for c in domain.test_clusters if c not in found and c not in found_show]
        if not missing or done >= len(order):
            break
        log(f"test set: searched {done:,} of {len(order):,} environments, no test yet for "
            f"{', '.join(domain.cluster_names[c] for c in missing)}")
        ids = order[done:done + preset.chunk_size]
        out = domain.plan_chunk(ids, thetas, normalisers)
    on = f"preset {preset.name} ({len(order):,} environments × {len(thetas)} θ)"
    fails = tuple(
        f"no environment of {on} can test cluster {c} '{domain.cluster_names[c]}': {shown[c]} show it under θ*, "
        f"none has 3 distinct optimal alternatives to θ*'s (1 of this strategy and 2 of a sibling's, or any 3 of its "
        f"class) with θ*-regret >= {min_regret:g}, all 4 pairwise >= {distance:g} apart"
        + (f", nor enough θ doing worse for a show test (a share >= {MIN_SHARE:g} with θ*-regret >= {min_regret:g})"
           if shows else "")
        + ": use a preset with more θ or environments, lower --min-option-distance, or drop it from test_clusters "
        f"({where(domain, 'test_clusters')})"
        for c in missing)
    if fails:
        return Result("test set", fails)
    picks = ", ".join(f"'{domain.cluster_names[c]}' environment {found[c]['env_id']}"
                      f"{' (relaxed)' if found[c]['rule'] == 'relaxed' else ''}" if c in found else
                      f"'{domain.cluster_names[c]}' environment {found_show[c]} (show the way)"
                      for c in domain.test_clusters)
    return Result("test set", (), f"every test cluster has a test environment on {on}, found in the first {done:,} "
                                  f"(min distance {distance:g}, min regret {min_regret:g}): {picks}")


def check_domain(domain, preset=None, n_envs: int = DEFAULT_ENVS, min_regret: float = MIN_REGRET,
                 min_distance: float | None = None, log: Callable[[str], None] | None = None,
                 static: Path = STATIC) -> Iterator[Result]:
    """Run every check on `domain` (a Domain) and `preset` (one of its presets; None: default_preset),
    yielding each Result as it is done.  n_envs: the sample the checks but the test set's plan, a seeded
    draw from the preset's environments; the test set's search goes on from there."""
    log = log or (lambda _: None)
    members = check_members(domain)
    yield members
    if not members.ok:
        return
    preset = default_preset(domain) if preset is None else preset
    thetas, normalisers = preset.thetas(), np.asarray(domain.default_normalisers(), np.float64)
    ids = (np.arange(domain.n_environments) if preset.n_envs >= domain.n_environments
           else np.asarray(domain.stratified_sample(preset.n_envs, seed=preset.seed)))
    order = np.random.default_rng(preset.seed).permutation(ids)
    sample = order[:max(1, n_envs)]
    log(f"planning {len(sample):,} of the {len(order):,} environments of preset {preset.name} × {len(thetas)} θ")
    out = domain.plan_chunk(sample, thetas, normalisers)
    arrays = check_arrays(domain, out, sample, len(thetas))
    yield arrays
    if arrays.ok:
        yield check_d_reward(domain, out, sample, thetas)
        yield check_labels(domain, out, sample)
        yield check_page_keys(domain, out, sample)
    yield check_palette(domain, static)
    if arrays.ok:
        yield check_test_set(domain, preset, order, out, thetas, normalisers, min_regret, min_distance, log)
