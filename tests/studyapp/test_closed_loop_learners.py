"""Simulated participants who learn by a model, through a closed-loop condition: they
learn from what the loop showed them and answer its checks by the choice model, so the loop follows their
answers; the model fit takes each one's own path."""
import numpy as np
import pytest

from studyapp.analysis.modelfit import fit_study, study_answers, study_design
from studyapp.analysis.simulate import StudyLearner, run_participant, simulate
from studyapp.models import Answer, LoopStep, Participant, StepKind
from studyapp.participant import closedloop
from studyapp.researcher.studies import build_study, table_spec
from teaching.api import SimulatedLearner
from tests.conftest import SMALL_SEQUENCES, TINY_TEST_SET

pytestmark = pytest.mark.django_db

LOOP = {"model": "prob-euclidean", "value": 1.0, "lapse": 0.2, "max_examples": 4, "check_every": 1}


@pytest.fixture
def loop_study(tiny_table, settings, tmp_path):
    settings.VAR_DIR = tmp_path
    spec = table_spec(tiny_table, slug="loop-learners", sequences={"alpha": SMALL_SEQUENCES["alpha"]},
                      **TINY_TEST_SET)
    spec["conditions"].append({"name": "closed-loop", "closed_loop": LOOP})
    spec.update(name="Closed loop", target_per_condition=100)
    return build_study(spec)


def loopers(study):
    return list(Participant.objects.filter(study=study, condition__name="closed-loop", completed_at__isnull=False))


def test_learners_go_through_the_loop_and_their_answers_steer_it(loop_study):
    simulate(loop_study, n_per_condition=10, seed=4, learner=SimulatedLearner("det-reward", 0.1, 0.3))
    people = loopers(loop_study)
    assert len(people) >= 8  # balanced assignment: about half of 20
    paths = set()
    for p in people:
        assert closedloop.replay(p) == []  # every decision follows from the stored answers
        steps = list(p.loop_steps.all())
        checks = Answer.objects.filter(participant=p, kind=StepKind.CHECK).count()
        assert checks == sum(s.kind == LoopStep.CHECK for s in steps) > 0
        paths.add(tuple(round(s.decision["p_theta_star"], 9) for s in steps))
    assert len(paths) > 1  # different answers, different beliefs behind the decisions


def test_a_learners_check_answers_follow_its_belief(loop_study):
    """A learner with no lapse who believes θ* outright picks θ*'s option; a careless one (lapse 1) guesses:
    over 40 check answers each, the first is right far more often."""
    learner = StudyLearner(loop_study, SimulatedLearner("exact", None, 0.0))
    rng = np.random.default_rng(0)
    right = {True: 0, False: 0}
    for attentive in (True, False):
        for _ in range(8):
            p = run_participant(loop_study, rng, attentive=attentive, learner=learner)
            if p.condition.name == "closed-loop":
                right[attentive] += Answer.objects.filter(participant=p, kind=StepKind.CHECK, correct=True).count()
    assert right[True] > right[False]


def test_the_fit_takes_each_loop_participants_own_path(loop_study):
    # An exact learner (lapse 0.1): its answers tell models apart from guessing on any draw.  Assignment ties and
    # option orders come from the system's randomness, and prob-euclidean (lambda = 1) on the tiny table gave
    # answers the fit could not tell from guessing in 2 of 4 runs.
    simulate(loop_study, n_per_condition=8, seed=5, learner=SimulatedLearner("exact", None, 0.1))
    design = study_design(loop_study)
    assert design.loops == ("closed-loop",) and set(design.sequences) == {"alpha"}
    answers, condition_of = study_answers(loop_study, design)
    row = {int(e): i for i, e in enumerate(np.asarray(design.table.env_ids))}
    for pid, g in zip(answers.participant_ids, answers.group, strict=True):
        p = Participant.objects.get(pk=int(pid))
        name = answers.sequence_names[g]
        assert condition_of[name] == p.condition.name
        if p.condition.name == "closed-loop":  # what the loop showed them, examples and feedback in order
            shown = [row[s.env_id] for s in p.loop_steps.all() if s.kind in (LoopStep.EXAMPLE, LoopStep.FEEDBACK)]
            assert list(answers.sequences[g]) == shown and name.startswith("closed-loop path ")
    cells = fit_study(loop_study).accuracy()
    loop_cells = [c for c in cells if c["condition"] == "closed-loop"]
    assert len(loop_cells) == len(loop_study.test_set)
    assert all(c["n"] == len(loopers(loop_study)) - Participant.objects.filter(
        study=loop_study, condition__name="closed-loop", excluded=True).count() for c in loop_cells)
    assert {c["condition"] for c in cells} == {"alpha", "closed-loop"}


def test_a_new_web_worker_maps_the_open_studies_packs_before_its_first_request(loop_study):
    """config/gunicorn.conf.py's post_worker_init calls warm_packs: a closed study's pack is left alone."""
    closedloop._load.cache_clear()
    assert closedloop.warm_packs() == 1 and closedloop._load.cache_info().currsize == 1
    closedloop._load.cache_clear()
    loop_study.is_open = False
    loop_study.save(update_fields=["is_open"])
    assert closedloop.warm_packs() == 0 and closedloop._load.cache_info().currsize == 0
