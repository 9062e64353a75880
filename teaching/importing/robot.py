"""An imported robot: the :class:`~teaching.core.domain.Domain` a table made by ``import-table`` carries with it.

A lab's robot has no planner here: its table was planned in the lab's own stack and imported from a folder
(docs/importing.md).  What the core needs besides the table's arrays - the features' names and scales, the
classes and strategies, θ*, the distance between two trajectories, the participants' texts and the scene - is
written beside the arrays, in ``<table>/robot/robot.json``, and this class reads it back.  Its fingerprint is
the hash of everything in ``robot/``, so a table whose robot was edited is refused as a table built under other
world constants is.

A table's trajectory, stored in its ``controls`` array, is what the distance compares:

* with recorded paths, the robot's poses (L, P) on the folder's clock; the distance is the padded distance of
  teaching.core.pathdistance with the folder's column scales;
* without them, the trajectory's features (D,), seen as a one-step path from the origin: two trajectories are
  as far apart as their features (in θ's units), the only description the folder gives of them.
"""
from __future__ import annotations

import hashlib
import json
import re
from functools import cached_property
from pathlib import Path

import numpy as np

from ..core.base import BaseDomain, stratified_sample
from ..core.domain import LegendEntry, ParticipantTexts
from ..core.i18n import gettext_noop as _
from ..core.pathdistance import padded_distance

ROBOT = "robot"  # the folder of a table that holds its robot
DESCRIPTION = "robot.json"
AGENTS = "agents.npy"
OBSTACLES = "obstacles.npy"
MEDIA = "media"  # the videos, each under its SHA-256 (a name that says nothing of an environment or objective)
VIDEOS = "videos.npy"  # (M, N) int32: the position in robot.json's "videos" of each trajectory's video
FORMAT = 1

SUMMARY = _("you watch a robot ({title}) act in a few situations and answer questions about what it prefers")
CONSENT = _("This is a research study about how people understand what a robot ({title}) prefers. Taking part "
            "is voluntary.")
# xgettext:no-python-brace-format
INSTRUCTIONS = _("You will watch {n_training} example{training_plural} of what a robot does, then answer "
                 "{n_tests} question{tests_plural} about what it would do in new situations.")
PALETTE = {"ground": "#f5f3ee", "grid": "#dedad0", "obstacle": "#5b5750", "robot": "#1f5fa8", "path": "#6f9fd6",
           "agent": "#b03a2e", "agent-path": "#e6a39b", "text": "#222222"}


class ImportedRobotError(ValueError):
    """An imported table's robot that cannot be used (one line: its file and what is wrong)."""


class ImportedDomain(BaseDomain):
    """The robot of the imported table at `table_dir` (its ``robot/robot.json``)."""

    code_root = Path(__file__).resolve().parent
    trajectory_dtype = np.dtype(np.float64)
    presets = ()  # imported, never built here
    palette = PALETTE

    def __init__(self, table_dir):
        self.table_dir = Path(table_dir)
        self.robot_dir = self.table_dir / ROBOT
        path = self.robot_dir / DESCRIPTION
        try:
            self.spec = json.loads(path.read_text(encoding="utf-8"))
        except FileNotFoundError:
            raise ImportedRobotError(f"{path}: missing: not a table made by import-table") from None
        except (OSError, ValueError) as exc:
            raise ImportedRobotError(f"{path}: unreadable ({exc})") from None
        if self.spec.get("format") != FORMAT:
            raise ImportedRobotError(f"{path}: format {self.spec.get('format')!r}, this version reads {FORMAT}: "
                                     "import the folder again")
        try:
            self._read(self.spec)
        except (KeyError, TypeError, ValueError, IndexError, OSError) as exc:
            raise ImportedRobotError(f"{path}: damaged ({type(exc).__name__}: {exc}): import the folder again") \
                from None

    def _read(self, s: dict) -> None:
        self.name = s["name"]
        self.title = s["title"]
        self.feature_names = tuple(f["name"] for f in s["features"])
        self.class_names = tuple(s["classes"])
        clusters = s["strategies"]
        self.cluster_names = (*(c["name"] for c in clusters), _("none of these"))
        self.class_of_cluster = np.array([c["class"] for c in clusters], np.int64)
        self.test_clusters = tuple(i for i, c in enumerate(clusters) if c["tested"])
        self.theta_star = np.array(s["theta_star"], np.float64)
        self.min_option_distance = float(s["min_option_distance"])
        self.env_ids = np.array(s["env_ids"], np.int64)
        self.n_environments = int(self.env_ids.max()) + 1
        self._class_of = dict(zip(self.env_ids.tolist(), s["env_class"], strict=True))
        self.paths = s.get("paths")
        if self.paths:
            self.trajectory_shape = (len(self.paths["t"]), len(self.paths["columns"]))
            self.state_scale = tuple(float(v) for v in self.paths["scale"])
        else:
            self.trajectory_shape = (len(self.feature_names),)
            self.state_scale = (1.0,) * len(self.feature_names)
        self.vocabulary = frozenset(w for w in re.split("[^a-z]+", self.name) if w)
        self.videos = tuple(s["videos"] or ())  # every video's file name in media/
        self.video_seconds = tuple(float(v) for v in s.get("video_seconds") or (0.0,) * len(self.videos))
        # (M, N) into self.videos, mapped: a page reads one entry, a site need not hold them all
        self.video_of = np.load(self.robot_dir / VIDEOS, mmap_mode="r") if self.videos else None
        if self.video_of is not None and (self.video_of.ndim != 2 or len(self.video_of) != len(self.env_ids)
                                          or self.video_of.min() < 0 or self.video_of.max() >= len(self.videos)):
            raise ValueError(f"{VIDEOS} does not index the {len(self.videos)} videos of {len(self.env_ids)} "
                             "environments")
        self.texts = _texts(s, drawn=not self.videos, agents=(self.robot_dir / AGENTS).exists(),
                            obstacles=(self.robot_dir / OBSTACLES).exists())

    # --- world -------------------------------------------------------------------------------------------------
    def parse_theta_star(self, values) -> tuple[float, ...]:
        """θ* as D finite numbers (an imported robot's weights may have either sign)."""
        if isinstance(values, str):
            try:
                values = [float(v) for v in values.replace(" ", "").split(",") if v]
            except ValueError:
                raise ValueError(f"theta* must be {len(self.feature_names)} numbers separated by commas, "
                                 f"got {values!r}") from None
        star = tuple(float(v) for v in values)
        if len(star) != len(self.feature_names) or not all(np.isfinite(star)):
            raise ValueError(f"theta* needs {len(self.feature_names)} finite weights, one per feature, "
                             f"got {list(star)}")
        return star

    def environment_class(self, env_ids) -> np.ndarray:
        ids = np.asarray(env_ids, np.int64)
        try:
            return np.array([self._class_of[int(e)] for e in ids.reshape(-1)], np.int8).reshape(ids.shape)
        except KeyError as exc:
            raise ValueError(f"environment {exc.args[0]} is not one of the imported robot {self.name!r}'s") from None

    @cached_property
    def all_classes(self) -> np.ndarray:
        return self.environment_class(self.env_ids)

    def stratified_sample(self, n: int, seed: int = 0) -> np.ndarray:
        return np.sort(self.env_ids[stratified_sample(self.all_classes, len(self.class_names), n, seed=seed)])

    # --- planner: the table's, imported -----------------------------------------------------------------------
    def fingerprint(self) -> str:
        """16 hex digits over every file of the table's robot/ folder (robot.json, the agents' paths, the
        videos), read once."""
        return self._fingerprint

    @cached_property
    def _fingerprint(self) -> str:
        return _folder_hash(self.robot_dir)[:16]

    def default_normalisers(self) -> np.ndarray:
        return np.array([f["scale"] for f in self.spec["features"]], np.float64)

    def planner_identity(self) -> dict:
        return {"imported": self.name, "robot": self.fingerprint()}

    def plan_chunk(self, env_ids, thetas, normalisers) -> dict:
        raise ValueError(f"{self.name!r} is an imported robot: its planner is its lab's own, so its table is imported "
                         "(python -m teaching import-table), never built here")

    def states(self, controls) -> np.ndarray:
        """Stored trajectories -> states: the poses (..., L, P) as they are, or features (..., D) as the one-step
        path (..., 2, D) from the origin to them."""
        c = np.asarray(controls, np.float64)
        if self.paths:
            return c
        return np.stack([np.zeros_like(c), c], axis=-2)

    def euclidean_distance(self, states_a, states_b) -> np.ndarray:
        return padded_distance(states_a, states_b, self.state_scale)

    # --- pages ----------------------------------------------------------------------------------------------------
    # A table with videos shows them (the lab's own recording of what its robot did); one with recorded paths
    # alone is drawn from above by the generic top-down scene.
    @property
    def scene(self) -> str:
        return "video" if self.videos else "topdown"

    @property
    def page_keys(self) -> tuple[str, ...]:
        return () if self.videos else ("bounds", "agents", "obstacles", "dt", "unit")

    @cached_property
    def _agents(self) -> np.ndarray | None:
        path = self.robot_dir / AGENTS
        return np.load(path, mmap_mode="r") if path.exists() else None

    @cached_property
    def _obstacles(self) -> np.ndarray | None:
        path = self.robot_dir / OBSTACLES
        return np.load(path, mmap_mode="r") if path.exists() else None

    def scene_payload(self, env_id: int) -> dict:
        """The environment's view: the table's one view, else the bounds of everything in the environment (every
        objective's path, the agents' and the obstacles, so all of its options share one view); the agents'
        paths, the obstacles [x0, y0, x1, y1] and the clock's step.  Nothing for a robot shown by its videos: a
        video holds its whole scene."""
        if self.videos:
            return {}
        if not self.paths:
            raise ValueError(f"the imported robot {self.name!r} has neither videos nor recorded paths to show "
                             "participants: import its folder with a stimuli manifest or paths.npz "
                             "(docs/importing.md, \"Videos\" and \"Recorded paths\")")
        row = self._row_of[int(env_id)]
        agents = [] if self._agents is None else np.round(np.asarray(self._agents[row]), 3).tolist()
        obstacles = [] if self._obstacles is None else np.round(np.asarray(self._obstacles[row]), 3).tolist()
        t = self.paths["t"]
        return {"bounds": [float(v) for v in self.paths["bounds"][row]], "agents": agents, "obstacles": obstacles,
                "dt": float(t[-1]) / (len(t) - 1), "unit": self.paths["unit"]}

    @cached_property
    def _row_of(self) -> dict[int, int]:
        return {int(e): i for i, e in enumerate(self.env_ids)}

    def path_rows(self, states) -> list:
        """One trajectory's poses (L, P) -> [[x, y], ...] every step of the clock."""
        return np.round(np.asarray(states, np.float64)[:, :2], 3).tolist()

    def stimulus(self, env_id: int, theta_index: int, states):
        """The video of objective `theta_index` in environment `env_id` as {"video": its SHA-256 file name,
        "seconds": its length}, or the path's rows for a robot drawn from its recorded paths."""
        if not self.videos:
            return self.path_rows(states)
        row = self._row_of.get(int(env_id))
        if row is None or not 0 <= int(theta_index) < self.video_of.shape[1]:
            raise ValueError(f"the imported robot {self.name!r} has no video of objective {theta_index} in "
                             f"environment {env_id}")
        k = int(self.video_of[row, int(theta_index)])
        return {"video": self.videos[k], "seconds": self.video_seconds[k]}

    def media_file(self, name: str) -> Path | None:
        """media/<name> for one of this robot's videos; None for any other name (so a request names no file
        outside media/)."""
        return self.robot_dir / MEDIA / name if name in self._video_names else None

    @cached_property
    def _video_names(self) -> frozenset[str]:
        return frozenset(self.videos)

    def render_sheet(self, **kwargs) -> int:
        if not (self.paths or self.videos):
            raise ValueError(f"{self.name!r} has neither videos nor recorded paths to draw: its table was imported "
                             "from features alone (docs/importing.md, \"Videos\" and \"Recorded paths\")")
        from .sheet import render_sheet  # noqa: PLC0415  (matplotlib loads only for a sheet)

        return render_sheet(domain=self, **kwargs)


def _texts(spec: dict, *, drawn: bool, agents: bool, obstacles: bool) -> ParticipantTexts:
    """The folder's [texts], plain defaults for the rest, and a legend of what its scenes draw (none for
    videos: what a video shows is the lab's, its texts say it)."""
    t, title = spec.get("texts", {}), spec["title"]
    return ParticipantTexts(
        summary=t.get("summary", SUMMARY.format(title=title)),
        consent=CONSENT.format(title=title),
        instructions=tuple(t.get("instructions", (INSTRUCTIONS,))),
        attention_question=_("What did you watch?"),
        attention_choices=(("robot", _("A robot")), ("recipe", _("A cooking recipe"))),
        attention_correct=frozenset({"robot"}),
        watch=t.get("watch", _("Watch what the robot does.")),
        question=t.get("question", _("Which of these matches the robot's preferences?")),
        legend=() if not drawn else (
            LegendEntry(_("the robot"), "ground", "robot"), LegendEntry(_("the robot's path"), "path", "path"),
            *((LegendEntry(_("another person or robot"), "agent", "agent"),) if agents else ()),
            *((LegendEntry(_("a wall or obstacle"), "obstacle", "obstacle"),) if obstacles else ())),
        option=t.get("option", _("option")),
        title=title)


def _folder_hash(folder: Path) -> str:
    """sha256 over every file under `folder` (its relative path and bytes), in a fixed order."""
    h = hashlib.sha256()
    for path in sorted(p for p in folder.rglob("*") if p.is_file()):
        h.update(path.relative_to(folder).as_posix().encode() + b"\0")
        with path.open("rb") as f:
            for block in iter(lambda: f.read(1 << 20), b""):
                h.update(block)
        h.update(b"\0")
    return h.hexdigest()
