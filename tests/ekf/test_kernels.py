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


def _sparse_model(n, moving, seed):
    """``F`` (n, n) with random rows ``moving`` (the rest zero), a symmetric positive
    ``Qc``, ``P``, ``x``."""
    rng = np.random.default_rng(seed)
    F = np.zeros((n, n))
    F[moving] = rng.normal(scale=0.3, size=(len(moving), n))
    F[moving, 3] = 0.0  # a zero inside a moving row
    A, B = rng.normal(size=(n, n)), rng.normal(size=(n, n))
    return F, A @ A.T * 1e-3, B @ B.T + n * np.eye(n), rng.normal(size=n)


# the INS rows (0-8) and the clock bias (15) of EKF26 with two inter-system biases,
# rows spread anywhere, every row, and a constant-states model
MODELS = [(28, [0, 1, 2, 3, 4, 5, 6, 7, 8, 15]), (20, [1, 4, 5, 11, 19]), (9, list(range(9)))]


@pytest.mark.parametrize(("n", "moving"), [*MODELS, (6, [])])
def test_discretisation_is_the_third_order_series(n, moving):
    """The products over the moving rows only equal the dense series to rounding."""
    F, Qc, _, _ = _sparse_model(n, moving, 2)
    dt = 0.8
    Phi, Qd = np.empty_like(F), np.empty_like(F)
    kernels.discretize(F, Qc, dt, Phi, Qd)
    A = F * dt
    Phi_ref = np.eye(n) + A + A @ A / 2 + A @ A @ A / 6
    FQ = F @ Qc
    Qd_ref = Qc * dt + (FQ + FQ.T) * dt**2 / 2 + F @ Qc @ F.T * dt**3 / 3
    np.testing.assert_allclose(Phi, Phi_ref, rtol=0, atol=1e-14 * np.abs(Phi_ref).max())
    np.testing.assert_allclose(Qd, Qd_ref, rtol=0, atol=1e-14 * np.abs(Qd_ref).max())
    assert sorted(kernels.moving_rows(F, 0.0)) == moving


@pytest.mark.parametrize(("n", "moving"), MODELS)
def test_prediction_is_phi_p_phi_t_plus_qd(n, moving):
    """``P + C + C^T + C B^T`` (``B = Phi - I`` over the moving rows) is ``Phi P Phi^T``,
    and the result exactly symmetric."""
    F, Qc, P, x = _sparse_model(n, moving, 3)
    Phi, Qd = np.empty_like(F), np.empty_like(F)
    kernels.discretize(F, Qc, 0.8, Phi, Qd)
    P_ref, x_ref = Phi @ P @ Phi.T + Qd, Phi @ x
    kernels.predict(x, P, Phi, Qd)
    np.testing.assert_allclose(x, x_ref, rtol=0, atol=1e-14 * np.abs(x_ref).max())
    np.testing.assert_allclose(P, P_ref, rtol=0, atol=1e-14 * np.abs(P_ref).max())
    np.testing.assert_array_equal(P, P.T)


def test_sequential_update_of_sparse_rows_equals_batch_joseph():
    """Rows with the zeros of pseudorange and range-rate rows (the update reads only a
    row's nonzero columns) give the batch update, and ``P`` stays exactly symmetric."""
    rng = np.random.default_rng(4)
    n, m = 26, 12
    A = rng.normal(size=(n, n))
    P = A @ A.T + n * np.eye(n)
    H = np.zeros((m, n))
    for i in range(m):  # position and attitude, or velocity too; a clock column
        H[i, : 9 if i % 2 else 3] = rng.normal(size=9 if i % 2 else 3)
        H[i, 6:9] = rng.normal(size=3)
        H[i, 15 + i % 2] = 1.0
    r, y0 = rng.uniform(0.5, 2.0, m), rng.normal(size=m)
    x_ref, P_ref, _, _ = kalman.update(np.zeros(n), P, y0, H, np.diag(r))
    x, P_seq = np.zeros(n), P.copy()
    acc, y, s = np.zeros(m, bool), np.empty(m), np.empty(m)
    assert kernels.sequential_update(x, P_seq, H, y0, r, np.inf, acc, y, s) == m
    np.testing.assert_allclose(x, x_ref, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(P_seq, P_ref, rtol=1e-9, atol=1e-12)
    np.testing.assert_array_equal(P_seq, P_seq.T)
