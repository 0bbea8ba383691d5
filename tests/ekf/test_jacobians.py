"""Every F and H block of the filters against a finite difference of the nonlinear model
(``tests/jacobian.py``): the tight EKF17/EKF26 (+ an inter-system bias) model and its
pseudorange and range-rate rows, the loose 15/24-state model with the time offset and
its antenna position and velocity rows, and the vehicle rows (NHC, odometer, ZUPT,
ZARU). The operating point makes every term matter: attitude (20, -10, 130) deg, a
lever arm of metres, a turning body (0.2-0.3 rad/s), an aircraft's or a car's speed, a
non-zero error state (the rows are taken at ``nav (-) x``), a mounting of degrees.

Each row function's prediction is checked too (``z - y`` against the nonlinear model
at the error state): ``H`` the derivative of the very prediction the update uses.
The stated approximations of design.md §6b are the tolerances: the lever arm turning
with the NED frame of a displaced position, ``|l| / R`` (5e-7 per metre).
"""

import numpy as np
import pytest

from inins.core import earth, rotation
from inins.core.error_model import EKF17, EKF26, StateLayout
from inins.core.units import DEG, DPH
from inins.ekf import kernels, loose, rows, step
from inins.ekf.measurements import predict
from tests.jacobian import (
    antenna,
    antenna_shift,
    assert_jacobian,
    body_rate_over_earth,
    column_tolerance,
    earth_rate,
    error_rate,
    specific_force_n,
    truth_of,
    vehicle_velocity,
)

LLA = np.array([37.0 * DEG, 127.0 * DEG, 300.0])
MAT_NB = rotation.mat_from_euler(20 * DEG, -10 * DEG, 130 * DEG)
QUAT = rotation.quat_from_mat(MAT_NB)
OMEGA_IB = np.array([0.2, -0.1, 0.3])  # rad/s: the body turns
F_B = np.array([1.2, -0.7, -9.5])  # m/s^2
LEVER = np.array([1.5, -0.8, -2.0])  # m
FLIGHT = np.array([150.0, -80.0, 5.0])  # m/s
DRIVE = np.array([15.0, -8.0, 0.5])
MOUNTING = np.array([2.0, -3.0, 10.0]) * DEG
FRAME = np.linalg.norm(LEVER) / earth.A  # the lever arm turning with the NED frame, per m


def _x0(layout, **extra):
    """A non-zero error state of ``layout``: the rows are taken at ``nav (-) x0``."""
    x = np.zeros(len(layout))
    values = {
        "dr_N": 0.3,
        "dr_E": -0.2,
        "dr_D": 0.5,
        "dv_N": 0.05,
        "dv_E": -0.03,
        "dv_D": 0.02,
        "phi_N": 1e-3,
        "phi_E": -2e-3,
        "phi_D": 5e-3,
        "ba_x": 1e-3,
        "bg_x": 2 * DPH,
        "bg_y": -1 * DPH,
        "bg_z": 3 * DPH,
        "clock_bias": 120.0,
        "clock_drift": 0.8,
        "isb_R": 4.0,
        "dt_g": 0.08,
    } | extra
    for name, value in values.items():
        if name in layout.names:
            x[layout.index(name)] = value
    return x


# --------------------------------------------------------------------------- F


@pytest.mark.parametrize("layout", [EKF17, EKF26], ids=["EKF17", "EKF26"])
def test_tight_model_is_the_jacobian_of_the_error_dynamics(layout):
    """:func:`inins.ekf.kernels.system_matrix26`, every block (the core's model is checked
    alike in tests/core/test_error_model.py; here the compiled one the filter runs)."""
    F = np.zeros((len(layout), len(layout)))
    kernels.system_matrix26(LLA[0], LLA[2], FLIGHT, F_B, MAT_NB, OMEGA_IB, F)
    point = (LLA, FLIGHT, MAT_NB, F_B, OMEGA_IB)
    x0 = np.zeros(len(layout))
    assert_jacobian(
        F,
        lambda x: error_rate(layout, point, x, tau=0.01),
        x0,
        layout,
        layout.names[-1],
        atol=column_tolerance(F, layout, 2e-5, 1e-12),
        rtol=0.0,
        steps={"position": 1e4, "velocity": 0.1, "attitude": 1e-3, "gyro_bias": 1e-6},
    )


@pytest.mark.parametrize("misalignments", [False, True], ids=["LOOSE15", "LOOSE24"])
def test_loose_model_is_the_jacobian_of_the_error_dynamics(misalignments):
    """The loose filter's F: EKF26's rows and columns ``LooseConfig.keep`` (the clock
    dropped) and the time offset, a constant (zero row and column)."""
    cfg = loose.LooseConfig(dt=0.01, misalignments=misalignments, time_offset=True)
    layout = cfg.layout
    Ff = np.zeros((26, 26))
    kernels.system_matrix26(LLA[0], LLA[2], DRIVE, F_B, MAT_NB, OMEGA_IB, Ff)
    F = np.zeros((cfg.n, cfg.n))
    F[: cfg.n_base, : cfg.n_base] = Ff[np.ix_(cfg.keep, cfg.keep)]
    point = (LLA, DRIVE, MAT_NB, F_B, OMEGA_IB)
    assert_jacobian(
        F,
        lambda x: error_rate(layout, point, x, tau=0.01),
        np.zeros(cfg.n),
        layout,
        "loose",
        atol=column_tolerance(F, layout, 2e-5, 1e-12),
        rtol=0.0,
        steps={"position": 1e4, "velocity": 0.1, "attitude": 1e-3, "gyro_bias": 1e-6},
    )


# --------------------------------------------------------------------------- tight rows


def _satellites(k=5, seed=3):
    r = earth.ecef_from_llh(*LLA)
    rng = np.random.default_rng(seed)
    dirs = rng.normal(size=(k, 3)) + 2.0 * r / np.linalg.norm(r)
    dirs /= np.linalg.norm(dirs, axis=1)[:, None]
    pos = r + 2.2e7 * dirs
    vel = rng.normal(scale=2500.0, size=(k, 3))
    return rows.Satellites(
        np.arange(1, k + 1, dtype=np.int64),
        pos,
        vel,
        2.2e7 + rng.normal(scale=100.0, size=k),  # pseudoranges (m)
        rng.normal(scale=1e4, size=k),  # satellite clocks (m)
        np.full(k, 3.0),  # delay (m)
        rng.normal(scale=500.0, size=k),  # range rates (m/s)
        rng.normal(scale=0.1, size=k),  # satellite clock drifts (m/s)
        np.ones(k),
        np.full(k, 0.05),
    )


class _Epoch:
    """The attributes :func:`inins.ekf.measurements.predict` reads."""

    def __init__(self, sats):
        self.sat_pos, self.sat_vel = sats.pos, sats.vel
        self.sat_clock, self.sat_clock_drift, self.delay = sats.clock, sats.clock_drift, sats.delay


def _tight_model(layout, sats, bias_col, x0):
    """Predicted (pseudoranges, range rates) of the truth ``nav (-) x`` (clock and bias
    states are values; the lever arm turns at the measured rate less the gyro-bias state
    and the Earth rate in body axes). ``stable``: the pseudoranges less those of a fixed
    antenna position, free of the cancellation of two 2e7 m ranges (for the differences)."""
    nav = (QUAT, FLIGHT, LLA)
    clk = layout.index("clock_bias")
    ref = truth_of(nav, x0)
    r_ref = antenna(ref, OMEGA_IB, LEVER)[0]

    def model(x, stable=False):
        truth = truth_of(nav, x, x0)
        bg = x[layout.slice("gyro_bias")]
        r, v = antenna(truth, body_rate_over_earth(truth, OMEGA_IB - bg), LEVER)
        isb = np.where(bias_col >= 0, x[np.maximum(bias_col, 0)], 0.0)
        pr, rr = predict(_Epoch(sats), r, v, x[clk], x[clk + 1], isb)
        if stable:  # |s - r| - |s - r_ref| = -2 d . (s - r_ref - d / 2) / (the sum), d = r - r_ref
            d = antenna_shift(truth, ref, LEVER)
            to_sat = sats.pos - r_ref
            norms = np.linalg.norm(to_sat - d, axis=1) + np.linalg.norm(to_sat, axis=1)
            pr = -2.0 * ((to_sat - d / 2) @ d) / norms + x[clk] + isb
        return pr, rr

    return model


@pytest.mark.parametrize(
    "layout",
    [EKF17, EKF26 + StateLayout(("isb_R",))],
    ids=["EKF17", "EKF26+isb"],
)
def test_pseudorange_and_range_rate_rows(layout):
    sats = _satellites()
    n = len(layout)
    bias_col = np.full(5, -1)
    if n > 26:
        bias_col[[1, 3]] = layout.index("isb_R")
    x0 = _x0(layout)
    ant = step.antenna(QUAT, FLIGHT, LLA, x0, OMEGA_IB, LEVER)
    los = rows.line_of_sight(ant, sats)
    y_pr, H_pr, r_pr = rows.pseudorange_rows(ant, sats, los, x0, bias_col)
    y_rr, H_rr, r_rr = rows.range_rate_rows(ant, sats, los, x0)
    model = _tight_model(layout, sats, bias_col, x0)
    pr0, rr0 = model(x0)
    z_pr = sats.pseudorange  # y = z - zhat, zhat with the satellite clock and delay
    np.testing.assert_allclose(z_pr - y_pr, pr0, rtol=0, atol=1e-6)
    np.testing.assert_allclose(sats.range_rate - y_rr, rr0, rtol=0, atol=1e-7)
    np.testing.assert_array_equal(r_pr, sats.sigma_pr**2)
    np.testing.assert_array_equal(r_rr, sats.sigma_rr**2)
    position = dict.fromkeys(("dr_N", "dr_E", "dr_D"), FRAME + 1e-9)
    assert_jacobian(H_pr, lambda x: model(x, True)[0], x0, layout, "pseudorange", atol=position)
    assert_jacobian(H_rr, lambda x: model(x)[1], x0, layout, "range rate", atol=position)


# --------------------------------------------------------------------------- loose rows


FRAC = 0.003  # s: the solution's tag after the INS state's IMU sample boundary


def _loose(misalignments):
    cfg = loose.LooseConfig(dt=0.01, misalignments=misalignments, time_offset=True)
    return cfg.layout, _x0(cfg.layout), cfg.layout.index("dt_g")


def _loose_position_model(layout, x0):
    """The antenna's ECEF position at the solution's instant ``r + C_en (C_nb l_b + v lag)``,
    ``lag = frac + dt_g``, less the IMU's position at ``nav (-) x0`` (so that differences
    keep their bits). The antenna is carried over the lag by the estimated velocity,
    taken as known (design.md §6b: the velocity error's share ``lag dv`` is not
    modelled)."""
    nav = (QUAT, DRIVE, LLA)
    td = layout.index("dt_g")
    _, v_known, lla0 = truth_of(nav, x0)
    r0 = earth.ecef_from_llh(*lla0)

    def model(x):
        q, _, lla = truth_of(nav, x, x0)
        shift = rotation.mat_from_quat(q) @ LEVER + v_known * (FRAC + x[td])
        return (earth.ecef_from_llh(*lla) - r0) + earth.mat_en(lla[0], lla[1]) @ shift

    return model


@pytest.mark.parametrize("misalignments", [False, True], ids=["LOOSE15+dt", "LOOSE24+dt"])
def test_antenna_position_rows(misalignments):
    layout, x0, td = _loose(misalignments)
    ant = step.antenna(QUAT, DRIVE, LLA, x0, OMEGA_IB, LEVER)
    lag = FRAC + x0[td]
    pos = earth.ecef_from_llh(*LLA) + 1.5
    y, H, r = rows.antenna_position_rows(ant, pos, np.array([1.0, 2.0, 3.0]), x0, td, lag)
    model = _loose_position_model(layout, x0)
    mat_ne = ant.mat_en.T  # the rows are in NED at the estimate
    r_imu = earth.ecef_from_llh(*ant.lla)
    np.testing.assert_allclose((pos - r_imu) - ant.mat_en @ y, model(x0), rtol=0, atol=1e-6)
    np.testing.assert_array_equal(r, [1.0, 2.0, 3.0])
    frame = (np.linalg.norm(LEVER) + np.linalg.norm(DRIVE) * lag) / earth.A + 1e-9
    position = dict.fromkeys(("dr_N", "dr_E", "dr_D"), frame)
    assert_jacobian(H, lambda x: mat_ne @ model(x), x0, layout, "position", atol=position)


def _loose_velocity_model(layout, x0):
    """The antenna's NED velocity at the solution's instant: ``v + C_nb (omega_eb x l_b)
    + a lag`` with ``omega_eb = omega_ib - bg - C_bn w_ie`` and ``a = C_nb (f_b - ba) + g``."""
    nav = (QUAT, DRIVE, LLA)
    td, bg, ba = layout.index("dt_g"), layout.slice("gyro_bias"), layout.slice("accel_bias")

    def model(x):
        truth = truth_of(nav, x, x0)
        q, v, _ = truth
        omega_eb = body_rate_over_earth(truth, OMEGA_IB - x[bg])
        u = rotation.mat_from_quat(q) @ np.cross(omega_eb, LEVER)
        return v + u + specific_force_n(truth, F_B - x[ba]) * (FRAC + x[td])

    return model


@pytest.mark.parametrize("misalignments", [False, True], ids=["LOOSE15+dt", "LOOSE24+dt"])
def test_antenna_velocity_rows(misalignments):
    layout, x0, td = _loose(misalignments)
    ant = step.antenna(QUAT, DRIVE, LLA, x0, OMEGA_IB, LEVER)
    lag = FRAC + x0[td]
    f_n = ant.mat_nb @ (F_B - x0[layout.slice("accel_bias")])
    vel = DRIVE + 0.3
    y, H, _ = rows.antenna_velocity_rows(ant, vel, np.ones(3), f_n, x0, td, lag)
    model = _loose_velocity_model(layout, x0)
    np.testing.assert_allclose(vel - y, model(x0), rtol=0, atol=1e-9)
    # the frame: gravity's height gradient over the lag (3e-7 per m)
    assert_jacobian(H, model, x0, layout, "velocity", atol=1e-6)


# --------------------------------------------------------------------------- vehicle rows


def _vehicle(layout, x0):
    """What :func:`inins.ekf.aiding.vehicle_update` hands the rows: at ``nav (-) x0``."""
    q, v, lla = truth_of((QUAT, DRIVE, LLA), x0)
    c_bn = rotation.mat_from_quat(q).T
    c_vb = rotation.mat_from_euler(*MOUNTING)
    return c_vb, c_vb @ c_bn, c_bn, v, lla


@pytest.mark.parametrize("misalignments", [False, True], ids=["LOOSE15+dt", "LOOSE24+dt"])
def test_vehicle_rows(misalignments):
    layout, x0, _ = _loose(misalignments)
    n = len(layout)
    nav = (QUAT, DRIVE, LLA)
    c_vb, c_vn, c_bn, v, lla = _vehicle(layout, x0)

    def vehicle(x):
        return vehicle_velocity(truth_of(nav, x, x0), c_vb)

    y, H, r = rows.nhc_rows(c_vn, v, 0.1, n)
    np.testing.assert_allclose(-y, vehicle(x0)[1:], atol=1e-12)
    np.testing.assert_allclose(r, [0.01, 0.01], rtol=1e-15)
    assert_jacobian(H, lambda x: vehicle(x)[1:], x0, layout, "NHC")
    y, H, _ = rows.odometer_rows(c_vn, v, 14.0, 0.1, n)
    np.testing.assert_allclose(14.0 - y, vehicle(x0)[:1], atol=1e-12)
    assert_jacobian(H, lambda x: vehicle(x)[:1], x0, layout, "odometer")
    y, H, _ = rows.zupt_rows(v, 0.01, n)
    np.testing.assert_allclose(-y, truth_of(nav, x0)[1], atol=1e-12)
    assert_jacobian(H, lambda x: truth_of(nav, x, x0)[1], x0, layout, "ZUPT")
    bg = layout.slice("gyro_bias")

    def gyro(x):
        """The mean gyro output at rest: the Earth rate in body axes plus the bias."""
        q, _, lla = truth_of(nav, x, x0)
        return rotation.mat_from_quat(q).T @ earth_rate(lla[0]) + x[bg]

    omega = gyro(x0) + 1e-5
    y, H, _ = rows.zaru_rows(omega, c_bn, earth_rate(lla[0]), x0, 0.01)
    np.testing.assert_allclose(omega - y, gyro(x0), atol=1e-15)
    # the latitude of the Earth rate (w_ie / R per m: 1e-11) is left out
    assert_jacobian(H, gyro, x0, layout, "ZARU", atol=1e-10)
