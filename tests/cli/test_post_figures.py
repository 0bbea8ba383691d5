"""The helpers of run-ekf's post figures (inins.commands.run_ekf_post_figures)."""

import numpy as np

from inins.commands import run_ekf_post_figures as pf


def test_beyond_3_sigma_is_the_rayleigh_tail_for_an_honest_filter():
    """North and east errors N(0, 1): the horizontal error exceeds 3 hypot(1, 1) with
    probability exp(-9) (1.2e-4); errors twice their sigma exceed it with exp(-9/4)."""
    rng = np.random.default_rng(1)
    ne = rng.standard_normal((2_000_000, 2))
    sig = np.full(ne.shape[0], np.hypot(1.0, 1.0))
    assert abs(pf.beyond_3_sigma(np.hypot(*ne.T), sig) - np.exp(-9)) < 2e-5
    assert abs(pf.beyond_3_sigma(2 * np.hypot(*ne.T), sig) - np.exp(-9 / 4)) < 1e-3
    assert np.isnan(pf.beyond_3_sigma(np.array([]), np.array([])))


def test_robust_limit_shows_the_bulk_not_the_outage_jumps():
    rng = np.random.default_rng(2)
    y = rng.standard_normal(10_000)
    y[::1000] = 1e5  # ten outage-exit jumps
    lim = pf.robust_limit(y)
    assert 2.5 * 1.5 < lim < 3.0 * 1.5  # 1.5 x the 99 % quantile of |N(0, 1)| (2.58)
    assert pf.robust_limit(np.array([np.nan])) == 1.0
