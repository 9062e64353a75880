"""The pages after the tests: the attention check, the demographics and the completion page."""
from __future__ import annotations

from ...i18n import participant_texts
from ...models import StepKind
from ...trajectories import study_domain
from .. import bonuses
from ..forms import AGE_MAX, AGE_MIN, GENDER_CHOICES, AttentionForm, DemographicsForm
from ..platforms import completion_target
from .base import Page, add


class AttentionPage(Page):
    """The domain's attention question (Domain.texts): a participant who fails it is excluded from the
    analysis, and still paid."""

    kind, form = StepKind.ATTENTION, AttentionForm

    def context(self, participant, step, ctx):
        texts = participant_texts(study_domain(participant.study))
        return {"question": texts.attention_question, "choices": texts.attention_choices}

    def stored(self, locked, data):
        locked.excluded = not data["passed"]

    def simulate(self, sim, participant, step):
        """Exactly the right answers; a careless participant ticks one more."""
        texts = study_domain(participant.study).texts
        right = sorted(texts.attention_correct)
        wrong = right + [next(v for v, _ in texts.attention_choices if v not in texts.attention_correct)]
        return {"goals": right if sim.attentive else wrong}


class DemographicsPage(Page):
    kind, form = StepKind.DEMOGRAPHICS, DemographicsForm

    def context(self, participant, step, ctx):
        return {"genders": [(key, str(label)) for key, label in GENDER_CHOICES], "age_min": AGE_MIN,
                "age_max": AGE_MAX}

    def simulate(self, sim, participant, step):
        return {"age": int(sim.rng.integers(20, 60)), "gender": "female"}


class DonePage(Page):
    """Thanks, the completion code and where it goes (the platform's address or form), and the bonus."""

    kind = StepKind.DONE

    def context(self, participant, step, ctx):
        out = completion_target(participant)
        if participant.bonus is not None and bonuses.offers_bonus(participant.study) and not participant.excluded:
            out["bonus"] = bonuses.participant_label(participant.study, participant.bonus)
        return out


ATTENTION, DEMOGRAPHICS, DONE = add(AttentionPage()), add(DemographicsPage()), add(DonePage())
