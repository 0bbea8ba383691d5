"""EKF2 (26 states) along the analytic aircraft flight of :mod:`inins.core.flight`.

Stands in for the run-ekf bank-turn flight until that lands: 10 min, speed
steps at 30, 150, 400 s, climbs, five coordinated turns (first at 90 s, bank
30 deg), pseudorange and range rate from six fixed satellites. Rank and degree
of observability disagree here, and the test shows why: a coordinated flight
keeps the body y specific force near zero (|f_y| <= 0.06 m/s^2), so the z
accelerometer's tilt toward y (ma_zy) is observable in rank but its sigma does
not move.
"""

import numpy as np
import pytest

from inins.core import flight
from inins.core.units import ARCSEC, DEG, DPH, MG
from inins.observability import covariance, models, pwcs
from inins.observability import measurements as meas
from inins.observability.segments import cut_segments

LOS = np.array(
    [
        [0.0, 0.0, -1.0],
        [0.5, 0.3, -0.8],
        [-0.4, 0.6, -0.6],
        [0.2, -0.7, -0.5],
        [-0.6, -0.5, -0.3],
        [0.7, -0.2, -0.4],
    ]
)
LOS = LOS / np.linalg.norm(LOS, axis=1)[:, None]
MEAS = [
    meas.Measurement("pseudorange", 3.0, los_n=LOS),
    meas.Measurement("range_rate", 0.05, los_n=LOS),
]
EKF26 = models.MODELS["ekf26"]
SIGMA_0 = np.r_[
    [10.0] * 3, [0.5] * 3, [1 * DEG] * 3, [1 * MG] * 3, [1 * DPH] * 3, 100.0, 1.0, [60 * ARCSEC] * 9
]


@pytest.fixture(scope="module")
def segments():
    traj = flight.aircraft_trajectory()
    t = np.arange(0.0, 600.0 + 1e-9, 1.0)
    mat, vel, lla = traj.state(t)
    omega, f_b = traj.rates(t)
    return cut_segments(
        t, mat, f_b, omega, vel, lla, attitude_threshold=5 * DEG, force_threshold=0.5
    )


@pytest.mark.slow
def test_ekf26_rank_along_the_flight(segments):
    res = pwcs.analyse(EKF26, segments, MEAS)
    ends = np.cumsum([s.duration for s in segments])
    # straight and level at constant speed: the 3 alignment directions and all 9
    # misalignments unobservable (rank 14, as at rest); full rank as soon as the
    # speed step centred on 30 s (logistic, tau 6 s) has started, before the first turn
    assert res.segment_rank[0] == 14
    full = ends[res.segment_rank.index(26)]
    assert 20.0 < full < 60.0, full
    assert res.rank == 26 and res.method == "stripped"
    assert max(abs(s.f_b[1]) for s in segments) < 0.06


@pytest.mark.slow
def test_ekf26_misalignments_become_observable_in_the_turns(segments):
    res = covariance.analyse(EKF26, segments, MEAS, SIGMA_0)
    names = EKF26.names

    def ratio(t, name):
        i = names.index(name)
        return res.sigma[np.searchsorted(res.time, t), i] / SIGMA_0[i]

    gyro = ("mg_xy", "mg_xz", "mg_yx", "mg_yz", "mg_zx", "mg_zy")
    # before the first turn (90 s) no gyro misalignment has moved (measured >= 0.998)
    assert min(ratio(89.0, n) for n in gyro) > 0.99
    # the first turn excites the roll and yaw rates: mg_xz, mg_yz, mg_yx move
    # (measured 0.87, 0.93, 0.93 at 150 s); by the end all six have (measured <= 0.60)
    assert ratio(150.0, "mg_xz") < 0.9 and ratio(150.0, "mg_yz") < 0.95
    assert max(ratio(599.0, n) for n in gyro) < 0.65
    # rank says observable, degree says no: ma_zy needs a y specific force
    assert ratio(599.0, "ma_zy") > 0.99
    assert ratio(599.0, "ma_zx") < 0.6 and ratio(599.0, "ma_yx") < 0.65
