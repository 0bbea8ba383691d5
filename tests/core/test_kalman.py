"""Kalman numerics against closed forms, a brute-force integral, and filter consistency."""

import numpy as np
import pytest
from scipy import integrate, linalg

from inins.core import kalman


def test_van_loan_double_integrator_closed_form():
    # x = [position, velocity], white acceleration of density q (m^2/s^3)
    q, dt = 0.37, 0.8
    F = np.array([[0.0, 1.0], [0.0, 0.0]])
    Phi, Qd = kalman.discretize(F, np.diag([0.0, q]), dt)
    np.testing.assert_allclose(Phi, [[1.0, dt], [0.0, 1.0]], rtol=1e-12, atol=1e-15)
    expected = q * np.array([[dt**3 / 3, dt**2 / 2], [dt**2 / 2, dt]])
    np.testing.assert_allclose(Qd, expected, rtol=1e-12)


def test_van_loan_gauss_markov_closed_form():
    # x' = -x/tau + w, stationary variance sigma^2 needs density 2 sigma^2 / tau
    sigma, tau, dt = 3.0e-3, 120.0, 7.5
    Phi, Qd = kalman.discretize([[-1.0 / tau]], [[2.0 * sigma**2 / tau]], dt)
    np.testing.assert_allclose(Phi[0, 0], np.exp(-dt / tau), rtol=1e-12)
    np.testing.assert_allclose(Qd[0, 0], sigma**2 * (1.0 - np.exp(-2.0 * dt / tau)), rtol=1e-12)


def test_van_loan_matches_quadrature_and_stacks():
    rng = np.random.default_rng(1)
    F = rng.normal(size=(4, 4)) * 0.3
    G = rng.normal(size=(4, 2))
    Qc = G @ G.T
    dt = 0.9
    Phi, Qd = kalman.discretize(F, Qc, dt)
    np.testing.assert_allclose(Phi, linalg.expm(F * dt), rtol=1e-12)

    def integrand(s):
        E = linalg.expm(F * s)
        return E @ Qc @ E.T

    Qd_quad, _ = integrate.quad_vec(integrand, 0.0, dt, epsabs=1e-14, epsrel=1e-13)
    np.testing.assert_allclose(Qd, Qd_quad, rtol=1e-10, atol=1e-13)
    # a stack on the leading axis gives the same answers item by item
    Phis, Qds = kalman.discretize(np.stack([F, 2 * F]), np.stack([Qc, Qc]), dt)
    np.testing.assert_allclose(Phis[0], Phi, rtol=1e-14)
    np.testing.assert_allclose(Qds[1], kalman.discretize(2 * F, Qc, dt)[1], rtol=1e-14)


def test_first_order_is_first_order():
    F, Qc = np.array([[-0.5]]), np.array([[2.0]])
    Phi, Qd = kalman.discretize(F, Qc, 0.1, method="first_order")
    assert Phi[0, 0] == pytest.approx(0.95, abs=1e-15)
    assert Qd[0, 0] == pytest.approx(0.2, abs=1e-15)
    # local error O(dt^2): halving dt quarters it
    errs = [
        abs(kalman.discretize(F, Qc, dt, "first_order")[0][0, 0] - np.exp(-0.5 * dt))
        for dt in (0.1, 0.05)
    ]
    assert errs[0] / errs[1] == pytest.approx(4.0, rel=0.05)
    with pytest.raises(ValueError, match="method"):
        kalman.discretize(F, Qc, 0.1, method="euler")


def test_predict():
    Phi = np.array([[1.0, 2.0], [0.0, 1.0]])
    x, P = kalman.predict([1.0, 3.0], np.diag([4.0, 1.0]), Phi, np.diag([0.0, 0.5]))
    np.testing.assert_allclose(x, [7.0, 3.0])
    np.testing.assert_allclose(P, [[8.0, 2.0], [2.0, 1.5]])


def test_joseph_equals_standard_form_when_well_conditioned():
    rng = np.random.default_rng(2)
    A = rng.normal(size=(5, 5))
    P = A @ A.T + np.eye(5)
    H = rng.normal(size=(2, 5))
    R = np.array([[0.5, 0.1], [0.1, 0.3]])
    x0, z = rng.normal(size=5), rng.normal(size=2)
    x, Pj, y, S = kalman.update(x0, P, z, H, R)
    S_ref = H @ P @ H.T + R
    K = P @ H.T @ np.linalg.inv(S_ref)
    np.testing.assert_allclose(S, S_ref, rtol=1e-13)
    np.testing.assert_allclose(y, z - H @ x0, rtol=1e-13)
    np.testing.assert_allclose(x, x0 + K @ y, rtol=1e-12)
    np.testing.assert_allclose(Pj, P - K @ H @ P, rtol=1e-11, atol=1e-12)


def test_joseph_stays_positive_definite_when_ill_conditioned():
    # Two nearly collinear, very precise measurements of a unit prior (the classic
    # Dyer-McReynolds example): here the conventional P - K H P has a negative
    # eigenvalue. The exact posterior (I + H^T H / d^2)^-1 has eigenvalues
    # 1 and 1 / (1 + mu / d^2) for the eigenvalues mu of the 2x2 Gram matrix.
    d = 1e-6
    H = np.array([[1.0, 1.0, 1.0], [1.0, 1.0, 1.0 + d]])
    _, P, _, _ = kalman.update(np.zeros(3), np.eye(3), np.zeros(2), H, d * d * np.eye(2))
    assert np.array_equal(P, P.T)
    np.linalg.cholesky(P)  # raises if not positive definite
    K = H.T @ np.linalg.inv(H @ H.T + d * d * np.eye(2))
    assert np.linalg.eigvalsh(np.eye(3) - K @ H).min() < -1e-6  # conventional form fails
    trace, det = 6.0 + 2.0 * d + d * d, 2.0 * d * d
    mu_big = 0.5 * (trace + np.sqrt(trace * trace - 4.0 * det))
    exact = np.sort([1.0 / (1.0 + mu_big / d**2), 1.0 / (1.0 + det / mu_big / d**2), 1.0])
    eig = np.linalg.eigvalsh(P)
    np.testing.assert_allclose(eig[1:], exact[1:], rtol=1e-6)
    np.testing.assert_allclose(eig[0], exact[0], rtol=1e-2)  # d^2/6 = 1.7e-13


def test_random_constant_posterior_closed_form():
    # x ~ N(0, s2); z_k = x + v_k, v_k ~ N(0, r): P_n = s2 / (1 + n s2 / r),
    # x_n = sum(z) / (n + r / s2)
    s2, r = 4.0, 0.25
    rng = np.random.default_rng(3)
    z = 1.3 + rng.normal(scale=np.sqrt(r), size=60)
    x, P = np.zeros(1), np.array([[s2]])
    for n in range(1, len(z) + 1):
        x, P, _, _ = kalman.update(x, P, z[n - 1 : n], [[1.0]], [[r]])
        assert P[0, 0] == pytest.approx(s2 / (1.0 + n * s2 / r), rel=1e-12)
        assert x[0] == pytest.approx(z[:n].sum() / (n + r / s2), rel=1e-12)


def _run_cv_filter(rng, steps, r_true, r_filter, q=0.02, dt=1.0):
    """Constant-velocity target, position measured; returns NIS series and final NEES."""
    F = np.array([[0.0, 1.0], [0.0, 0.0]])
    Phi, Qd = kalman.discretize(F, np.diag([0.0, q]), dt)
    L = np.linalg.cholesky(Qd)
    H, R = np.array([[1.0, 0.0]]), np.array([[r_filter]])
    truth = np.array([0.0, 1.0])
    P = np.diag([10.0, 1.0])
    x = truth + np.linalg.cholesky(P) @ rng.normal(size=2)
    nis = np.empty(steps)
    for k in range(steps):
        truth = Phi @ truth + L @ rng.normal(size=2)
        x, P = kalman.predict(x, P, Phi, Qd)
        z = H @ truth + np.sqrt(r_true) * rng.normal(size=1)
        x, P, y, S = kalman.update(x, P, z, H, R)
        nis[k] = kalman.nis(y, S)
    return nis, kalman.nees(x - truth, P)


def test_nis_of_consistent_filter_averages_to_measurement_dimension():
    rng = np.random.default_rng(4)
    nis, _ = _run_cv_filter(rng, 2000, r_true=1.0, r_filter=1.0)
    low, high = kalman.consistency_bounds(1, len(nis), probability=0.99)
    assert low < nis.mean() < high  # bounds about 1 +- 0.08
    # the same test rejects a filter that trusts its measurements 4x too much
    bad, _ = _run_cv_filter(np.random.default_rng(4), 2000, r_true=1.0, r_filter=0.25)
    assert bad.mean() > high


def test_nees_monte_carlo_averages_to_state_dimension():
    rng = np.random.default_rng(5)
    final = np.array([_run_cv_filter(rng, 15, 1.0, 1.0)[1] for _ in range(300)])
    low, high = kalman.consistency_bounds(2, len(final), probability=0.99)
    assert low < final.mean() < high


def test_nis_nees_closed_forms_and_stacks():
    S = np.array([[4.0, 0.0], [0.0, 9.0]])
    assert kalman.nis([2.0, 3.0], S) == pytest.approx(2.0, rel=1e-15)
    e = np.array([[2.0, 0.0], [0.0, 6.0]])
    np.testing.assert_allclose(kalman.nees(e, np.stack([S, S])), [1.0, 4.0], rtol=1e-15)


def test_gate_threshold_is_chi_square():
    S = np.array([[4.0]])  # sigma = 2
    assert kalman.gate([2.0 * 2.99], S) == (True, pytest.approx(2.99**2))
    assert kalman.gate([2.0 * 3.01], S)[0] is False  # 0.9973 is 3 sigma in 1 dof
    # 3 dof: threshold chi2.ppf(0.9973, 3) = 14.156
    assert kalman.gate(np.full(3, np.sqrt(14.15 / 3)), np.eye(3))[0] is True
    assert kalman.gate(np.full(3, np.sqrt(14.17 / 3)), np.eye(3))[0] is False
