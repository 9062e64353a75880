"""A world file as a registered domain: :class:`FileGridDomain` and :func:`world_domain`.

Everything a domain needs comes from the file (teaching.domains._grid.worldfile) and the exact
planner (teaching.domains._grid.fileworld): an environment is a variant and a state of its start pool
(ids variant by variant, each variant's pool in order), classes and strategy
clusters are the file's rules over a trajectory's counts, θ* and the presets are the file's.

An environment's class, never from θ: the first of the file's classes of which at least two
strategies are shown by some trajectory on the environment's fronts (so the environment can tell
them apart), else "other".
"""
from __future__ import annotations

import re
from functools import cache, cached_property
from pathlib import Path

import numpy as np

from ...core.build import Preset
from ...core.domain import ComprehensionQuestion, LegendEntry, ParticipantTexts
from ...core.i18n import gettext_noop as _
from . import ROOT
from .domain import GridDomain
from .fileworld import EXIT, ReplayError, fronts, play, start_pool, world_fingerprint
from .worldfile import HELD, World, WorldFileError, load_world

# words a world's name or class names may hold that any text about teaching uses too (the "two" of "two-goal",
# the "which" of "which goal"): not the robot's own, so not in its vocabulary (the core names no robot's words)
PLAIN_WORDS = frozenset({"one", "two", "three", "four", "which", "what", "the", "and", "other"})
PLANNER_VERSION = 1  # bump whenever a change alters the trajectories the planner returns
SECONDS_PER_ACTION = 0.4


class FileGridDomain(GridDomain):
    """The domain of one world file (module docstring): a grid domain whose fronts are the
    planner's, one per way an episode ends, and whose trajectories carry what the robot holds."""

    extra_code_roots = ()  # code_root is the building blocks' package itself
    code_root = ROOT
    trajectory_dtype = np.dtype(np.int16)
    # the Euclidean learner compares positions in cells; holding the object is part of a state (a
    # pick-up is an action taken) but adds no distance
    state_scale = (1.0, 1.0, np.inf)
    page_keys = ("dt", "world")
    scene = "world"  # static/studyapp/scenes/world.js draws every world from a file

    def __init__(self, world: World):
        self.world = world
        self.name = world.name
        pools = []
        # each variant's start pool; reachability depends only on which cells are blocked, so variants that
        # block the same cells share one pool
        by_blocked: dict[bytes, tuple] = {}
        for v in range(world.n_variants):
            key = world.blocked(v).tobytes()
            if key not in by_blocked:
                by_blocked[key] = start_pool(world, v)
            pools.append(by_blocked[key])
        self.pools = tuple(pools)  # (V,) each variant's start states
        self._first_id = np.cumsum([0, *(len(p) for p in self.pools)])  # (V + 1,) each variant's first id
        self.n_environments = int(self._first_id[-1])
        self.feature_names = world.feature_names
        self.theta_star = np.array(world.theta_star)
        self.min_option_distance = world.min_option_distance
        self.width, self.max_moves = world.width, world.max_moves
        self.class_names = (*(c.name for c in world.classes), "other")
        strategies = [(i, s) for i, c in enumerate(world.classes) for s in c.strategies]
        self._strategies = strategies
        self.cluster_names = (*(f"{world.classes[i].name}: {s.name}" for i, s in strategies),
                              f"other: {world.other}", "none of its class's strategies")
        self.class_of_cluster = np.array([i for i, _ in strategies] + [len(world.classes)])
        self.test_clusters = tuple(next(k for k, (_, s) in enumerate(strategies) if s.name == t) for t in world.tests)
        words = {world.name, *world.kinds, *(world.obj or "").split()} | {c.name for c in world.classes}
        self.vocabulary = frozenset(w for word in words for w in re.findall(r"[a-z]+", word.lower())
                                    if len(w) > 2 and w not in PLAIN_WORDS)
        self.palette = {"free": "#f4f1e8", "grid": "#c8c2b4", "wall": "#2f3338", "robot": "#f5c518",
                        "robot-edge": "#111111", "path": "#ff7a1a", "text": "#111111", "object": "#7c3aed",
                        **{f"cell-{k}": v.colour for k, v in world.kinds.items()}}
        self.texts = _texts(world)
        # each default text that names the world, by its English text: the marked text and the values it was
        # filled with, so that the web side can look the marked text up and fill in the translation
        self.formatted_texts = {text.format(title=world.title): (text, {"title": world.title})
                                for text in (SUMMARY, CONSENT, WATCH_FIRST)}
        if world.obj and world.destination is not None:  # the legend's D names the object
            self.formatted_texts[DESTINATION.format(object=world.obj)] = (DESTINATION, {"object": world.obj})
        # the file's own texts in other languages ([translations.<language>]): they are the researcher's, so
        # they travel with the file rather than in the project's catalogs
        self.translations = world.translations
        self.translations_source = world.source

    @cached_property
    def presets(self) -> tuple[Preset, ...]:
        return tuple(Preset(self.name if suffix == "full" else f"{self.name}-{suffix}",
                            n_envs=min(envs or self.n_environments, self.n_environments), n_thetas=thetas,
                            chunk_size=64, domain=self.name)
                     for suffix, (envs, thetas) in self.world.presets.items())

    def fingerprint(self) -> str:
        return world_fingerprint(self.world)

    def planner_identity(self) -> dict:
        return {"version": PLANNER_VERSION, "algorithm": "label-setting over (cell, object) per ending"}

    def parse_theta_star(self, values) -> tuple[float, ...]:
        """θ* from one number per feature, each with the sign the file's θ* gives it."""
        if isinstance(values, str):
            try:
                values = [float(v) for v in values.replace(" ", "").split(",") if v]
            except ValueError:
                raise ValueError(f"theta* must be {len(self.feature_names)} numbers separated by commas") from None
        star = tuple(float(v) for v in values)
        if len(star) != len(self.feature_names):
            raise ValueError(f"theta* needs one weight per feature ({len(self.feature_names)}), got {len(star)}")
        for name, v, ref in zip(self.feature_names, star, self.theta_star, strict=True):
            if not np.isfinite(v) or np.sign(v) != np.sign(ref):
                raise ValueError(f"the weight of {name!r} must be {'negative' if ref < 0 else 'positive'}, got {v}")
        return star

    def split(self, env_id: int) -> tuple[int, int]:
        """Environment id -> (variant, the start's place in the variant's pool)."""
        env_id = int(env_id)
        if not 0 <= env_id < self.n_environments:
            raise ValueError(f"environment ids must lie in [0, {self.n_environments}); got {env_id}")
        variant = int(np.searchsorted(self._first_id, env_id, side="right")) - 1
        return variant, env_id - int(self._first_id[variant])

    def environment_id(self, variant: int, start: int = 0) -> int:
        """(variant, the start's place in its pool) -> environment id: split's inverse."""
        if not (0 <= variant < self.world.n_variants and 0 <= start < len(self.pools[variant])):
            raise ValueError(f"no start {start} in variant {variant}")
        return int(self._first_id[variant]) + start

    def environment(self, env_id: int) -> tuple[int, tuple]:
        """Environment id -> (variant, start state)."""
        variant, start = self.split(env_id)
        return variant, self.pools[variant][start]

    @cache  # noqa: B019  (one domain object per world, alive as long as the process)
    def front(self, env_id: int) -> tuple[np.ndarray, list]:
        """fileworld.fronts of environment `env_id`; ValueError if a trajectory needs more actions
        than the table holds."""
        phi, paths = fronts(self.world, *self.environment(env_id))
        lengths = [len(p) - 1 for p in paths]
        if max(lengths) > self.max_moves:
            own = lengths[int(np.argmax(phi @ self.theta_star))]
            raise WorldFileError(f"{self.world.source}: max_moves: environment {env_id} has a trajectory of "
                                 f"{max(lengths)} actions that some θ finds best (θ*'s own takes {own}); every "
                                 f"such trajectory is a candidate, so raise max_moves to at least {max(lengths)}")
        return phi, paths

    def environment_class(self, env_ids) -> np.ndarray:
        ids = np.asarray(env_ids, np.int64)
        return np.array([self._class_of(int(i)) for i in ids], np.int8).reshape(ids.shape)

    def stratified_sample(self, n: int, seed: int = 0) -> np.ndarray:
        """(n,) sorted int64 ids with a share for every class (shares differ by at most one).  A pool of
        every reachable state holds thousands of environments, and a class needs the environment's fronts,
        so there the classes are found lazily: environments in a seeded random order, each taken while its
        class's share is not full, until every share is; a class with fewer members than its share leaves
        its places to the others' next environments in that order, so a preset gets the environments it
        names (two-goal has no "other" environment).  A file of listed starts keeps the core's sample
        (teaching.core.base.stratified_sample: a short class's places stay empty), and so its tables."""
        if self.world.start_pool == "listed":
            return super().stratified_sample(n, seed=seed)
        n_classes = len(self.class_names)
        if not n_classes <= n <= self.n_environments:
            raise ValueError(f"sample size must lie in [{n_classes}, {self.n_environments}]")
        shares = np.diff(np.linspace(0, n, n_classes + 1).round().astype(int))
        taken, passed = {c: [] for c in range(n_classes)}, []
        for env_id in np.random.default_rng(seed).permutation(self.n_environments):
            c = self._class_of(int(env_id))
            (taken[c] if len(taken[c]) < shares[c] else passed).append(int(env_id))
            if all(len(taken[c]) == shares[c] for c in taken):
                break
        picks = [e for c in taken for e in taken[c]]
        return np.sort(np.array(picks + passed[:n - len(picks)], np.int64))

    def _class_of(self, env_id: int) -> int:
        phi, _ = self.front(env_id)
        for c, cls in enumerate(self.world.classes):
            if sum(bool(s.holds(phi).any()) for s in cls.strategies) >= 2:
                return c
        return len(self.world.classes)

    def strategy_labels(self, phi, env_class) -> np.ndarray:
        """phi (..., D) counts, env_class (...) -> (...) int8 cluster: the first strategy of the
        environment's class that the counts meet (C: none), "other" for the other class."""
        phi, cls = np.asarray(phi), np.asarray(env_class)
        S = len(self._strategies)  # clusters 0..S-1 the strategies, S "other", S + 1 none
        out = np.full(cls.shape, S + 1, np.int8)
        out[cls == len(self.world.classes)] = S
        for k in reversed(range(S)):  # reversed: the first strategy that holds is written last
            c, s = self._strategies[k]
            out[(cls == c) & s.holds(phi)] = k
        return out

    def encode(self, path) -> np.ndarray:
        """A trajectory [state, ...] -> (max_moves + 1,) int16 codes cell * 2 + holding, the last repeated."""
        codes = [(r * self.world.width + c) * 2 + (place == HELD) for (r, c), place in path]
        out = np.empty(self.max_moves + 1, np.int16)
        out[:len(codes)] = codes
        out[len(codes):] = codes[-1]
        return out

    def states(self, controls) -> np.ndarray:
        """Stored codes (..., max_moves + 1) -> states (..., max_moves + 1, 3) float64 [col, row, holding]."""
        codes = np.asarray(controls, np.int64)
        cell, holding = codes // 2, codes % 2
        return np.stack([cell % self.world.width, cell // self.world.width, holding], axis=-1).astype(np.float64)

    def score_shown(self, env_id: int, actions, tolerance: float = 1e-9) -> dict:
        """A trajectory a participant showed in environment `env_id` (action names, fileworld.ACTIONS)
        scored under θ*: its counts, reward, the optimum's reward, regret = optimum - reward (≥ 0, in
        θ*'s units), regret_normalised (the same with θ* scaled to an L1 norm of 1, the units Lee, Admoni &
        Simmons report in), optimal (regret ≤ tolerance) and its rows as path_rows gives a table's trajectory
        (to find it among the table's).  ValueError (one line) for actions the world
        does not allow (fileworld.play) or more of them than :attr:`max_actions`, whoever calls."""
        actions = list(actions)
        if len(actions) > self.max_actions:
            raise ReplayError(_("this way has {count} actions, and at most {limit} can be shown"),
                              count=len(actions), limit=self.max_actions)
        path = []
        counts, ending = play(self.world, *self.environment(env_id), actions, states=path)
        phi = self.front(env_id)[0]
        best = float(np.max(phi @ self.theta_star))
        got = float(counts @ self.theta_star)
        return {"counts": counts.tolist(), "ending": ending if ending == EXIT else self.feature_names[ending],
                "reward": got, "optimum": best, "regret": best - got,
                "regret_normalised": (best - got) / float(np.abs(self.theta_star).sum()),
                "optimal": best - got <= tolerance,
                "rows": [[c, r, int(place == HELD)] for (r, c), place in path]}

    @property
    def max_actions(self) -> int:
        """The most actions a shown way may have: four times the table's longest trajectory, room for every
        detour a participant might try, and a bound on what one answer makes the server replay."""
        return 4 * self.max_moves

    def show_rules(self, env_id: int) -> dict:
        """What a "show the way" page needs to offer exactly the actions fileworld.successors allows:
        blocked (H, W) cells the robot cannot enter, whether dropping the object on its destination ends
        the episode (deliver), whether exit is allowed anywhere, at most how many actions a shown way may
        have (four times the table's longest) and the object's name."""
        variant, _ = self.split(env_id)
        return {"blocked": self.world.blocked(variant).tolist(),
                "deliver": any(f.counts == "deliver" for f in self.world.features),
                "exit": bool(self.world.exit), "max_actions": self.max_actions,
                "object": self.world.obj or ""}

    # --- the page ---------------------------------------------------------------------------
    def scene_payload(self, env_id) -> dict:
        """The variant's cells (kind names, "" free), the start, the object and the goals, in (x, y)
        screen cells: x the column, y the row from the top."""
        variant, ((r, c), place) = self.environment(env_id)
        w = self.world
        return {"dt": SECONDS_PER_ACTION, "env_id": int(env_id), "variant": variant,
                "world": {"cells": w.cells(variant).tolist(), "start": [c, r],
                          "labels": {k: v.label for k, v in w.kinds.items()},
                          "object": None if place is None else (HELD if place == HELD else [place[1], place[0]]),
                          "destination": None if w.destination is None else [w.destination[1], w.destination[0]],
                          "goals": [[f.at[1], f.at[0]] for f in w.features if f.counts == "reach"],
                          "exit": bool(w.exit)}}

    def render_sheet(self, **kwargs) -> int:
        from .filesheet import render_sheet  # noqa: PLC0415  (matplotlib loads only for a sheet)

        return render_sheet(self, **kwargs)

    def path_rows(self, states) -> list[list[int]]:
        """(max_moves + 1, 3) states -> [[col, row, holding]] up to the episode's end."""
        rows = np.asarray(states, np.int64)
        moving = np.flatnonzero(np.any(rows != rows[-1], axis=1))
        end = int(moving[-1]) + 2 if len(moving) else 1
        return rows[:end].tolist()


# The defaults that name the world: marked for the catalog with the title as a placeholder, filled in after
# the web side has looked the text up (a file's own texts, written in its language, are not in the catalog).
SUMMARY = _("you watch a robot act in a small grid world ({title}) and answer questions about what it prefers")
CONSENT = _("This is a research study about how people understand what a robot in a grid world ({title}) "
            "prefers. Taking part is voluntary.")
DESTINATION = _("destination of the {object}")
WATCH_FIRST = _("Examples of a robot moving in a small grid world ({title})")
# A translation may leave out the English plural endings ({training_plural}, {tests_plural}), which the format
# check of the catalog would refuse:
# xgettext:no-python-brace-format
INSTRUCTIONS = _("You will watch {n_training} example{training_plural} of a robot in a small grid world, then "
                 "answer {n_tests} question{tests_plural} about what it would do.")


def _texts(world: World) -> ParticipantTexts:
    """The file's [texts], with plain defaults for what it leaves out (its comprehension questions replace
    the default ones whole)."""
    t = world.texts
    return ParticipantTexts(
        summary=t.get("summary", SUMMARY.format(title=world.title)),
        consent=t.get("consent", CONSENT.format(title=world.title)),
        instructions=tuple(t.get("instructions", (INSTRUCTIONS,))),
        attention_question=t.get("attention_question", _("What did you watch?")),
        attention_choices=(("robot", _("A robot moving on a grid")), ("car", _("A car on a highway"))),
        attention_correct=frozenset({"robot"}),
        watch=t.get("watch", _("Watch what the robot does.")),
        question=t.get("question", _("Which of these matches the robot's preferences?")),
        legend=(LegendEntry("the robot", "robot", "robot-edge"), LegendEntry("wall", "wall", "wall"),
                *((LegendEntry(world.obj, "object", "object"),) if world.obj else ()),
                *(LegendEntry(k.label, f"cell-{k.name}", f"cell-{k.name}") for k in world.kinds.values()),
                *_letters(world)),
        title=t.get("title", world.title),
        comprehension=tuple(ComprehensionQuestion(q, choices, right) for q, choices, right in t["comprehension"])
        if "comprehension" in t else _comprehension(world))


def _letters(world: World) -> tuple[LegendEntry, ...]:
    """The letters the page's canvas writes on cells (static/studyapp/scenes/world.js drawMarks)."""
    out = [LegendEntry(_("where the robot starts"), "free", "free", letter="S")]
    if any(f.counts == "reach" for f in world.features):
        out.append(LegendEntry(_("a goal: reaching it ends the way"), "free", "free", letter="G"))
    if world.destination is not None:
        out.append(LegendEntry(DESTINATION.format(object=world.obj or _("object")), "free", "free", letter="D"))
    return tuple(out)


def _comprehension(world: World) -> tuple[ComprehensionQuestion, ...]:
    """The comprehension check's default questions: what every grid world's instructions say (examples of a
    robot on a grid first, then questions about new situations), with the world's own title."""
    return (
        ComprehensionQuestion(_("What will you watch first?"),
                              (_("A car on a highway"), WATCH_FIRST.format(title=world.title),
                               _("A video about the researchers")), (1,)),
        ComprehensionQuestion(_("What are the questions after the examples about?"),
                              (_("What the robot would do in new situations"),
                               _("Where the walls of the grid should be"), _("How many moves you can remember")),
                              (0,)),
    )


def world_domain(path) -> FileGridDomain:
    """The domain of the world file at `path` (WorldFileError, one line, for a file with a mistake)."""
    return FileGridDomain(load_world(Path(path)))


__all__ = ["FileGridDomain", "world_domain"]
