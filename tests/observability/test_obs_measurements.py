"""Measurement rows against finite differences of the nonlinear measurements (spec §6a)."""

import numpy as np
import pytest

from inins.core import earth, error_model
from inins.core import rotation as rot
from inins.core.units import DEG
from inins.exceptions import InputError
from inins.observability import measurements as meas
from inins.observability import models
from inins.observability.segments import make_segment

LLA = (np.radians(37.5), np.radians(127.0), 800.0)
LOS = np.array(
    [[0.0, 0.0, -1.0], [0.5, 0.3, -0.8], [-0.4, 0.6, -0.6], [0.2, -0.7, -0.5], [-0.6, -0.5, -0.3]]
)
LOS = LOS / np.linalg.norm(LOS, axis=1)[:, None]
MAT_NB = rot.mat_from_euler(10 * DEG, -5 * DEG, 200 * DEG)


def _segment(**kwargs):
    return make_segment(60.0, LLA, mat_nb=MAT_NB, vel_n=(120.0, -40.0, 2.0), **kwargs)


def _perturbed(mat_nb, phi):
    """``C_est = exp(-[phi x]) C`` (phi-angle definition, exact)."""
    return rot.mat_from_rotvec(-np.asarray(phi)) @ mat_nb


def test_dd_phase_row_is_the_derivative_of_the_nonlinear_double_difference():
    baseline_b = np.array([0.3, 1.8, -0.1])
    m = meas.Measurement("dd_phase", 0.005, baseline_b=baseline_b, los_n=LOS, reference=2)
    H, R = meas.rows(error_model.ALIGN12, _segment(), m)
    pairs = meas.dd_pairs(len(LOS), 2)
    assert H.shape == (4, 12) and pairs.tolist() == [[2, 0], [2, 1], [2, 3], [2, 4]]
    np.testing.assert_array_equal(R, 0.005**2 * np.eye(4))
    phi_cols = slice(3, 6)
    assert not H[:, :3].any() and not H[:, 6:].any()  # attitude only
    step = 1e-6
    for i in range(3):
        dphi = np.zeros(3)
        dphi[i] = step
        plus = meas.dd_phase(_perturbed(MAT_NB, dphi), baseline_b, LOS, pairs)
        minus = meas.dd_phase(_perturbed(MAT_NB, -dphi), baseline_b, LOS, pairs)
        fd = (plus - minus) / (2 * step)
        np.testing.assert_allclose(H[:, phi_cols][:, i], fd, rtol=0, atol=1e-9)
    # closed form of spec §6a: -(e_i - e_j)^T [b_n x]
    b_n = MAT_NB @ baseline_b
    expected = -(LOS[pairs[:, 0]] - LOS[pairs[:, 1]]) @ rot.skew(b_n)
    np.testing.assert_allclose(H[:, phi_cols], expected, rtol=1e-15, atol=1e-15)
    # rotation about the baseline is invisible: H b_n = 0
    np.testing.assert_allclose(H[:, phi_cols] @ b_n, 0.0, atol=1e-14)
    # sign of the nonlinear model: the range from B is shorter by e^T b
    assert meas.dd_phase(np.eye(3), [0, 0, -1.0], LOS[[0, 1]], np.array([[0, 1]]))[0] == (
        pytest.approx(-(LOS[0, 2] - LOS[1, 2]) * -1.0)
    )


def _range_change(r_ant, sat):
    """``|sat - r| - |sat|`` without cancellation: ``(r.r - 2 sat.r) / (|sat - r| + |sat|)``."""
    return (r_ant @ r_ant - 2.0 * sat @ r_ant) / (
        np.linalg.norm(sat - r_ant, axis=-1) + np.linalg.norm(sat, axis=-1)
    )


def test_pseudorange_row_is_the_derivative_of_the_range_with_lever_arm():
    lever_b = np.array([1.2, -0.4, -2.5])
    m = meas.Measurement("pseudorange", 3.0, lever_arm_b=lever_b, los_n=LOS)
    layout = error_model.EKF17
    H, _ = meas.rows(layout, _segment(), m)
    sat = 2.2e7 * LOS  # satellites 22 000 km from the antenna (NED, antenna at the origin)

    def rho(x):
        dr, phi = x[:3], x[6:9]
        moved = dr + (_perturbed(MAT_NB, phi) - MAT_NB) @ lever_b  # antenna displacement
        return _range_change(moved, sat) + x[15]

    x0 = np.zeros(17)
    for name, step in (
        ("dr_N", 1.0),
        ("dr_E", 1.0),
        ("dr_D", 1.0),
        ("phi_N", 1e-5),
        ("phi_E", 1e-5),
        ("phi_D", 1e-5),
        ("clock_bias", 1.0),
    ):
        i = layout.index(name)
        dx = x0.copy()
        dx[i] = step
        fd = (rho(dx) - rho(-dx)) / (2 * step)
        np.testing.assert_allclose(H[:, i], fd, rtol=0, atol=1e-8, err_msg=name)
    others = [i for i, n in enumerate(layout.names) if not n.startswith(("dr", "phi", "clock_b"))]
    assert not H[:, others].any()


def test_range_rate_row_is_the_derivative_with_the_lever_arm_velocity():
    lever_b = np.array([1.2, -0.4, -2.5])
    omega_eb_b = np.array([0.05, -0.02, 0.1])  # a turning body
    w_ie = earth.rate_ie_n(LLA[0])  # the antenna's velocity over the Earth
    seg = _segment(omega_ib_b=omega_eb_b + MAT_NB.T @ w_ie)
    m = meas.Measurement("range_rate", 0.05, lever_arm_b=lever_b, los_n=LOS)
    layout = error_model.EKF17
    H, _ = meas.rows(layout, seg, m)

    def rate(x):
        """INS-predicted range rate minus the true one (satellite velocity cancels)."""
        c_est = _perturbed(MAT_NB, x[6:9])
        w_eb = seg.omega_ib_b + x[12:15] - c_est.T @ w_ie
        v_ant = x[3:6] + c_est @ np.cross(w_eb, lever_b)  # true v_n cancels: left out
        return -LOS @ v_ant + x[16]

    for name in (
        "dv_N",
        "dv_E",
        "dv_D",
        "phi_N",
        "phi_E",
        "phi_D",
        "bg_x",
        "bg_y",
        "bg_z",
        "clock_drift",
    ):
        i = layout.index(name)
        dx = np.zeros(17)
        dx[i] = 1e-6
        fd = (rate(dx) - rate(-dx)) / 2e-6
        np.testing.assert_allclose(H[:, i], fd, rtol=1e-7, atol=1e-12, err_msg=name)


def test_velocity_and_position_rows_pick_the_states_present():
    seg = _segment()
    H, R = meas.rows(error_model.EKF17, seg, meas.Measurement("position", 2.0))
    np.testing.assert_array_equal(H, np.eye(17)[:3])
    assert R[0, 0] == 4.0
    H, _ = meas.rows(models.ALIGN10, seg, meas.Measurement("velocity", 0.1))
    np.testing.assert_array_equal(H, np.eye(10)[:2])  # the 10-state model: dv_N, dv_E only
    H, R = meas.measurement_matrix(
        error_model.ALIGN12,
        seg,
        [
            meas.Measurement("velocity", 0.1),
            meas.Measurement("dd_phase", 0.01, baseline_b=(0, 1, 0), los_n=LOS),
        ],
    )
    assert H.shape == (7, 12) and np.allclose(np.diag(R), [0.01] * 3 + [1e-4] * 4)


def test_bad_measurements_raise_input_errors_naming_the_key():
    seg = _segment()
    with pytest.raises(InputError, match="unknown measurement") as err:
        meas.Measurement("doppler_hz", 1.0, key="measurements.2")
    assert err.value.key == "measurements.2.kind"
    with pytest.raises(InputError, match="non-zero") as err:
        meas.Measurement("dd_phase", 0.01, baseline_b=(0, 0, 0), key="measurements.1")
    assert err.value.key == "measurements.1.baseline_b"
    with pytest.raises(InputError, match="lines of sight") as err:
        meas.rows(
            error_model.ALIGN12, seg, meas.Measurement("dd_phase", 0.01, baseline_b=(0, 1, 0))
        )
    assert err.value.key == "measurement.los_n"
    with pytest.raises(InputError, match="needs states"):
        meas.rows(error_model.ALIGN12, seg, meas.Measurement("pseudorange", 3.0, los_n=LOS))
    with pytest.raises(InputError, match="sigma"):
        meas.Measurement("velocity", 0.0)
    # geometry from the segment when the measurement has none
    seg = _segment(los_n=LOS[:3])
    H, _ = meas.rows(
        error_model.ALIGN12, seg, meas.Measurement("dd_phase", 0.01, baseline_b=(0, 1, 0))
    )
    assert H.shape == (2, 12)
