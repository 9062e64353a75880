"""What a study page shows of the highway: its scene payload, palette and participant texts.

The browser draws a scene with static/studyapp/scenes/driving.js from :func:`scene_payload` (the
goal, the other car's positions, the world's sizes) and :func:`path_rows` (the robot car's
states).  Units: ft and s; x across the road (right positive), y along it (forward).
"""
from __future__ import annotations

import numpy as np

from ...core.domain import ComprehensionQuestion, LegendEntry, ParticipantTexts
from ...core.i18n import gettext_noop as _
from .environments import get_environments, other_car_states
from .world import GOAL_NAMES, WORLD

DECIMALS = 3  # payload rows are rounded to a thousandth of a foot (or radian, ft/s)

# The one palette: the page's CSS custom properties (--scene-<name>), the canvas and the contact sheet.
# Not colour alone (legible in greyscale): the goal lane is dark and hatched against a light road, the autonomous
# car light with a black outline, the other car dark with a white outline.
PALETTE = {
    "grass": "#dfe9d8", "road": "#959ca4", "line": "#f4f4f4", "goal": "#1e3a8a",
    "goal-hatch": "rgba(255, 255, 255, 0.38)", "goal-edge": "#ffffff", "outline": "#1f2328",
    "robot": "#f5c518", "robot-edge": "#111111", "other": "#2b2f36", "other-edge": "#ffffff", "path": "#ff7a1a",
}

# What a participant's page may carry of a payload (besides the robot's path on a training page):
# the goal it highlights, the time step, the other car's path and the world's sizes.
PAGE_KEYS = ("goal", "dt", "other", "world")

TEXTS = ParticipantTexts(
    summary=_("you watch short animations of an autonomous car on a three-lane road and answer questions about "
              "its driving style"),
    consent=(
        _("This is a research study about how people understand the driving style of an autonomous car. "
          "You will watch short animations of a yellow car driving on a three-lane road and then answer "
          "questions about how it would drive in new situations.\n\n"
          "We record your answers, the time you spend, your age and gender, and the identifier of the "
          "recruiting platform (if any). The data are stored under a pseudonym and used only for research. "
          "Taking part is voluntary; you may stop at any time by closing this page.")),
    instructions=(
        _("You will see a road with three lanes from above. The yellow car (black outline) is an autonomous car; "
          "the dark gray car (white outline) is another driver who stays in its lane."),
        _("In every situation the autonomous car has one of two goals, shown as a blue striped lane marked "
          "\"goal\": either to merge into the right lane or to drive forward."),
        # A translation may leave out the English plural endings ({training_plural}, {tests_plural}), which the
        # format check of the catalog would refuse:
        # xgettext:no-python-brace-format
        _("First you will watch {n_training} example{training_plural} of how the car drives. Watch closely: the "
          "car has its own driving style (how much it keeps its distance, accelerates, changes speed or steers). "
          "Each example can be replayed, and \"Show trail\" shows the whole drive at once (later positions "
          "darker)."),
        _("Then, in {n_tests} new situations, you will see four possible drives. Pick the one that matches the "
          "car's driving style, and rate how well each of the four matches it (1 = not at all, 7 = exactly).")),
    attention_question=_("In the situations you saw, what were the two possible goals of the autonomous car?"),
    attention_choices=(("merge", _("Merge into the right lane")), ("forward", _("Drive forward")),
                       ("park", _("Park on the shoulder")), ("left", _("Turn into the left lane and stop")),
                       ("exit", _("Take the next exit")), ("overtake", _("Overtake every car it meets"))),
    attention_correct=frozenset({"merge", "forward"}),
    watch=_("Watch how the yellow car drives."),
    question=_("Which drive matches the autonomous car's driving style?"),
    option=_("drive"),
    choice_required=_("Please choose the option that matches the car's driving style."),
    title=_("How does the autonomous car drive?"),
    legend=(LegendEntry(_("autonomous car"), "robot", "robot-edge"),
            LegendEntry(_("other car"), "other", "other-edge"),
            LegendEntry(_("goal lane"), "goal", "goal", hatch="goal-hatch")),
    comprehension=(
        ComprehensionQuestion(_("Which car is the autonomous car?"),
                              (_("The dark gray car with a white outline"), _("The yellow car with a black outline"),
                               _("Either car: they take turns")), (1,)),
        ComprehensionQuestion(_("How is the autonomous car's goal in a situation shown?"),
                              (_("As a blue striped lane marked \"goal\""), _("As a red flag at the end of the road"),
                               _("It is not shown: you have to guess it")), (0,)),
        ComprehensionQuestion(_("What will you do in the new situations after the examples?"),
                              (_("Steer the car yourself"),
                               _("Pick the fastest of four drives"),
                               _("Pick the drive that matches the car's driving style, and rate all four")), (2,)),
    ),
)


def _rows(array) -> list:
    return np.round(np.asarray(array, dtype=float), DECIMALS).tolist()


def scene_sizes() -> dict:
    """The world's sizes a scene is drawn with (ft): lane width and centres (left to right), the
    road's half-width, the cars' length and width.  Taken from ``WORLD``, their one source."""
    return {"lane_width": float(WORLD.lane_width), "lane_centres": [float(x) for x in WORLD.lane_centres],
            "road_half_width": float(WORLD.road_half_width), "car_length": float(WORLD.car_length),
            "car_width": float(WORLD.car_width)}


def scene_payload(env_id: int) -> dict:
    """{"goal": 0 merge / 1 forward, "goal_name", "other_lane", "dt": s per row, "other": [[x, y]] * (T+1),
    "world": scene_sizes()} of environment `env_id`."""
    env = get_environments([int(env_id)])
    goal = int(env.goal[0])
    return {"goal": goal, "goal_name": GOAL_NAMES[goal], "other_lane": int(env.other_lane[0]), "dt": WORLD.dt,
            "other": _rows(other_car_states(env)[0]), "world": scene_sizes()}


def path_rows(states: np.ndarray) -> list:
    """(T+1, 5) states [x, y, heading, v, steer] -> the same rows, rounded."""
    return _rows(states)


def page_scene(payload: dict) -> dict:
    """A stored payload's :data:`PAGE_KEYS`; one stored before payloads carried ``world`` gets today's."""
    scene = {k: payload[k] for k in PAGE_KEYS if k != "world"}
    scene["world"] = payload.get("world") or scene_sizes()
    return scene


# The goals as a caption names them (world.GOAL_NAMES, stored in every payload), marked for the catalog: the
# web side translates a caption's parts by looking them up there.
CAPTION_GOALS = (_("merge right"), _("drive forward"))


def caption(payload: dict) -> tuple[str, str]:
    return (_("Goal in this situation"), payload["goal_name"])


# scenes/driving.js's INTERACTION_FT: the other car within this distance along the road is framed with the robot
INTERACTION_FT = 150.0


def framed_span(robot, other) -> float:
    """scenes/driving.js's framedSpan: the along-road gap (ft) a view must hold between the two cars (the
    largest while within INTERACTION_FT; 0 where they never come that close: the canvas then marks the
    other car at its edge with its distance)."""
    gaps = [abs(other[min(k, len(other) - 1)][1] - r[1]) for k, r in enumerate(robot)]
    return max((g for g in gaps if g <= INTERACTION_FT), default=0.0)


def study_view(scenes) -> dict:
    """{"study_span": ft}: the largest framed span of any canvas of a study, so every canvas is drawn at
    the one scale that holds it and the same speeds and gaps look the same in training and at test."""
    spans = [framed_span(robot, scene["other"]) for scene, robot in scenes]
    return {"study_span": round(max(spans, default=0.0), 1)}
