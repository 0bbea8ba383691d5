"""Paper 003 §3.3 on one simulated bank-turn flight: gyro misalignment, true z-gyro bias 0.

EKF1 (17 states) takes the heading error that the symmetric gyro misalignment
accumulates in every bank turn for a z-gyro bias that does not exist (003 Fig. 9);
EKF2 (26 states) attributes it to the misalignments (Figs. 10-11); in FB the
heading error stays well below EKF1-FF's (003 Fig. 12: about one fifth).
"""

import numpy as np
import pytest
from ekf_sim import Receiver, epoch_stream
from scipy import stats

from inins.core import imu, strapdown
from inins.core.units import ARCSEC, DEG, DEG_RTH, DPH, UG
from inins.ekf.config import Coupling, FilterConfig, InitialSigma, Model
from inins.ekf.filter import run_filter
from inins.ekf.flight import (
    Dither,
    Dithered,
    FlightPlan,
    Leg,
    LegKind,
    dither_window,
    flight_trajectory,
    gyrocompass_attitude,
)

DT = 0.005
ERRORS = imu.SensorErrors(
    gyro_bias=np.array([0.01, -0.01, 0.0]) * DPH,
    accel_bias=np.array([50, -40, 30]) * UG,
    gyro_misalignment=np.array([-30, 20, 50, 200, -40, 200]) * 1e-6,  # m_yz + m_zy = 400 urad
    accel_misalignment=np.array([20, -30, 10]) * 1e-6,
    gyro_arw=0.002 * DEG_RTH,
    accel_vrw=20 * UG,
)
DITHER = Dither(60 * ARCSEC, 40.0)
TURNS_FROM = 290.0  # s: first turn starts after the wait, take-off, climb and a straight


def _plan():
    """Wait 120 s at heading 180, take-off, climb, six alternating 360-deg turns at 30 deg
    bank (4 deg/s at 80 m/s) with a descent after the third: 1064 s. (A 690 s version
    with five turns left mg_xz at 2.0 sigma: the flight length sets the observability.)"""
    legs = [
        Leg(LegKind.WAIT, 120),
        Leg(LegKind.TAKEOFF, 40, speed=80.0),
        Leg(LegKind.CLIMB, 100, climb_rate=5.0),
    ]
    for i in range(6):
        legs += [
            Leg(LegKind.STRAIGHT, 30),
            Leg(LegKind.TURN, bank=30 * DEG, angle=(360 if i % 2 == 0 else -360) * DEG),
        ]
        if i == 2:
            legs += [Leg(LegKind.CLIMB, 60, climb_rate=-4.0)]
    return FlightPlan(
        37 * DEG, 127 * DEG, 100.0, 180 * DEG, (*legs, Leg(LegKind.STRAIGHT, 30)), aoa=2 * DEG
    )


@pytest.fixture(scope="module")
def runs():
    plan = _plan()
    base = flight_trajectory(plan)
    truth = Dithered(base, DITHER)
    rx = Receiver()
    epochs = list(epoch_stream(truth, base, ERRORS, DT, plan.duration, rx, seed=1))
    mat0, vel0, lla0 = truth.state([0.0])
    mat_base, _, _ = base.state([0.0])
    aligned = gyrocompass_attitude(mat_base[0], lla0[0, 0], lla0[0, 2], ERRORS)
    initial = strapdown.NavState.from_attitude(aligned @ mat_base[0].T @ mat0[0], vel0[0], lla0[0])
    out = {}
    for model, coupling in (
        (Model.EKF1, Coupling.FF),
        (Model.EKF2, Coupling.FF),
        (Model.EKF2, Coupling.FB),
    ):
        config = FilterConfig(
            model,
            coupling,
            DT,
            lever_arm=rx.lever_arm,
            arw=np.full(3, 0.002 * DEG_RTH),
            vrw=np.full(3, 20 * UG),
            dither_window=dither_window(DITHER, DT),
            initial_sigma=InitialSigma(
                heading=0.1 * DEG,
                gyro_bias=0.02 * DPH,
                accel_bias=100 * UG,
                gyro_misalignment=300e-6,
                accel_misalignment=100e-6,
            ),
        )
        out[model, coupling] = run_filter(config, initial, 0.0, epochs, ERRORS)
    return out


@pytest.mark.slow
def test_ekf1_misattributes_heading_drift_to_z_gyro_bias(runs):
    est, sigma = runs[Model.EKF1, Coupling.FF].series("bg_z")
    assert abs(est[-1]) > 3.0 * sigma[-1]  # true bg_z = 0


@pytest.mark.slow
@pytest.mark.parametrize("coupling", [Coupling.FF, Coupling.FB])
def test_ekf2_identifies_misalignment(runs, coupling):
    result = runs[Model.EKF2, coupling]
    est, sigma = result.series("bg_z")
    assert abs(est[-1]) < 2.0 * sigma[-1]
    for name, true in zip(
        ("mg_xy", "mg_xz", "mg_yx", "mg_yz", "mg_zx", "mg_zy"),
        ERRORS.gyro_misalignment,
        strict=True,
    ):
        est, sigma = result.series(name)
        assert abs(est[-1] - true) < 2.0 * sigma[-1], name
    # the accumulating pair is resolved well below its prior (300 urad)
    assert result.series("mg_yz")[1][-1] < 60e-6
    assert result.series("mg_zy")[1][-1] < 60e-6


@pytest.mark.slow
def test_fb_heading_error_a_fraction_of_ekf1_ff(runs):
    """Heading error against truth over the turning phase (measured 0.0057 vs 0.066 deg)."""

    def rms(result):
        sel = result.time >= TURNS_FROM
        return np.sqrt(np.mean(result.heading_error[sel] ** 2))

    assert rms(runs[Model.EKF2, Coupling.FB]) <= 0.3 * rms(runs[Model.EKF1, Coupling.FF])


@pytest.mark.slow
def test_fb_heading_corrections_a_fraction_of_the_ff_heading_drift(runs):
    """003's own comparison, Fig. 12 against Fig. 8: the inertial heading error that
    EKF1-FF estimates grows to ~0.25 deg (measured 0.24), while the heading corrections
    EKF2-FB feeds back sum to about a fifth of it (measured 0.05 deg)."""
    ff = runs[Model.EKF1, Coupling.FF]
    fb = runs[Model.EKF2, Coupling.FB]
    drift = abs(ff.series("phi_D")[0][-1])
    assert 0.2 * DEG < drift < 0.3 * DEG
    assert abs(fb.cumulative[-1, fb.layout.index("phi_D")]) <= 0.3 * drift


@pytest.mark.slow
def test_ekf2_errors_consistent_with_sigma(runs):
    """Per-state RMS of error / sigma below 1.5 (pyins-style consistency)."""
    result = runs[Model.EKF2, Coupling.FB]
    true = np.concatenate(
        [ERRORS.accel_bias, ERRORS.gyro_bias, ERRORS.accel_misalignment, ERRORS.gyro_misalignment]
    )
    sens = np.r_[9:15, 17:26]
    z = np.concatenate(
        [
            result.nav_error / result.sigma[:, :9],
            (result.state[:, sens] - true) / result.sigma[:, sens],
        ],
        axis=1,
    )
    assert np.all(np.sqrt(np.mean(z**2, axis=0)) < 1.5)
    summary = result.summary()
    assert 0.8 < summary.nis_mean < 1.2


@pytest.mark.slow
@pytest.mark.parametrize("coupling", [Coupling.FF, Coupling.FB])
def test_ekf2_nees_in_chi_square_band(runs, coupling):
    """Time-averaged NEES of all 26 states inside the 95 % chi-square(26) band.

    Measured ~19: below 26 because the true sensor errors are fixed values well
    inside the prior (misalignments 10-50 urad against 100-300 urad), which stays
    on the weakly observable states. (The band of 1064 independent samples,
    [24.6, 27.4], does not apply: successive NEES values are strongly correlated.)
    """
    low, high = stats.chi2.ppf([0.025, 0.975], 26)
    assert low < runs[Model.EKF2, coupling].summary().nees_mean < high
    # EKF1 is inconsistent on this flight: its model lacks the misalignments
    assert runs[Model.EKF1, Coupling.FF].summary().nees_mean > 10 * high


@pytest.mark.slow
def test_ff_and_fb_agree(runs):
    """No nonlinearity at these error sizes: feeding back changes nothing first order."""
    ff, fb = runs[Model.EKF2, Coupling.FF], runs[Model.EKF2, Coupling.FB]
    for name in ("mg_yz", "mg_zy", "bg_x", "bg_y"):
        (a, sigma), (b, _) = ff.series(name), fb.series(name)
        assert abs(a[-1] - b[-1]) < 0.1 * sigma[-1], name
    assert abs(ff.summary().pos_err_rms_m - fb.summary().pos_err_rms_m) < 0.05
