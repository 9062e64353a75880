"""What a study page shows of the delivery yard: its scene payload, palette and participant texts.

The browser draws a yard with static/studyapp/scenes/gridworld.js from :func:`scene_payload`
(the yard's cells) and the domain's ``path_rows`` (the robot's cells, one row per move).  Units: cells;
x is the column (left to right), y the row (top to bottom), as the domain's ``states`` gives them.
"""
from __future__ import annotations

from ...core.domain import ComprehensionQuestion, LegendEntry, ParticipantTexts
from ...core.i18n import gettext_noop as _
from .environments import get_yard

SECONDS_PER_MOVE = 0.4  # the animation's pace: a 12-move delivery plays in 4.8 s

# The one palette: the page's CSS custom properties (--scene-<name>), the canvas and the contact sheet.
# Greyscale-safe: mud is dark and dotted, the cells next to the dog light and hatched, the robot light
# with a dark outline, so no two kinds rely on hue alone.
PALETTE = {
    "free": "#f4f1e8", "grid": "#c8c2b4", "wall": "#2f3338", "mud": "#8b5a2b", "mud-mark": "#d9b38c",
    "near": "#f3c4c4", "near-mark": "#c62828", "dog": "#c62828", "cart": "#1d4ed8",
    "robot": "#f5c518", "robot-edge": "#111111", "path": "#ff7a1a", "text": "#111111",
}

# What a participant's page may carry of a payload (besides the robot's path on a training page):
# the yard and the pace; never the environment's id, class or strategy cluster.
PAGE_KEYS = ("dt", "yard")

TEXTS = ParticipantTexts(
    summary=_("you watch short animations of a delivery robot carrying parcels across a small yard and answer "
              "questions about what it prefers"),
    consent=(
        _("This is a research study about how people understand what a delivery robot cares about. "
          "You will watch short animations of a robot carrying a parcel across a small yard and then answer "
          "questions about how it would deliver in new yards.\n\n"
          "We record your answers, the time you spend, your age and gender, and the identifier of the "
          "recruiting platform (if any). The data are stored under a pseudonym and used only for research. "
          "Taking part is voluntary; you may stop at any time by closing this page.")),
    instructions=(
        _("You will see a small yard from above, divided into square cells. A delivery robot (the yellow "
          "circle) carries a parcel from its start S on the left edge to the drop-off D on the right edge, "
          "one cell at a time. Dark cells are walls."),
        _("Some yards have mud (brown, dotted), a dog (the red disc; the cells next to it are hatched red) or a "
          "cart (the blue square): the robot may pick the cart up by moving into its cell and push the parcel "
          "on it from then on."),
        # A translation may leave out the English plural endings ({training_plural}, {tests_plural}), which the
        # format check of the catalog would refuse:
        # xgettext:no-python-brace-format
        _("First you will watch {n_training} example{training_plural} of how the robot delivers. Watch closely: "
          "the robot has its own preferences (how much it minds long paths, mud, the dog, and whether it thinks "
          "fetching the cart is worth a detour). Each example can be replayed, and \"Show trail\" shows the "
          "whole path at once."),
        _("Then, in {n_tests} new yards, you will see four possible deliveries. Pick the one that matches the "
          "robot's preferences, and rate how well each of the four matches them (1 = not at all, 7 = exactly).")),
    attention_question=_("In the yards you saw, what did the robot do every time?"),
    attention_choices=(("deliver", _("Carried a parcel to the drop-off D")),
                       ("charge", _("Drove to a charging station")),
                       ("collect", _("Collected parcels from the dog")),
                       ("clean", _("Cleaned up the mud"))),
    attention_correct=frozenset({"deliver"}),
    watch=_("Watch how the robot carries the parcel from S to D."),
    question=_("Which delivery matches the robot's preferences?"),
    option=_("delivery"),
    choice_required=_("Please choose the delivery that matches the robot's preferences."),
    title=_("How does the delivery robot deliver?"),
    legend=(LegendEntry(_("the robot"), "robot", "robot-edge"), LegendEntry(_("mud"), "mud", "mud-mark"),
            LegendEntry(_("next to the dog"), "near", "near-mark"), LegendEntry(_("cart"), "cart", "cart"),
            LegendEntry(_("wall"), "wall", "wall")),
    comprehension=(
        ComprehensionQuestion(_("Where does the robot carry the parcel?"),
                              (_("From the drop-off D back to its start S"),
                               _("From its start S on the left edge to the drop-off D on the right edge"),
                               _("Around the yard and back to S")), (1,)),
        ComprehensionQuestion(_("What can the robot do with the cart (the blue square)?"),
                              (_("Pick it up by moving into its cell, and push the parcel on it from then on"),
                               _("Nothing: the cart is a wall"), _("Leave the parcel in it for the dog")), (0,)),
        ComprehensionQuestion(_("What will you do in the new yards after the examples?"),
                              (_("Move the robot yourself"), _("Pick the shortest of four deliveries"),
                               _("Pick the delivery that matches the robot's preferences, and rate all four")), (2,)),
    ),
)


def scene_payload(env_id: int) -> dict:
    """The yard of environment `env_id`: {"dt": s per move, "yard": {"cells": (H, W) codes (0 free,
    1 wall, 2 mud, 3 dog, 4 cart), "near_dog": (H, W) 0/1, "start": [col, row], "goal": [col, row]}}."""
    yard = get_yard(env_id)
    return {"dt": SECONDS_PER_MOVE,
            "yard": {"cells": yard.cells.astype(int).tolist(), "near_dog": yard.near_dog().astype(int).tolist(),
                     "start": [yard.start[1], yard.start[0]], "goal": [yard.goal[1], yard.goal[0]]}}
