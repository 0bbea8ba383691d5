"""Chi-square quantiles of inins.core.stats against closed forms, tables and scipy."""

import math

import numpy as np
import pytest
from scipy import special

from inins.core.stats import chi2_cdf, chi2_ppf


@pytest.mark.parametrize("p", [1e-6, 0.01, 0.5, 0.95, 0.999, 1 - 1e-9])
def test_two_degrees_of_freedom_is_the_exponential_law(p):
    # chi-square with 2 dof: P(x) = 1 - exp(-x/2), so x = -2 ln(1 - p)
    assert chi2_ppf(p, 2) == pytest.approx(-2.0 * math.log1p(-p), rel=1e-12)


@pytest.mark.parametrize(
    ("p", "dof", "quantile"),  # printed tables (Abramowitz & Stegun table 26.8)
    [
        (0.95, 1, 3.841458820694124),
        (0.99, 1, 6.634896601021214),
        (0.95, 3, 7.814727903251179),
        (0.99, 10, 23.209251158954356),
        (0.05, 30, 18.492660981953467),
        (0.999, 4, 18.46682695290317),
    ],
)
def test_table_quantiles(p, dof, quantile):
    assert chi2_ppf(p, dof) == pytest.approx(quantile, rel=1e-10)


def test_agrees_with_scipy_over_the_range_a_gate_uses():
    dof = np.arange(1, 61)
    for p in (1e-4, 0.05, 0.5, 0.9, 0.99, 1 - 1e-3, 1 - 1e-7, 1 - 1e-12):
        mine = chi2_ppf(p, dof)
        assert mine.shape == dof.shape
        np.testing.assert_allclose(mine, special.chdtri(dof, 1.0 - p), rtol=1e-11)


def test_cdf_inverts_ppf_and_edges():
    for dof in (0.5, 1.0, 7.0, 250.0):
        for p in (0.001, 0.3, 0.97):
            assert chi2_cdf(chi2_ppf(p, dof), dof) == pytest.approx(p, abs=1e-13)
    assert chi2_ppf(0.0, 3) == 0.0
    assert chi2_ppf(1.0, 3) == math.inf
    assert math.isnan(chi2_ppf(1.5, 3))
    with pytest.raises(ValueError, match="degrees of freedom"):
        chi2_ppf(0.5, 0)


def test_many_degrees_of_freedom_as_consistency_bounds_use():
    # the mean NIS over an hour of 26-state epochs: 10^5 degrees of freedom
    for dof in (1e3, 9.36e4, 1e6):
        for p in (0.025, 0.975):
            np.testing.assert_allclose(chi2_ppf(p, dof), special.chdtri(dof, 1 - p), rtol=1e-9)
