"""The robot's examples: a training example, and in a closed loop the feedback after a check question
(θ*'s trajectory there), each watched to its end."""
from __future__ import annotations

from django.utils.translation import gettext

from ...models import LoopStep, StepKind
from ...trajectories import drawn_scene, study_domain
from ..forms import TrainingForm
from .base import Page, add


def caption_of(domain, payload: dict) -> tuple[str, str] | None:
    """The domain's caption above a canvas (what to look for, and its value there), in the participant's
    language: both parts are English texts the domain marks for the catalog."""
    caption = domain.caption(payload)
    return tuple(gettext(part) for part in caption) if caption else caption


def repeated_example(training: list[dict], item: int) -> int | None:
    """The number (1-based) of the last earlier example showing the same environment as example `item`,
    or None.  A sequence may repeat an environment on purpose (prob-reward shows two environments ten
    times); without a word on the page a repeat looks like a glitch.  Only the number reaches the page."""
    env_id = training[item].get("env_id")
    earlier = [i for i in range(item) if env_id is not None and training[i].get("env_id") == env_id]
    return earlier[-1] + 1 if earlier else None


class TrainingPage(Page):
    """One example: θ*'s trajectory in one environment, played to its end before the participant goes on.
    A closed loop's examples are decided as the participant goes (studyapp.participant.closedloop), not listed here."""

    kind, form, draws_robot = StepKind.TRAINING, TrainingForm, True

    def items(self, participant):
        return range(len(participant.condition.training))

    def context(self, participant, step, ctx):
        # The page gets what it draws and nothing else (drawn_scene): no theta, cluster or option
        # index, and no reference trajectory, so its source cannot tell theta*'s option apart.
        domain = study_domain(participant.study)
        if participant.condition.closed_loop:
            training = [s.payload for s in participant.loop_steps.filter(index__lte=step.item, kind=LoopStep.EXAMPLE)]
            payload, item = participant.loop_steps.get(index=step.item).payload, len(training) - 1
        else:
            training, item = participant.condition.training, step.item
            payload = training[item]
        out = {"caption": caption_of(domain, payload), "env": drawn_scene(payload, robot=True, domain=domain),
               "number": item + 1}
        if self.kind == StepKind.TRAINING:
            out["seen_before"] = repeated_example(training, item)
        return out

    def simulate(self, sim, participant, step):
        return {"played": "1"}


class FeedbackPage(TrainingPage):
    """After a closed loop's check question: what really happens there, watched as an example is."""

    kind = StepKind.FEEDBACK


TRAINING, FEEDBACK = add(TrainingPage()), add(FeedbackPage())
