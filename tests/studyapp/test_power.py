"""Planning a study's size (studyapp/analysis/power.py), checked against hand-worked cases and an
independent power computation from the noncentral t distribution."""
import io
import math

import numpy as np
import pytest
from django.core.management import call_command
from django.core.management.base import CommandError
from scipy import stats

from studyapp.analysis import power


def noncentral_t_power(d, n, alpha=0.05):
    """Power of a two-sided two-sample t-test, n per group, written out from its definition."""
    df = 2 * n - 2
    nc = d * math.sqrt(n / 2)
    tc = stats.t.isf(alpha / 2, df)
    return stats.nct.sf(tc, df, nc) + stats.nct.cdf(-tc, df, nc)


def test_the_textbook_case():
    # Cohen (1988): d = 0.5, alpha = .05 two-sided, power .8 -> 64 per group (63.77 rounded up)
    assert power.participants_needed(0.5) == 64
    assert noncentral_t_power(0.5, 64) >= 0.8 > noncentral_t_power(0.5, 63)
    assert power.power_with(0.5, 64) == pytest.approx(noncentral_t_power(0.5, 64), abs=1e-9)


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
    for bad in (dict(alpha=0), dict(alpha=1.5), dict(power=1.0)):
        with pytest.raises(ValueError, match="strictly between 0 and 1"):
            power.power_table(**bad)
    with pytest.raises(ValueError, match="effect size must be positive"):
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
    for args, message in ((["--effect", "oops"], "NAME=D"), (["--effect", "x=-1"], "positive Cohen's d"),
                          (["--alpha", "2"], "strictly between"), (["--study", "nope"], "no study 'nope'"),
                          (["--n", "1"], "at least 2")):
        with pytest.raises(CommandError, match=message):
            call_command("power", *args, stdout=io.StringIO())
