"""The compiled epoch helpers equal their core counterparts."""

import numpy as np

from inins.core import earth, error_model, rotation, strapdown
from inins.core.units import DEG
from inins.ekf import step
from inins.ekf.filter import correct


def test_strapdown_chunks_equal_integrate():
    rng = np.random.default_rng(0)
    state = strapdown.NavState.from_attitude(
        [0.1, -0.05, 2.0], [50.0, -20.0, 1.0], [0.6, 2.0, 500.0]
    )
    dtheta = 1e-4 * rng.normal(size=(1000, 3))
    dv = np.array([0.0, 0.0, -9.8 * 0.005]) + 1e-3 * rng.normal(size=(1000, 3))
    end, series = strapdown.integrate(state, dtheta, dv, 0.005)
    nav = strapdown.FreeInertial(state)
    for lo, hi in ((0, 130), (130, 130), (130, 777), (777, 1000)):
        _, (quat, vel, lla) = nav.run(dtheta[lo:hi], dv[lo:hi], 0.005)
        if hi > lo:
            np.testing.assert_array_equal(quat, series.quat_nb[lo:hi])
            np.testing.assert_array_equal(vel, series.vel_n[lo:hi])
            np.testing.assert_array_equal(lla, series.lla[lo:hi])
    got = nav.state()
    np.testing.assert_array_equal(got.quat_nb, end.quat_nb)
    np.testing.assert_array_equal(got.vel_n, end.vel_n)
    assert got.count == end.count


def test_navigation_helpers_equal_core():
    lla = np.array([37.0 * DEG, 127.0 * DEG, 800.0])
    quat = rotation.quat_from_rotvec([0.3, -0.2, 1.1])
    np.testing.assert_allclose(
        step.mat_en(lla[0], lla[1]), earth.mat_en(lla[0], lla[1]), atol=1e-15
    )
    np.testing.assert_allclose(step.ecef(lla), earth.ecef_from_llh(*lla), rtol=1e-15)
    np.testing.assert_allclose(step.mat_from_quat(quat), rotation.mat_from_quat(quat), atol=1e-15)


def test_correct_inverts_the_error_definitions():
    """``nav (-) e`` of a state with error ``e`` gives the truth back, to second order."""
    lla = np.array([37.0 * DEG, 127.0 * DEG, 800.0])
    mat_nb = rotation.mat_from_euler(0.2, 0.1, 3.0)
    vel = np.array([100.0, -30.0, 2.0])
    e = np.array([30.0, -20.0, 5.0, 0.3, -0.2, 0.1, 1e-4, -2e-4, 5e-4])
    lla_est = error_model.lla_offset(lla, e[0:3])
    mat_est = rotation.mat_from_rotvec(-e[6:9]) @ mat_nb
    quat, vel_c, lla_c = correct(rotation.quat_from_mat(mat_est), vel + e[3:6], lla_est, e)
    np.testing.assert_allclose(error_model.position_error_ned(lla_c, lla), 0.0, atol=1e-3)
    np.testing.assert_allclose(vel_c, vel, atol=1e-12)
    phi = error_model.attitude_error(rotation.mat_from_quat(quat), mat_nb)
    np.testing.assert_allclose(phi, 0.0, atol=1e-12)


def test_compensation_removes_bias_and_misalignment():
    """``(I - M) (M_true w + b - b)`` leaves ``w`` to second order in ``M``."""
    rng = np.random.default_rng(1)
    mg = 1e-4 * rng.normal(size=6)
    ma = 1e-4 * rng.normal(size=3)
    bg, ba = np.array([1e-6, -2e-6, 3e-6]), np.array([1e-3, 2e-3, -1e-3])
    m_g = np.eye(3) + np.array([[0, mg[0], mg[1]], [mg[2], 0, mg[3]], [mg[4], mg[5], 0]])
    m_a = np.eye(3) + np.array([[0, 0, 0], [ma[0], 0, 0], [ma[1], ma[2], 0]])
    w = 0.01 * rng.normal(size=(50, 3))
    f = rng.normal(size=(50, 3))
    dt = 0.005
    out_w, out_f = step.compensate(
        (w @ m_g.T + bg) * dt, (f @ m_a.T + ba) * dt, dt, np.concatenate([ba, bg, ma, mg])
    )
    np.testing.assert_allclose(out_w / dt, w, atol=1e-8 * 0.04)  # |M|^2 |w| ~ 1e-8 * 0.04
    np.testing.assert_allclose(out_f / dt, f, atol=1e-7 * 4)
