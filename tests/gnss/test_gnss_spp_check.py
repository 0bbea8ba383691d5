"""The statistics of an SPP solution (:class:`inins.gnss.spp_check.SppCheck`) on a
solution with known errors: the horizontal error against a reference trajectory, the
standing scatter, the fixes the residual test accepted."""

from types import SimpleNamespace

import numpy as np
import pytest

from inins.core import earth
from inins.gnss.spp import FixStatus
from inins.gnss.spp_check import SppCheck

LLA = np.array([0.7, 2.1, 80.0])


def _solution(offset_ned, n=10):
    """Fixes at ``ref + C_en offset`` (ECEF) with the reference 0.5 s apart."""
    r0 = earth.ecef_from_llh(*LLA)
    m_en = earth.mat_en(LLA[0], LLA[1])
    ref = r0 + np.arange(n)[:, None] * np.array([1.0, -0.5, 0.2])
    pos = ref + m_en @ np.asarray(offset_ned, float)
    status = np.full(n, FixStatus.FIX)
    status[3] = FixStatus.FAULT_DETECTED
    sol = SimpleNamespace(
        time=100.0 + 0.5 * np.arange(n),
        pos=pos,
        vel=np.zeros((n, 3)),
        status=status,
        n_used=np.full(n, 7),
        pdop=np.full(n, 1.8),
        residual_rms=np.full(n, 0.4),
    )
    return sol, ref


def test_track_error_is_horizontal_in_the_ned_axes_of_the_reference():
    """Fixes 3 m north, 4 m east and 12 m below the reference: 5 m horizontal at every
    accepted fix, the one whose residual test failed not scored."""
    sol, ref = _solution([3.0, 4.0, 12.0])
    check = SppCheck(sol, np.full(3, np.nan), np.nan, None, None)
    check.score_track(sol.time, ref, 0.0)
    err = check.track_error_h
    assert np.isnan(err[3]) and check.track_inside == 10
    np.testing.assert_allclose(np.delete(err, 3), 5.0, atol=1e-6)
    r = check.results()
    assert r["epochs_accepted"] == 9 and r["err_h_median_m"] == pytest.approx(5.0, abs=1e-6)


def test_standing_scatter_is_horizontal():
    """Standing fixes spread 2 cm north-south and 1 m up-down: the horizontal scatter is
    the north-south one alone."""
    n = 20
    sol, _ = _solution([0.0, 0.0, 0.0], n)
    m_en = earth.mat_en(LLA[0], LLA[1])
    centre = earth.ecef_from_llh(*LLA)
    jitter = np.stack([0.02 * (-1.0) ** np.arange(n), np.zeros(n), np.linspace(-1, 1, n)], -1)
    sol.pos = centre + jitter @ m_en.T
    sol.status[:] = FixStatus.FIX
    check = SppCheck(sol, np.full(3, np.nan), 100.0, 50.0, (0.0, 30.0))
    assert check.results()["static_horizontal_std_m"] == pytest.approx(0.02, abs=1e-6)
