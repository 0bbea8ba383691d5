"""The chi-square(1) gate of each scalar measurement (003 §2): an innovation ``y`` with
variance ``s = H P H^T + r`` is rejected when ``y^2 / s`` exceeds the
``gate_probability`` quantile. Checked from the statistics, not from the code: clean
innovations are rejected at ``1 - p``; a fault of ``b`` sigma is rejected with the
noncentral chi-square probability ``1 - ncx2(1, b^2).cdf(threshold)`` (a 5-sigma fault
mostly, a 2-sigma one almost never at p = 0.9999).

The threshold is set where a filter run starts (``inins.ekf.filter._Run``, the only
entry point: no public function returns it); the gating itself is the compiled
:func:`inins.ekf.kernels.sequential_update`.
"""

import numpy as np
import pytest
from scipy import stats

from inins.core import strapdown
from inins.ekf import kernels
from inins.ekf.config import Coupling, FilterConfig, Model
from inins.ekf.filter import _Run

P0, R0 = 3.0, 1.0  # prior variance of the one state, measurement noise: s = 4, sigma 2


def _threshold(p):
    config = FilterConfig(Model.EKF1, Coupling.FB, 0.005, gate_probability=p)
    initial = strapdown.NavState.from_attitude([0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.6, 2.0, 0.0])
    return _Run(config, initial, 0.0, keep=False).model.threshold


def _rejected(y0, threshold):
    """Fraction of single-row updates (one state, H = 1) the gate rejects."""
    out = np.empty(len(y0), dtype=bool)
    acc, y, s = np.zeros(1, dtype=np.bool_), np.empty(1), np.empty(1)
    H, r = np.ones((1, 1)), np.array([R0])
    for i, v in enumerate(y0):
        x, P = np.zeros(1), np.array([[P0]])
        kernels.sequential_update(x, P, H, np.array([v]), r, threshold, acc, y, s)
        assert s[0] == P0 + R0
        if acc[0]:  # an accepted row moves the state by the gain times the innovation
            assert x[0] == pytest.approx(P0 / (P0 + R0) * v)
        else:
            assert x[0] == 0.0 and P[0, 0] == P0
        out[i] = not acc[0]
    return out.mean()


def _binomial_ok(rate, expected, n):
    return abs(rate - expected) <= 4.0 * np.sqrt(expected * (1 - expected) / n) + 1.0 / n


@pytest.mark.parametrize("p", [0.99, 0.9999])
def test_faults_are_rejected_at_the_stated_probability(p):
    threshold = _threshold(p)
    sigma = np.sqrt(P0 + R0)
    rng = np.random.default_rng(7)
    n = 20_000
    noise = rng.standard_normal(n)
    # clean innovations: rejected at 1 - p (p = 0.99: 1 %)
    if p == 0.99:
        assert _binomial_ok(_rejected(sigma * noise, threshold), 1 - p, n)
    for bias in (2.0, 5.0):
        expected = stats.ncx2.sf(threshold, 1, bias**2)
        rate = _rejected(sigma * (bias + noise), threshold)
        assert _binomial_ok(rate, expected, n), (p, bias, rate, expected)
    if p == 0.9999:  # 3.9 sigma gate: a 5-sigma fault is mostly rejected, 2 sigma accepted
        assert _rejected(sigma * (5.0 + noise), threshold) > 0.8
        assert _rejected(sigma * (2.0 + noise), threshold) < 0.05


def test_gate_sits_at_the_quantile_in_sigma():
    """p = 0.9999 puts the gate at 3.89 sigma of the innovation: 3.8 sigma passes, 4.0 not."""
    threshold = _threshold(0.9999)
    sigma = np.sqrt(P0 + R0)
    assert _rejected(np.array([3.8, -3.8]) * sigma, threshold) == 0.0
    assert _rejected(np.array([4.0, -4.0]) * sigma, threshold) == 1.0
