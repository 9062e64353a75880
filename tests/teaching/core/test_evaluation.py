"""Ideal-user matrix and examples-per-cluster grids, by hand and on a synthetic table."""
import matplotlib.image as mpimg
import numpy as np
import pytest

from teaching.core.conditions import teach
from teaching.core.evaluation import (
    SEQUENCE_NAMES,
    USER_NAMES,
    cluster_counts,
    cluster_grid,
    examples_per_cluster,
    ideal_user_matrix,
)
from teaching.core.learners import MODEL_NAMES, Distances, make_model
from teaching.core.plots import plot_examples_shown, plot_ideal_users
from teaching.core.selection import theta_star_clusters
from teaching.domains.driving.domain import DOMAIN as DRIVING
from teaching.domains.driving.synthetic import hand_table, synthetic_table

PAIRS = DRIVING.class_of_cluster  # the car: clusters 2k, 2k+1 belong to class k


def test_matrix_by_hand():
    # 3 envs x 4 thetas
    d_reward = np.array([[0, 0, 1, 1], [0, 1, 0, 1], [0, 0, 0, 0.0]])
    d_euclid = np.array([[0, 2, 0, 2], [0, 0, 0, 0], [0, 2, 2, 2.0]])
    dist = Distances(hand_table(d_reward, d_euclid))
    models = {"exact": make_model("exact"), "det-euclidean": make_model("det-euclidean", 1.0),
              "prob-reward": make_model("prob-reward", np.log(3.0))}
    seqs = {"a": [0], "b": [0, 1], "c": [2]}
    m = ideal_user_matrix(models, seqs, dist, sequence_names=("a", "b", "c"),
                          user_names=("exact", "det-euclidean", "prob-reward"))
    expect = np.array([
        [1 / 2, 1 / 2, 1 / (1 + 1 + 2 / 3)],      # env 0: exact keeps {0,1}; euclid keeps {0,2}
        [1.0, 1 / 2, 1 / (1 + 1 / 3 + 1 / 3 + 1 / 9)],
        [1 / 4, 1.0, 1 / 4],
    ])
    np.testing.assert_allclose(m, expect, rtol=1e-6)


def test_cluster_grid_layout_matches_the_paper():
    grid = cluster_grid(np.arange(8), PAIRS)
    # columns = merging, braking, tailgating, other; rows = first / second strategy
    np.testing.assert_array_equal(grid, [[0, 2, 4, 6], [1, 3, 5, 7]])


def test_cluster_grid_of_uneven_classes():
    # 3 classes: two strategies, three strategies, one ("other"); rows = a class's 1st, 2nd, 3rd cluster
    grid = cluster_grid(np.array([10, 11, 20, 21, 22, 30]), np.array([0, 0, 1, 1, 1, 2]))
    np.testing.assert_array_equal(grid, [[10, 20, 30], [11, 21, 0], [0, 22, 0]])


def test_cluster_counts_count_repeats():
    clusters = np.array([0, 3, 3, 7, 5])
    np.testing.assert_array_equal(cluster_counts(clusters, [1, 2, 1, 4], 8), [0, 0, 0, 3, 0, 1, 0, 0])
    grids = examples_per_cluster(clusters, {"x": [0, 3], "y": []}, names=("x", "y"), class_of_cluster=PAIRS)
    np.testing.assert_array_equal(grids[0], [[1, 0, 0, 0], [0, 0, 0, 1]])
    assert grids[1].sum() == 0


@pytest.fixture(scope="module")
def result():
    table = synthetic_table(120, 50, n_candidates=5, seed=21)
    return table, Distances(table), teach(table, seed=0)


def test_paper_matrix_shape_and_diagonal(result):
    table, dist, res = result
    envs = {k: s.envs for k, s in res.sequences.items()}
    m = ideal_user_matrix(res.models, envs, dist)
    # the paper's 8 x 7 figure and the hierarchical learner's row (before random) and column (last)
    assert m.shape == (9, 8) and SEQUENCE_NAMES[-1] == "random" and USER_NAMES[-1] == "hierarchical"
    assert USER_NAMES[:7] == MODEL_NAMES and SEQUENCE_NAMES[:7] + SEQUENCE_NAMES[8:] == MODEL_NAMES + ("random",)
    paper = ideal_user_matrix({k: res.models[k] for k in MODEL_NAMES}, envs, dist,
                              sequence_names=MODEL_NAMES + ("random",), user_names=MODEL_NAMES)
    np.testing.assert_array_equal(paper, np.delete(m, 7, axis=0)[:, :7])
    assert np.all((m >= 0) & (m <= 1))
    # prob-strategy and det-strategy are the same user and the same sequence
    np.testing.assert_allclose(m[:, 3], m[:, 6])
    np.testing.assert_allclose(m[3], m[6])
    # each deterministic user is taught best by its own sequence unless the cap binds
    for j, name in enumerate(USER_NAMES):
        if name in ("exact", "det-reward", "det-euclidean", "det-strategy") and len(envs[name]) < 10:
            assert m[j, j] == pytest.approx(m[:, j].max())


def test_figures_are_grayscale_white_zero_black_one(tmp_path, result):
    table, dist, res = result
    path = tmp_path / "sim.png"
    plot_ideal_users(np.array([[0.0, 1.0]]), ["s"], ["u0", "u1"], path)
    img = mpimg.imread(path)[..., :3]
    assert img.shape[0] > 50
    # the image is gray: R = G = B everywhere
    assert np.allclose(img[..., 0], img[..., 1]) and np.allclose(img[..., 1], img[..., 2])
    assert (img.mean(-1) < 0.05).any() and (img.mean(-1) > 0.95).any()  # a black cell and white paper
    grids = examples_per_cluster(theta_star_clusters(table), {k: s.envs for k, s in res.sequences.items()},
                                 class_of_cluster=PAIRS)
    plot_examples_shown(grids, SEQUENCE_NAMES, tmp_path / "ex.png", DRIVING)
    assert (tmp_path / "ex.png").stat().st_size > 1000
