"""The analysis statistics against numbers computed independently of the code under test.

The code uses statsmodels (ANOVA), scipy.stats.ttest_ind / pingouin (Welch, Cohen's d),
statsmodels multipletests (Holm) and scipy.stats.pearsonr.  The expected values here come from
numpy least squares on hand-built design matrices, the textbook Welch / Fisher-z formulas and
regularised incomplete beta functions (scipy.special), never from those functions.
"""
from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from scipy import special

from studyapp.analysis import stats as S
from studyapp.conditions import negligible_spread

TOL = 1e-6


# ------------------------------------------------------------------ independent references

def f_sf(F, d1, d2):
    """P(F(d1, d2) > F) via the regularised incomplete beta function."""
    return special.betainc(d2 / 2, d1 / 2, d2 / (d2 + d1 * F))


def t_two_sided(t, df):
    return special.betainc(df / 2, 0.5, df / (df + t * t))


def rss(X, y):
    beta, *_ = np.linalg.lstsq(X, y, rcond=None)
    r = y - X @ beta
    return float(r @ r)


def dummies(levels, values, coding):
    """Columns for a categorical factor: treatment (drop first) or sum-to-zero (last = -1)."""
    cols = []
    for lv in levels[1:] if coding == "treatment" else levels[:-1]:
        if coding == "treatment":
            cols.append((values == lv).astype(float))
        else:
            cols.append((values == lv).astype(float) - (values == levels[-1]).astype(float))
    return np.column_stack(cols)


def inter(A, B):
    return np.column_stack([A[:, i] * B[:, j] for i in range(A.shape[1]) for j in range(B.shape[1])])


def hand_anova(y, a, b, interaction=True):
    """Type II and type III SS, df, F, p and partial eta^2 by model comparison."""
    la, lb = sorted(set(a)), sorted(set(b))
    one = np.ones((len(y), 1))
    out = {}
    # type II: each main effect adjusted for the other main effect only
    At, Bt = dummies(la, a, "treatment"), dummies(lb, b, "treatment")
    full_cols = [one, At, Bt] + ([inter(At, Bt)] if interaction else [])
    X_full = np.column_stack(full_cols)
    rss_full = rss(X_full, y)
    df_res = len(y) - np.linalg.matrix_rank(X_full)
    rss_ab = rss(np.column_stack([one, At, Bt]), y)
    ss2 = {"a": rss(np.column_stack([one, Bt]), y) - rss_ab, "b": rss(np.column_stack([one, At]), y) - rss_ab}
    if interaction:
        ss2["ab"] = rss_ab - rss_full
    # type III: sum coding, drop each block from the full model
    As, Bs = dummies(la, a, "sum"), dummies(lb, b, "sum")
    blocks = {"a": As, "b": Bs}
    if interaction:
        blocks["ab"] = inter(As, Bs)
    ss3 = {}
    for k in blocks:
        X = np.column_stack([one] + [v for kk, v in blocks.items() if kk != k])
        ss3[k] = rss(X, y) - rss_full
    dfs = {"a": len(la) - 1, "b": len(lb) - 1, "ab": (len(la) - 1) * (len(lb) - 1)}
    for typ, ss in (("II", ss2), ("III", ss3)):
        out[typ] = {}
        for k, v in ss.items():
            F = (v / dfs[k]) / (rss_full / df_res)
            out[typ][k] = dict(SS=v, df=dfs[k], F=F, p=f_sf(F, dfs[k], df_res), partial_eta2=v / (v + rss_full))
    out["resid"] = dict(SS=rss_full, df=df_res)
    return out


# ------------------------------------------------------------------ fixed data

def make_data(cells: dict[str, list[list[tuple[bool, int]]]], excluded_garbage=True, training=None):
    """cells: condition -> list of participants, each a list of (correct, confidence) answers."""
    P, A = [], []
    for cond, people in cells.items():
        for i, answers in enumerate(people):
            pid = f"{cond}#{i}"
            P.append(dict(participant_id=pid, condition=cond, attention_ok=True))
            for t, (ok, conf) in enumerate(answers):
                A.append(dict(participant_id=pid, test_index=t, test_cluster=[0, 1, 2, 3, 4, 5][t], correct=ok,
                              confidence=conf))
        if excluded_garbage:  # failed the attention check with extreme answers: must not count anywhere
            pid = f"{cond}#x"
            P.append(dict(participant_id=pid, condition=cond, attention_ok=False))
            for t in range(2):
                A.append(dict(participant_id=pid, test_index=t, test_cluster=t, correct=True, confidence=7))
    if training is None:
        training = [dict(condition=c, position=0, cluster=0) for c in cells]
    return pd.DataFrame(P), pd.DataFrame(A), pd.DataFrame(training)


def by_hand_means(cells):
    return {c: [np.mean([conf if ok else -conf for ok, conf in ans]) for ans in people] for c, people in cells.items()}


# Unbalanced 2x2 for distance {reward, euclidean} x determinism {det, prob}: n = 3, 5, 4, 2.
APPROX_CELLS = {
    "det-reward": [[(True, 5), (False, 2)], [(True, 3), (True, 4)], [(False, 6), (True, 1)]],
    "det-euclidean": [[(True, 7), (True, 6)], [(True, 5), (False, 1)], [(True, 6), (True, 3)],
                      [(True, 4), (True, 7)], [(False, 2), (True, 6)]],
    "prob-reward": [[(False, 4), (False, 3)], [(True, 2), (False, 5)], [(True, 6), (False, 1)],
                    [(False, 7), (True, 3)]],
    "prob-euclidean": [[(True, 3), (True, 2)], [(False, 1), (True, 5)]],
    "det-strategy": [[(True, 2), (False, 3)], [(True, 6), (True, 6)], [(False, 1), (False, 4)]],
}
COVERAGE_CELLS = {
    "random": [[(True, 3), (False, 4)], [(False, 5), (False, 2)], [(True, 1), (True, 2)], [(False, 3), (True, 6)]],
    "coverage-random": [[(True, 4), (True, 2)], [(False, 1), (True, 5)]],
    "det-euclidean": APPROX_CELLS["det-euclidean"],
    "coverage-approx*": [[(True, 7), (True, 7)], [(True, 5), (True, 6)], [(False, 2), (True, 7)]],
    "exact": [[(False, 3), (True, 2)], [(True, 1), (False, 6)], [(False, 4), (False, 4)]],
}


def row(table, effect):
    return table.loc[effect]


def check_anova(res, expected, names):
    assert res.ok, res.message
    for typ, table in (("II", res.type2), ("III", res.type3)):
        for key, eff in names.items():
            e = expected[typ][key]
            got = row(table, eff)
            for col in ("SS", "df", "F", "p", "partial_eta2"):
                assert got[col] == pytest.approx(e[col], abs=TOL, rel=TOL), (typ, eff, col)
        assert row(table, "Residual")["SS"] == pytest.approx(expected["resid"]["SS"], abs=TOL)
        assert row(table, "Residual")["df"] == expected["resid"]["df"]


# ------------------------------------------------------------------ tests

def test_scores_and_participant_table_apply_exclusions():
    P, A, T = make_data(APPROX_CELLS, training=[dict(condition="det-reward", position=i, cluster=i) for i in range(3)])
    table = S.participant_table(P, A, T)
    assert len(table) == sum(len(v) + 1 for v in APPROX_CELLS.values())  # excluded kept in the table
    bad = table[~table["attention_ok"]]
    assert bad["excluded"].all() and (bad["exclusion_reason"] == "failed attention check").all()
    r = table.set_index("participant_id").loc["det-reward#0"]
    assert (r["score_0"], r["score_1"], r["mean_score"]) == (5.0, -2.0, 1.5)
    assert r["distance"] == "reward" and r["determinism"] == "deterministic" and r["model"] == "approximate"
    assert r["n_examples"] == 3 and not r["coverage"]
    assert S.condition_factors("coverage-approx*")["distance"] == "euclidean"
    cr = S.condition_factors("coverage-random")
    assert cr["model"] == "random" and cr["coverage"] and pd.isna(cr["distance"])
    assert S.condition_factors("my-custom-sequence")["model"] == "other"
    summary = S.condition_summary(table)
    means = by_hand_means(APPROX_CELLS)
    for c, v in means.items():
        assert summary.loc[c, "n"] == len(v) and summary.loc[c, "n_excluded"] == 1
        assert summary.loc[c, "mean"] == pytest.approx(np.mean(v), abs=TOL)
        assert summary.loc[c, "se"] == pytest.approx(np.std(v, ddof=1) / math.sqrt(len(v)), abs=TOL)


def test_unbalanced_distance_x_determinism_type2_and_type3_by_hand():
    P, A, T = make_data(APPROX_CELLS)
    table = S.participant_table(P, A, T)
    additive, full = S.distance_determinism_anovas(table)
    means = by_hand_means(APPROX_CELLS)
    conds = ["det-reward", "det-euclidean", "prob-reward", "prob-euclidean"]
    y = np.array([m for c in conds for m in means[c]])
    a = np.array([c.split("-")[1] for c in conds for _ in means[c]])           # distance
    b = np.array([S.DETERMINISM[c.split("-")[0]] for c in conds for _ in means[c]])  # determinism
    exp = hand_anova(y, a, b, interaction=True)
    check_anova(full, exp, {"a": "distance", "b": "determinism", "ab": "distance x determinism"})
    # the design is unbalanced, so type II and III main effects really differ
    assert abs(full.type2.loc["distance", "SS"] - full.type3.loc["distance", "SS"]) > 1e-3
    assert abs(full.type2.loc["determinism", "F"] - full.type3.loc["determinism", "F"]) > 1e-3
    assert list(full.cells["n"]) == [5, 2, 3, 4]  # euclidean/det, euclidean/prob, reward/det, reward/prob

    conds5 = conds + ["det-strategy"]
    y5 = np.array([m for c in conds5 for m in means[c]])
    a5 = np.array([c.split("-")[1] for c in conds5 for _ in means[c]])
    b5 = np.array([S.DETERMINISM[c.split("-")[0]] for c in conds5 for _ in means[c]])
    exp5 = hand_anova(y5, a5, b5, interaction=False)
    check_anova(additive, exp5, {"a": "distance", "b": "determinism"})
    assert additive.type2.loc["distance", "df"] == 2
    assert additive.type2.loc["Residual", "df"] == len(y5) - 4


def test_coverage_x_model_anova_by_hand():
    P, A, T = make_data(COVERAGE_CELLS)
    table = S.participant_table(P, A, T)
    res = S.coverage_model_anova(table)
    means = by_hand_means(COVERAGE_CELLS)
    spec = {"random": ("without", "random"), "coverage-random": ("with", "random"),
            "det-euclidean": ("without", "approx*"), "coverage-approx*": ("with", "approx*")}
    y = np.array([m for c in spec for m in means[c]])
    a = np.array([spec[c][0] for c in spec for _ in means[c]])
    b = np.array([spec[c][1] for c in spec for _ in means[c]])
    check_anova(res, hand_anova(y, a, b), {"a": "coverage", "b": "model", "ab": "coverage x model"})
    assert abs(res.type2.loc["model", "SS"] - res.type3.loc["model", "SS"]) > 1e-3
    assert res.cells.set_index(["coverage", "model"]).loc[("with", "random"), "n"] == 2


def hand_welch(x, y):
    x, y = np.asarray(x, float), np.asarray(y, float)
    n1, n2 = len(x), len(y)
    v1, v2 = x.var(ddof=1), y.var(ddof=1)
    se = math.sqrt(v1 / n1 + v2 / n2)
    t = (x.mean() - y.mean()) / se
    df = (v1 / n1 + v2 / n2) ** 2 / ((v1 / n1) ** 2 / (n1 - 1) + (v2 / n2) ** 2 / (n2 - 1))
    q = special.stdtrit(df, 0.975)
    sp = math.sqrt(((n1 - 1) * v1 + (n2 - 1) * v2) / (n1 + n2 - 2))
    d = x.mean() - y.mean()
    return dict(t=t, df=df, p=t_two_sided(t, df), diff=d, ci_low=d - q * se, ci_high=d + q * se, cohen_d=d / sp)


def hand_holm(p):
    p = np.asarray(p, float)
    order = np.argsort(p)
    m = len(p)
    adj = np.empty(m)
    running = 0.0
    for rank, i in enumerate(order):
        running = max(running, min(1.0, (m - rank) * p[i]))
        adj[i] = running
    return adj


def test_welch_planned_comparisons_holm_and_named_pair_by_hand():
    P, A, T = make_data(COVERAGE_CELLS)
    table = S.participant_table(P, A, T)
    extra = [("coverage-approx*", "coverage-random")]
    w, msgs = S.welch_tests(table, S.default_comparisons() + extra)
    assert msgs == []
    means = by_hand_means(COVERAGE_CELLS)
    pairs = [("det-euclidean", "exact"), ("det-euclidean", "random"), ("coverage-approx*", "random"),
             ("coverage-random", "random"), ("coverage-approx*", "coverage-random")]
    assert list(zip(w["a"], w["b"], strict=True)) == pairs
    exp = [hand_welch(means[a], means[b]) for a, b in pairs]
    holm = hand_holm([e["p"] for e in exp])
    for i, e in enumerate(exp):
        for k, v in e.items():
            assert w.loc[i, k] == pytest.approx(v, abs=TOL, rel=TOL), (pairs[i], k)
        assert w.loc[i, "p_holm"] == pytest.approx(holm[i], abs=TOL)
        assert w.loc[i, "n_a"] == len(means[pairs[i][0]])
    assert w.loc[0, "comparison"] == "approx* (det-euclidean) vs exact"


def test_too_few_participants_give_messages_not_nan():
    cells = {k: v for k, v in COVERAGE_CELLS.items()}
    cells["coverage-random"] = cells["coverage-random"][:1]
    P, A, T = make_data(cells)
    an = S.analyze(P, A, T)
    w = an.welch.set_index("comparison")
    note = w.loc["coverage-random vs random", "note"]
    assert "coverage-random has 1" in note and "at least 2" in note
    assert pd.isna(w.loc["coverage-random vs random", "t"])
    # Holm family = the three comparisons that were run
    tested = an.welch[an.welch["t"].notna()]
    assert len(tested) == 3
    assert np.allclose(tested["p_holm"], hand_holm(tested["p"]))
    # the coverage design is complete (its cell lacks participants: said); of the five approximate models
    # only det-euclidean is a condition, so there is no distance x determinism design and no such ANOVA
    [cov] = an.anovas
    assert cov.name.startswith("coverage x model")
    assert not cov.ok and "(with, random): 1" in cov.message
    assert any("coverage x model" in m for m in an.messages)
    assert not any("distance" in m for m in an.messages)


def test_the_papers_anovas_and_comparisons_only_where_their_conditions_are():
    """A study of the five approximate models has both distance x determinism ANOVAs and no coverage one;
    a study of exact and random alone has no ANOVA and no planned comparison (and says nothing about them);
    pairs the researcher names are compared whatever the study's conditions."""
    approx = S.analyze(*make_data(APPROX_CELLS))
    assert [a.name.split(" (")[0] for a in approx.anovas] == ["distance + determinism", "distance x determinism"]
    assert set(approx.welch["comparison"]) == set()  # neither exact nor random: no planned pair
    two = {"exact": COVERAGE_CELLS["exact"], "random": COVERAGE_CELLS["random"]}
    bare = S.analyze(*make_data(two))
    assert bare.anovas == [] and bare.welch.empty
    assert not any(m.startswith(("distance", "coverage", "approx*", "Welch")) for m in bare.messages), bare.messages
    named = S.analyze(*make_data(two), extra_comparisons=[("exact", "random")])
    assert list(named.welch["comparison"]) == ["exact vs random"] and named.welch["t"].notna().all()


def hand_pearson(x, y):
    x, y = np.asarray(x, float), np.asarray(y, float)
    n = len(x)
    r = np.corrcoef(x, y)[0, 1]
    z, se = math.atanh(r), 1 / math.sqrt(n - 3)
    q = 1.959963984540054
    t = r * math.sqrt((n - 2) / (1 - r * r))
    return dict(r=r, p=t_two_sided(t, n - 2), ci_low=math.tanh(z - q * se), ci_high=math.tanh(z + q * se))


def test_helpful_examples_and_pearson_by_hand():
    # det-euclidean shows clusters 0,0,2; random shows 1,3,3,4,6; exact shows 5
    training = ([dict(condition="det-euclidean", position=i, cluster=c) for i, c in enumerate([0, 0, 2])]
                + [dict(condition="random", position=i, cluster=c) for i, c in enumerate([1, 3, 3, 4, 6])]
                + [dict(condition="exact", position=0, cluster=5)])
    rng = np.random.default_rng(3)
    cells = {c: [[(bool(rng.random() < 0.6), int(rng.integers(1, 8))) for _ in range(6)] for _ in range(n)]
             for c, n in (("det-euclidean", 4), ("random", 5), ("exact", 3))}
    P, A, T = make_data(cells, training=training)
    counts = S.examples_per_cluster(pd.DataFrame(training))
    # test cluster -> helpful, by the paper's rule (x if x > 0 else -y, y from the partner cluster)
    # (tests are in clusters 0..5; the partner of cluster c is c ^ 1)
    expected_helpful = {
        "det-euclidean": [2, -2, 1, -1, 0, 0],
        "random": [-1, 1, -2, 2, 1, -1],
        "exact": [0, 0, 0, 0, -1, 1],
    }
    for c, hs in expected_helpful.items():
        assert [S.helpful_examples(counts, c, t) for t in range(6)] == hs, c
    table = S.participant_table(P, A, T)
    cors = {(c.name, c.level): c for c in S.correlations(table, A, T)}
    # condition x test level (the paper's figure): y = mean score over included participants
    xs_n, xs_h, ys = [], [], []
    nex = {"det-euclidean": 3, "random": 5, "exact": 1}
    for c, people in cells.items():
        for t in range(6):
            ys.append(np.mean([(conf if ok else -conf) for ok, conf in (p[t] for p in people)]))
            xs_n.append(nex[c])
            xs_h.append(expected_helpful[c][t])
    for key, xs in ((("number of examples vs score", "condition x test"), xs_n),
                    (("helpful examples vs per-test score", "condition x test"), xs_h)):
        got, e = cors[key], hand_pearson(xs, ys)
        assert got.ok and got.n == 18
        for k, v in e.items():
            assert getattr(got, k) == pytest.approx(v, abs=TOL), (key, k)
    # answer level, helpful vs score, excluded participants absent
    hx = [expected_helpful[c][t] for c, people in cells.items() for p in people for t in range(6)]
    hy = [(conf if ok else -conf) for c, people in cells.items() for p in people for ok, conf in p]
    got, e = cors[("helpful examples vs per-test score", "answer")], hand_pearson(hx, hy)
    assert got.n == len(hx) == 72
    for k, v in e.items():
        assert getattr(got, k) == pytest.approx(v, abs=TOL)
    # participant level, number of examples vs mean score
    px = [nex[c] for c, people in cells.items() for _ in people]
    py = [np.mean([(conf if ok else -conf) for ok, conf in p]) for people in cells.values() for p in people]
    got, e = cors[("number of examples vs mean score", "participant")], hand_pearson(px, py)
    for k, v in e.items():
        assert getattr(got, k) == pytest.approx(v, abs=TOL)


def test_pearson_too_few_or_constant_is_a_message():
    d = pd.DataFrame({"x": [1, 2, 3], "y": [1, 3, 2]})
    c = S.correlation(d, "x", "y", "n", "level")
    assert not c.ok and "3 point(s)" in c.message and math.isnan(c.r)
    d = pd.DataFrame({"x": [2, 2, 2, 2, 2], "y": [1, 3, 2, 5, 4]})
    c = S.correlation(d, "x", "y", "n", "level")
    assert not c.ok and "x is constant" in c.message


def _constant(cells, answers_of):
    """The same shape of study, every participant in a condition giving `answers_of(condition)`."""
    return {c: [answers_of(c) for _ in people] for c, people in cells.items()}


def test_identical_scores_everywhere_are_a_message_not_an_f():
    """Every participant identical is a message, not an F: rounding noise used to give 'F(2, 11) = 0.41'."""
    cells = _constant({**APPROX_CELLS, **COVERAGE_CELLS}, lambda c: [(True, 5), (False, 2)])
    an = S.analyze(*make_data(cells))
    for a in an.anovas:
        assert not a.ok and "every included participant has the same score" in a.message, a.name
        assert a.type2 is None and a.type3 is None
    assert an.welch["t"].isna().all() and an.welch["p_holm"].isna().all()
    assert all("zero variance" in n for n in an.welch["note"])


def test_constant_cells_with_different_means_are_a_message_not_an_f():
    """Constant cells with different means used to give 'F(1, 8) = 1.8e31, p < .001'; two constant
    groups with fractional means 't(6.0) = 2.7e16', entering the Holm family."""
    # fractional means (0.5, 1.5, ...) so the rounding residue is not exactly zero
    answers = {"det-reward": [(True, 3), (False, 2)], "det-euclidean": [(True, 1), (True, 2)],
               "prob-reward": [(True, 5), (False, 2)], "prob-euclidean": [(True, 7), (False, 4)],
               "det-strategy": [(True, 2), (True, 1)], "random": [(True, 3), (False, 2)],
               "coverage-random": [(True, 1), (True, 2)], "coverage-approx*": [(True, 6), (True, 7)],
               "exact": [(False, 1), (True, 2)]}
    cells = _constant({**APPROX_CELLS, **COVERAGE_CELLS}, answers.get)
    an = S.analyze(*make_data(cells))
    for a in an.anovas:
        assert not a.ok and "no variance within cells" in a.message, a.name
    assert an.welch["t"].isna().all() and an.welch["p_holm"].isna().all()
    # one varying group beside a constant one is an ordinary Welch test
    cells["random"] = COVERAGE_CELLS["random"]
    w = S.analyze(*make_data(cells)).welch
    tested = w[w["t"].notna()]
    assert sorted(tested["b"]) == ["random"] * 3 and np.isfinite(tested["t"]).all()
    assert np.allclose(tested["p_holm"], hand_holm(tested["p"]))  # the Holm family is these three only


def test_negligible_spread_is_relative_to_the_scores_size():
    assert negligible_spread(0.0, [])
    assert negligible_spread(0.0, [0.0, 0.0])
    assert negligible_spread(1e-16, [0.5, 1.5])
    assert not negligible_spread(1e-6, [0.5, 1.5])
    assert not negligible_spread(1e-13, [1e-6, 2e-6])  # small scores, real spread
