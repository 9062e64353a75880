"""Planning a study's size (studyapp/analysis/power.py), checked against hand-worked cases and an
independent power computation from the noncentral t distribution."""
import io
import math

import numpy as np
import pytest
from django.core.management import call_command
from django.core.management.base import CommandError
from scipy import integrate, stats
from statsmodels.stats.power import TTestIndPower

from studyapp.analysis import power


def noncentral_t_power(d, n, alpha=0.05):
    """Power of a two-sided two-sample t-test, n per group, written out from its definition."""
    df = 2 * n - 2
    nc = d * math.sqrt(n / 2)
    tc = stats.t.isf(alpha / 2, df)
    return stats.nct.sf(tc, df, nc) + stats.nct.cdf(-tc, df, nc)


def integrated_power(d, n, alpha):
    """The same power without the noncentral t (whose SciPy tails can be NaN): T = (Z + nc) / sqrt(V / df)
    with V ~ chi2(df), so P(|T| > c) = E_V[Phi(nc - c s) + Phi(-nc - c s)], s = sqrt(V / df), by quadrature."""
    df = 2 * n - 2
    nc, c = d * math.sqrt(n / 2), stats.t.isf(alpha / 2, df)

    def given(v):
        s = math.sqrt(v / df)
        return (stats.norm.cdf(nc - c * s) + stats.norm.cdf(-nc - c * s)) * stats.chi2.pdf(v, df)

    lo, hi = stats.chi2.ppf([1e-15, 1 - 1e-15], df)
    return integrate.quad(given, lo, hi, limit=500, epsabs=1e-13, points=[df])[0]


def test_the_textbook_case():
    # Cohen (1988): d = 0.5, alpha = .05 two-sided, power .8 -> 64 per group (63.77 rounded up)
    assert power.participants_needed(0.5) == 64
    assert noncentral_t_power(0.5, 64) >= 0.8 > noncentral_t_power(0.5, 63)
    assert power.power_with(0.5, 64) == pytest.approx(noncentral_t_power(0.5, 64), abs=1e-9)
    assert integrated_power(0.5, 64, 0.05) == pytest.approx(noncentral_t_power(0.5, 64), abs=1e-9)


def test_the_papers_first_effect():
    # p = .025 with 27 + 27: t(52) two-sided critical value 2.30816, d = 2.30816 * sqrt(2/27) = 0.62820
    d = power.effect_from_p(0.025, 27, 27)
    assert d == pytest.approx(2.308165 * math.sqrt(2 / 27), abs=1e-5)
    assert d == pytest.approx(0.62820, abs=1e-5)
    n = power.participants_needed(d)
    assert n == 41 and noncentral_t_power(d, n) >= 0.8 > noncentral_t_power(d, n - 1)
    # a study of exactly that size had about even odds of reaching p < .05 again
    assert power.power_with(d, 27) == pytest.approx(noncentral_t_power(d, 27), abs=1e-9)
    assert 0.5 < power.power_with(d, 27) < 0.7


@pytest.mark.parametrize("alpha, target", [(0.05, 0.9), (0.01, 0.8), (0.1, 0.8)])
def test_needed_is_the_smallest_n_reaching_the_power(alpha, target):
    for d in (0.3, 0.8, 1.2):
        n = power.participants_needed(d, alpha=alpha, power=target)
        assert noncentral_t_power(d, n, alpha) >= target - 1e-9
        assert noncentral_t_power(d, n - 1, alpha) < target


def test_the_table_and_bad_input():
    rows = power.power_table(n_per_condition=30, effects={"my guess": 0.4})
    assert [r["comparison"] for r in rows] == ["approx* vs exact", "coverage-approx* vs random",
                                               "coverage-random vs random", "my guess"]
    assert rows[-1]["needed"] == power.participants_needed(0.4) == 100
    assert all(0 < r["power_at_n"] < 1 for r in rows)
    assert np.all(np.diff([r["d"] for r in rows[:3]]) != 0)
    for bad, message in ((dict(alpha=0), "alpha must be a number from 0.0001 to 0.5"),
                         (dict(alpha=1.5), "alpha must be"), (dict(power=1.0), "power must be above alpha"),
                         (dict(effects={"x": math.inf}), "from 0.05 to 5")):
        with pytest.raises(ValueError, match=message):
            power.power_table(**bad)
    with pytest.raises(ValueError, match="Cohen's d"):
        power.participants_needed(0)


@pytest.mark.django_db
def test_the_command(make_study):
    out = io.StringIO()
    call_command("power", "--effect", "small=0.2", "--n", "27", stdout=out)
    text = out.getvalue()
    assert "approx* vs exact" in text and " 0.628      41 " in text and "small" in text and "power@27" in text
    make_study("sized", target_per_condition=25)
    out = io.StringIO()
    call_command("power", "--study", "sized", stdout=out)
    assert "power@25" in out.getvalue()
    for args, message in ((["--effect", "oops"], "NAME=D"), (["--effect", "x=-1"], "from 0.05 to 5"),
                          (["--alpha", "2"], "alpha must be"), (["--study", "nope"], "no study 'nope'"),
                          (["--n", "1"], "at least 2")):
        with pytest.raises(CommandError, match=message):
            call_command("power", *args, stdout=io.StringIO())


# Inputs that used to end in "cannot convert float NaN to integer" (statsmodels' solver
# answered NaN) are each refused with a message naming the bound; in bounds an answer always exists.
@pytest.mark.parametrize("args, message", [
    (["--alpha", "0.5", "--power", "0.3"], "power must be above alpha (0.5) and at most 0.999, got 0.3"),
    (["--effect", "x=inf"], "--effect x=inf: an effect size (Cohen's d) must be a number from 0.05 to 5, got inf"),
    (["--effect", "x=1e-9"], "from 0.05 to 5, got 1e-09"),
    (["--effect", "x=nan"], "from 0.05 to 5, got nan"),
    (["--effect", "x=6"], "from 0.05 to 5, got 6.0"),
    (["--alpha", "nan"], "alpha must be a number from 0.0001 to 0.5 (two-sided), got nan"),
    (["--alpha", "0"], "alpha must be a number from 0.0001 to 0.5"),
    (["--alpha", "0.6"], "alpha must be a number from 0.0001 to 0.5"),
    (["--power", "1"], "at most 0.999, got 1.0"),
    (["--power", "inf"], "got inf"),
    (["--alpha", "0.05", "--power", "0.05"], "power must be above alpha (0.05)"),
])
@pytest.mark.django_db
def test_bad_power_inputs_are_refused_with_a_message(args, message):
    with pytest.raises(CommandError) as caught:
        call_command("power", *args, stdout=io.StringIO())
    assert message in str(caught.value) and "NaN" not in str(caught.value)


@pytest.mark.django_db
def test_a_good_input_against_statsmodels_by_hand():
    out = io.StringIO()
    call_command("power", "--alpha", "0.05", "--power", "0.8", "--effect", "mine=0.5", stdout=out)
    line = next(x for x in out.getvalue().splitlines() if x.startswith("mine"))
    # TTestIndPower's own solver, where it converges: 63.77 -> 64; and 64 is the first n reaching .8
    solved = TTestIndPower().solve_power(effect_size=0.5, alpha=0.05, power=0.8, ratio=1.0, alternative="two-sided")
    assert solved == pytest.approx(63.7656, abs=1e-3)
    assert line.split()[1:3] == ["0.500", str(math.ceil(solved))] == ["0.500", "64"]
    assert TTestIndPower().power(0.5, nobs1=63, alpha=0.05) < 0.8 <= TTestIndPower().power(0.5, nobs1=64, alpha=0.05)


@pytest.mark.parametrize("d, alpha, target", [
    (5.0, 0.5, 0.8),      # 2 per group already exceed the power: statsmodels' solver gave NaN
    (2.0, 0.2, 0.5),      # likewise (the dashboard's "solver finds no sample size")
    (0.5, 0.001, 0.99),   # the solver converged on an n whose power is .977, short of .99
    (0.05, 0.0001, 0.999),  # the bounds' far corner
    (5.0, 0.0001, 0.06),  # power barely above alpha, the largest effect
])
def test_the_solver_s_failures_now_have_the_smallest_n(d, alpha, target):
    n = power.participants_needed(d, alpha=alpha, power=target)
    assert integrated_power(d, n, alpha) >= target - 1e-9
    assert n == 2 or integrated_power(d, n - 1, alpha) < target


def test_scipy_nan_tails_are_taken_from_the_complement():
    # d = 1, alpha = 1e-4, n = 50: SciPy's nct.cdf of the far lower tail is NaN, so statsmodels' power is too
    assert math.isnan(TTestIndPower().power(1.0, nobs1=50, alpha=1e-4))
    upper = stats.nct.sf(stats.t.isf(5e-5, 98), 98, 5.0)  # the lower tail (below -3.97 at nc = 5) is < 1e-20
    assert power.power_with(1.0, 50, alpha=1e-4) == pytest.approx(upper, abs=1e-15)
    assert power.power_with(1.0, 50, alpha=1e-4) == pytest.approx(integrated_power(1.0, 50, 1e-4), abs=1e-8)
