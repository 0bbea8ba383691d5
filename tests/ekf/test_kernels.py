"""The compiled per-epoch numerics equal the core reference functions."""

import numpy as np
import pytest

from inins.core import error_model, kalman, rotation
from inins.core.units import DEG
from inins.ekf import kernels


@pytest.mark.parametrize("layout", [error_model.EKF17, error_model.EKF26])
def test_system_and_noise_match_core(layout):
    rng = np.random.default_rng(0)
    for _ in range(5):
        lat, h = rng.uniform(-70, 70) * DEG, rng.uniform(0, 10000)
        vel = rng.normal(scale=100.0, size=3)
        mat_nb = rotation.mat_from_rotvec(rng.normal(size=3))
        f_b, w_b = rng.normal(scale=5.0, size=3), rng.normal(scale=0.1, size=3)
        F = np.zeros((len(layout), len(layout)))
        kernels.system_matrix26(lat, h, vel, f_b, mat_nb, w_b, F)
        ref = error_model.system_matrix(layout, lat, h, vel, mat_nb @ f_b, mat_nb, w_b)
        np.testing.assert_allclose(F, ref, rtol=1e-12, atol=1e-18)
        arw, vrw = np.array([1e-6, 2e-6, 3e-6]), np.array([1e-4, 2e-4, 3e-4])
        Q = np.zeros_like(F)
        kernels.noise26(mat_nb, arw, vrw, np.full(3, 1e-7), np.full(3, 1e-9), 0.1, 0.01, Q)
        ref = error_model.noise_matrix(
            layout,
            mat_nb,
            arw,
            vrw,
            accel_bias_rw=1e-7,
            gyro_bias_rw=1e-9,
            clock_bias_psd=0.1,
            clock_drift_psd=0.01,
        )
        np.testing.assert_allclose(Q, ref, rtol=1e-12, atol=1e-25)


def test_discretisation_close_to_van_loan():
    """Third-order Phi and trapezoidal Qd over 1 s in a 3 deg/s turn at 150 m/s."""
    layout = error_model.EKF26
    mat_nb = rotation.mat_from_euler(30 * DEG, 2 * DEG, 1.0)
    f_b = mat_nb.T @ np.array([0.0, 5.6, -9.8])
    F, Q = np.zeros((26, 26)), np.zeros((26, 26))
    kernels.system_matrix26(
        0.6, 3000.0, np.array([130.0, 75.0, 0.0]), f_b, mat_nb, np.array([0.0, 0.026, 0.045]), F
    )
    kernels.noise26(
        mat_nb, np.full(3, 1e-6), np.full(3, 2e-4), np.zeros(3), np.zeros(3), 0.1, 0.01, Q
    )
    Phi, Qd = np.empty_like(F), np.empty_like(F)
    kernels.discretize(F, Q, 1.0, Phi, Qd)
    Phi_ref, Qd_ref = kalman.discretize(F, Q, 1.0)
    # truncation A^4 / 24: 1.2e-5 of the largest entry (position <- attitude) measured
    np.testing.assert_allclose(Phi, Phi_ref, rtol=0, atol=3e-5 * np.abs(Phi_ref).max())
    np.testing.assert_allclose(np.diag(Qd), np.diag(Qd_ref), rtol=1e-3, atol=1e-30)
    assert layout.size == 26


def test_sequential_update_equals_batch_joseph():
    rng = np.random.default_rng(1)
    n, m = 26, 16
    A = rng.normal(size=(n, n))
    P = A @ A.T + n * np.eye(n)
    H, r = rng.normal(size=(m, n)), rng.uniform(0.5, 2.0, m)
    y0 = rng.normal(size=m)
    x_ref, P_ref, _, _ = kalman.update(np.zeros(n), P, y0, H, np.diag(r))
    x, P_seq = np.zeros(n), P.copy()
    acc, y, s = np.zeros(m, bool), np.empty(m), np.empty(m)
    count = kernels.sequential_update(x, P_seq, H, y0, r, np.inf, acc, y, s)
    assert count == m
    np.testing.assert_allclose(x, x_ref, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(P_seq, P_ref, rtol=1e-9, atol=1e-12)
