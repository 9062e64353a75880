"""What model-based simulated participants score, in expectation: the closed form behind
the designer's pilot and power table, checked by hand and against participants drawn one by one."""
import numpy as np
import pytest

from teaching.core.answers import Question
from teaching.core.conditions import teach
from teaching.core.learners import make_model
from teaching.core.simulate import AnswerModel, SimulatedLearner, model_choices, predicted_scores
from teaching.core.testset import select_test_set
from teaching.domains.driving.synthetic import synthetic_table


def test_predicted_scores_by_hand():
    # sure of θ*'s option: every participant picks it and rates it 1 + 6 = 7
    sure = predicted_scores(np.array([[1.0, 0.0]]), np.array([0]), 0.0)
    assert (sure.accuracy, sure.mean, sure.sd) == (1.0, 7.0, 0.0)
    # a pure guess between two: each option half the time, rated 1 + Binomial(6, 1/2) (mean 4, variance 1.5),
    # so s = ±r has mean 0 and E[s²] = 1.5 + 16
    guess = predicted_scores(np.array([[1.0, 0.0]]), np.array([0]), 1.0)
    assert guess.accuracy == 0.5 and guess.mean == pytest.approx(0.0) and guess.sd == pytest.approx(np.sqrt(17.5))
    # two tests, one sure of θ* (second option) and one sure of the wrong one: mean (7 - 7) / 2, no spread
    two = predicted_scores(np.array([[0.0, 1.0], [0.0, 1.0]]), np.array([1, 0]), 0.0)
    assert (two.accuracy, two.mean, two.sd) == (0.5, 0.0, 0.0)
    with pytest.raises(ValueError, match=r"lapse rate must lie in \[0, 1\]"):
        predicted_scores(np.array([[1.0, 0.0]]), np.array([0]), 1.5)


@pytest.fixture(scope="module")
def design():
    table = synthetic_table(200, 40, n_candidates=6, seed=8)
    result = teach(table)
    sequences = {c: result.sequences[c].envs for c in ("exact", "det-euclidean", "random")}
    ids = np.asarray(table.env_ids)
    tests = select_test_set(table, [ids[s].tolist() for s in sequences.values()], 0)
    questions = [Question(t["env_index"], tuple(o["theta_index"] for o in t["options"])) for t in tests]
    star = np.array([[o["is_theta_star"] for o in t["options"]].index(True) for t in tests])
    return table, result, sequences, questions, star


@pytest.mark.parametrize("model, lapse", [("det-euclidean", 0.15), ("prob-reward", 0.0), ("hierarchical", 0.3)])
def test_the_closed_form_is_what_drawn_participants_score(design, model, lapse):
    """8,000 participants drawn by AnswerModel.answer, scored as the study scores them (the chosen option's
    rating, negative unless it is θ*'s): their mean and spread match the closed form."""
    table, result, sequences, questions, star = design
    learner = result.models[model]
    no_lapse = model_choices(table, {model: learner}, sequences, questions)[model]
    drawn = AnswerModel(table, SimulatedLearner(model, learner.value if learner.param else None, lapse), questions)
    rng = np.random.default_rng(3)
    for name, rows in sequences.items():
        want = predicted_scores(no_lapse[name], star, lapse)
        scores, hits = [], []
        for _ in range(8_000):
            choice, ratings = drawn.answer(tuple(rows), rng)
            chosen = ratings[np.arange(len(choice)), choice]
            scores.append(np.where(choice == star, chosen, -chosen).mean())
            hits.append((choice == star).mean())
        se = max(want.sd, 0.05) / np.sqrt(len(scores))
        assert np.mean(scores) == pytest.approx(want.mean, abs=5 * se), name
        assert np.mean(hits) == pytest.approx(want.accuracy, abs=0.01), name
        assert np.std(scores) == pytest.approx(want.sd, rel=0.05, abs=0.02), name


def test_the_models_choices_are_the_answer_models_without_lapse(design):
    table, result, sequences, questions, _ = design
    models = {"exact": make_model("exact"), "det-euclidean": result.models["det-euclidean"]}
    got = model_choices(table, models, sequences, questions)
    assert set(got) == set(models) and all(set(v) == set(sequences) for v in got.values())
    for label, model in models.items():
        answers = AnswerModel(table, SimulatedLearner(label, model.value if model.param else None, 0.0), questions)
        for name, rows in sequences.items():
            assert got[label][name].shape == (len(questions), 4)
            np.testing.assert_allclose(got[label][name], answers.probabilities(tuple(int(e) for e in rows)), atol=1e-12)
