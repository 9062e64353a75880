"""The questions about new situations: a test (which option is the robot's?), a closed loop's check question
(the same, between examples), and each as "show the way" in a study whose tests ask for a way
(Study.test_kind)."""
from __future__ import annotations

from django.utils.translation import gettext

from ...i18n import domain_text
from ...models import LoopStep, StepKind
from ...trajectories import drawn_scene, study_domain
from ..closedloop import way_index
from ..forms import RATING_MAX, RATING_MIN, ShowForm, TestForm
from .base import Page, add
from .teaching import caption_of

LETTERS = "ABCDEFGH"  # options as the participant sees them


def option_letters(participant, j: int, kind: str = StepKind.TEST) -> list[tuple[str, int]]:
    """(letter, option index) of test j's (or, for a CHECK, loop step j's) options as this participant
    sees them, top to bottom.

    The page names options only by these letters, so nothing in it tells theta*'s option
    apart (the option indices, where theta*'s may sit first, stay on the server)."""
    order = (participant.loop_steps.get(index=j).option_order if kind == StepKind.CHECK
             else participant.option_orders[j])
    return [(LETTERS[pos], k) for pos, k in enumerate(order)]


def question_of(participant, kind: str, j: int) -> dict:
    """The stored test (or check question, for a CHECK step j) the participant answers."""
    if kind == StepKind.CHECK:
        step = participant.loop_steps.get(index=j)
        return participant.condition.closed_loop["checks"][step.question]
    return participant.study.test_set[j]


def score_test(participant, j: int, data: dict, kind: str = StepKind.TEST) -> tuple[bool, int]:
    """(correct, confidence score): the chosen option's rating, negated if it is not theta*'s."""
    option = question_of(participant, kind, j)["options"][data["choice"]]
    rating = data["ratings"][data["choice"]]
    correct = bool(option["is_theta_star"])
    return correct, rating if correct else -rating


def score_show(participant, j: int, data: dict, kind: str = StepKind.TEST) -> tuple[bool, float, int | None]:
    """(optimal, regret, way) of the way shown in show test j (or loop step j's check): replayed under θ*
    (Domain.score_shown); `way` is, for a check, which of its ways it is (closedloop.way_index), else None."""
    question = question_of(participant, kind, j)
    score = study_domain(participant.study).score_shown(question["env_id"], data["moves"])
    way = way_index(question, score["rows"]) if kind == StepKind.CHECK else None
    return bool(score["optimal"]), float(score["regret"]), way


def show_endings(scene: dict, rules: dict) -> list[str]:
    """What ends the way on a show page, in the participant's language, one sentence each: what "finished"
    means there (a square marked G, the object put down on D, the "Stop here" button)."""
    out = []
    if scene["world"].get("goals"):
        out.append(gettext("it reaches a square marked G"))
    if rules.get("deliver"):
        out.append(gettext("it puts the {object} down on the square marked D").format(
            object=rules["object"] or gettext("object")))
    if rules.get("exit"):
        out.append(gettext("you press “Stop here”: the robot stays where it is"))
    return out


class TestPage(Page):
    """A test: the environment without the robot, then its options (each played, one chosen, each rated);
    options go by the letters this participant sees, so the page cannot tell θ*'s apart."""

    __test__ = False  # a study's test page, not a pytest class
    kind, form, draws_robot = StepKind.TEST, TestForm, True

    def items(self, participant):
        return range(len(participant.study.test_set))

    def number(self, participant, step) -> int:
        return step.item + 1

    def context(self, participant, step, ctx):
        domain = study_domain(participant.study)
        test = question_of(participant, self.kind, step.item)
        shown = option_letters(participant, step.item, self.kind)
        return {"number": self.number(participant, step), "caption": caption_of(domain, test),
                "scene": drawn_scene(test, robot=False, domain=domain), "options": [letter for letter, _ in shown],
                "option_robots": {letter: test["options"][k]["robot"] for letter, k in shown},
                "ratings": range(RATING_MIN, RATING_MAX + 1)}

    def bind(self, participant, step, post):
        return TestForm(post, participant, step, shown=option_letters(participant, step.item, self.kind),
                        env_id=question_of(participant, self.kind, step.item)["env_id"])

    def score(self, answer, participant, step, data):
        answer.chosen_option = data["choice"]
        answer.correct, answer.confidence_score = score_test(participant, step.item, data, self.kind)

    def simulate(self, sim, participant, step):
        options = question_of(participant, self.kind, step.item)["options"]
        choice, ratings = sim.choose(participant, step, options)
        letter = dict((k, a) for a, k in option_letters(participant, step.item, self.kind))  # the page posts letters
        return {"choice": letter[choice], "played": list(letter.values()),
                **{f"rating_{letter[k]}": r for k, r in enumerate(ratings)}}


class CheckPage(TestPage):
    """A closed loop's check question, answered as a test is; numbered among the loop's checks."""

    kind = StepKind.CHECK

    def items(self, participant):
        return ()  # the closed loop decides its checks as the participant goes

    def number(self, participant, step) -> int:
        return participant.loop_steps.filter(index__lte=step.item, kind=LoopStep.CHECK).count()


class ShowTestPage(TestPage):
    """A test that asks to show the way: the world and its rules, never θ*'s way; the way shown is replayed
    and scored on the server (Domain.score_shown)."""

    form = ShowForm

    @property
    def template(self) -> str:
        return "studyapp/step_show.html"

    def context(self, participant, step, ctx):
        domain = study_domain(participant.study)
        test = question_of(participant, self.kind, step.item)
        scene = drawn_scene(test, robot=False, domain=domain)  # never θ*'s way
        rules = domain.show_rules(test["env_id"])
        rules = {**rules, "object": domain_text(domain, rules["object"])}  # the page says its name
        return {"number": self.number(participant, step), "caption": caption_of(domain, test), "scene": scene,
                "rules": rules, "endings": show_endings(scene, rules)}

    def bind(self, participant, step, post):
        return ShowForm(post, participant, step, question_of(participant, self.kind, step.item))

    def score(self, answer, participant, step, data):
        answer.correct, answer.regret, answer.chosen_option = score_show(participant, step.item, data, self.kind)

    def simulate(self, sim, participant, step):
        return None  # simulated participants choose among options; they cannot show a way


class ShowCheckPage(ShowTestPage):
    """A closed loop's check question that asks to show the way."""

    kind = StepKind.CHECK
    items, number = CheckPage.items, CheckPage.number


TEST, CHECK = add(TestPage()), add(CheckPage())
add(ShowTestPage(), show=True)
add(ShowCheckPage(), show=True)
