"""System-level calibration: a Kalman filter on the navigation errors of a rotation
sequence (known position, zero velocity), estimating all 21 sensor terms at once.

The unit navigates the whole sequence in stationary mode (position held, velocity
integrated without Coriolis feedback, as :func:`inins.calibration.navigate.navigate`),
from a levelling + gyrocompass alignment on the first position. Its computed velocity is
then the velocity error, measured against zero at the end of every filter step. The
error model (:mod:`inins.core.error_model`, stationary navigation, no transport rate)::

    dv'  = f_n x phi + C_nb (b_a + diag(f_b) s_a + A_a f_b)
    phi' = -w_ie x phi - C_nb (b_g + diag(w_b) s_g + B_g w_b)

is linear time-invariant in ``(dv, phi)`` (at rest on the table ``f_n = -g_n`` and
``w_ie`` are constant in n) with a time-varying input matrix ``B(t)`` in the 21 terms.
Over a step of ``T`` s the transition is exact,
``x(T) = e^{AT} x(0) + (sum_j e^{A tau_j} B_j) theta``, the sum over the samples of the
step with ``B_j`` built from the computed attitude at mid-sample and the increments
(``f_b dt = dv_j``, ``w_b dt = dtheta_j``), ``e^{A tau}`` to third order (``A^4 = 0``
here up to ``W^2`` terms). White sensor noise enters as process noise
(:func:`inins.core.error_model.noise_matrix`).

The linear model is first order in the navigation errors; the filter is therefore run
again on the data compensated with the terms found (:func:`imu_model.compensate`), three
passes in all, so that the terms converge like Gauss-Newton iterations and the second-
order error of a pass does not remain. The 1-sigma is the filter's final covariance.
Only units whose gyros sense the Earth rate well against their bias can gyrocompass the
initial heading (navigation grade).
"""

from dataclasses import dataclass

import numpy as np

from inins.calibration import alignment, imu_model
from inins.core import earth, rotation, strapdown

NAMES = imu_model.SENSOR_TERMS
_PAIRS_A = [("xyz".index(n[-2]), "xyz".index(n[-1])) for n in NAMES if n.startswith("ma_")]
_PAIRS_G = [("xyz".index(n[-2]), "xyz".index(n[-1])) for n in NAMES if n.startswith("mg_")]
PRIOR = {"ba": 1e-2, "bg": 1e-4, "sa": 1e-2, "sg": 1e-2, "ma": 1e-2, "mg": 1e-2}
"""1-sigma of the filter's prior per term kind (SI): wide, so the data decide."""


@dataclass(frozen=True)
class SystemFit:
    """Result of :func:`calibrate`.

    Attributes
    ----------
    names : tuple of str
    values, sigma : ndarray, shape (21,)
    covariance : ndarray, shape (21, 21)
    time : ndarray, shape (k,)
        Ends of the filter steps (s from the start).
    innovation : ndarray, shape (k, 3)
        Measured velocity minus the filter's prediction at each step, last pass (m/s).
    velocity_before, velocity_after : ndarray, shape (k, 3)
        Computed velocity (the velocity error) with the raw data and after the final
        compensation (m/s).
    passes : int
    """

    names: tuple
    values: np.ndarray
    sigma: np.ndarray
    covariance: np.ndarray
    time: np.ndarray
    innovation: np.ndarray
    velocity_before: np.ndarray
    velocity_after: np.ndarray
    passes: int

    @property
    def terms(self):
        return imu_model.ImuTerms(dict(zip(self.names, self.values, strict=True)))


def _navigate(dtheta, dv, dt, lla, n_align):
    aligned = alignment.align_stationary(dtheta[:n_align], dv[:n_align], dt, lla[0])
    state = strapdown.NavState.from_attitude(aligned.mat_nb, np.zeros(3), lla)
    _, series = strapdown.integrate(
        state, dtheta, dv, dt, fixed_position=True, zero_velocity=True, decimation=1
    )
    return aligned.mat_nb, series


def _input_sums(mat_mid, dtheta, dv, dt, m, a_mat):
    """``sum_j e^{A tau_j} B_j`` for every step, shape (k, 6, 21)."""
    k = mat_mid.shape[0] // m
    tau = (m - np.arange(m) - 0.5) * dt
    a2 = a_mat @ a_mat
    weights = np.stack([np.ones(m), tau, tau**2 / 2.0, tau**3 / 6.0])  # (4, m)
    mats = np.stack([np.eye(6), a_mat, a2, a2 @ a_mat])  # (4, 6, 6)
    c = mat_mid[: k * m].reshape(k, m, 3, 3)
    # weighted sums over the samples of each step, one batched matrix product each
    c_sum = (c.reshape(k, m, 9).transpose(0, 2, 1) @ weights.T).reshape(k, 3, 3, 4)
    b = np.zeros((4, k, 6, 21))
    for sensor, u, rows, sign in ((0, dv, slice(0, 3), 1.0), (1, dtheta, slice(3, 6), -1.0)):
        u = u[: k * m].reshape(k, m, 3)
        prod = c[..., :, :, None] * u[:, :, None, None, :]  # C[a, i] u_l: (k, m, 3, 3, 3)
        cu = (prod.reshape(k, m, 27).transpose(0, 2, 1) @ weights.T).reshape(k, 3, 3, 3, 4)
        cu = np.moveaxis(cu, -1, 0)  # (4, k, a, i, l)
        pairs = _PAIRS_A if sensor == 0 else _PAIRS_G
        col_bias = 3 * sensor  # ba 0-2, bg 3-5
        col_scale = 6 + 3 * sensor  # sa 6-8, sg 9-11
        col_mis = 12 if sensor == 0 else 15  # ma 12-14, mg 15-20
        b[:, :, rows, col_bias : col_bias + 3] = sign * dt * np.moveaxis(c_sum, -1, 0)
        for i in range(3):
            b[:, :, rows, col_scale + i] = sign * cu[:, :, :, i, i]
        for p, (i, l) in enumerate(pairs):
            b[:, :, rows, col_mis + p] = sign * cu[:, :, :, i, l]
    return np.einsum("pxy,pkyz->kxz", mats, b)


def _kalman(gamma, e_mat, qd, vel, r, p0):
    """The 27-state filter; returns the estimate, covariance and innovations."""
    n = 27
    x = np.zeros(n)
    p = np.diag(p0**2)
    phi = np.eye(n)
    phi[:6, :6] = e_mat
    q = np.zeros((n, n))
    q[:6, :6] = qd
    h = np.zeros((3, n))
    h[:, :3] = np.eye(3)
    rr = np.eye(3) * r**2
    innov = np.empty((gamma.shape[0], 3))
    eye = np.eye(n)
    for k in range(gamma.shape[0]):
        phi[:6, 6:] = gamma[k]
        x = phi @ x
        p = phi @ p @ phi.T + q
        nu = vel[k] - x[:3]
        innov[k] = nu
        s = p[:3, :3] + rr
        gain = np.linalg.solve(s, p[:3, :]).T
        x = x + gain @ nu
        ikh = eye - gain @ h
        p = ikh @ p @ ikh.T + gain @ rr @ gain.T
        p = 0.5 * (p + p.T)
    return x, p, innov


def calibrate(dtheta, dv, dt, lla, n_align, step, arw, vrw, vel_sigma=1e-4, passes=3):
    """System-level calibration of a rotation sequence (module docstring).

    Parameters
    ----------
    dtheta, dv : ndarray, shape (n, 3)
        Raw increments (rad, m/s), the table at rest at its centre between and during
        the rotations.
    dt : float
    lla : ndarray, shape (3,)
    n_align : int
        Samples of the first position used for the alignment.
    step : int
        Samples per filter step.
    arw, vrw : float
        White noise (rad/sqrt(s), m/s/sqrt(s)), process noise of the filter.
    vel_sigma : float
        1-sigma of the zero-velocity measurement (m/s): the table's vibration and the
        velocity quantization.
    passes : int
        Filter runs, each on the data compensated with the terms found so far.
    """
    f_n = -earth.gravity_n(lla[0], lla[2])
    w_ie = earth.rate_ie_n(lla[0])
    a_mat = np.zeros((6, 6))
    a_mat[:3, 3:] = rotation.skew(f_n)
    a_mat[3:, 3:] = -rotation.skew(w_ie)
    t_step = step * dt
    from scipy.linalg import expm

    e_mat = expm(a_mat * t_step)
    qc = np.diag(np.r_[np.full(3, vrw**2), np.full(3, arw**2)])
    qd = (
        qc * t_step
        + (a_mat @ qc + qc @ a_mat.T) * t_step**2 / 2.0
        + a_mat @ qc @ a_mat.T * t_step**3 / 3.0
    )
    p0 = np.r_[np.zeros(3), np.full(3, 1e-3), [PRIOR[n[:2]] for n in NAMES]]
    p0[:3] = 1e-9
    values = np.zeros(21)
    k = dtheta.shape[0] // step
    before = None
    cov = None
    innov = None
    for _ in range(passes):
        terms = imu_model.ImuTerms(dict(zip(NAMES, values, strict=True)))
        th, vv = imu_model.compensate(dtheta, dv, dt, terms)
        mat0, series = _navigate(th, vv, dt, lla, n_align)
        mats = series.mat_nb()
        vel = series.vel_n[step - 1 : k * step : step]
        if before is None:
            before = vel
        mid_q = np.concatenate([rotation.quat_from_mat(mat0)[None], series.quat_nb[:-1]])
        mid_q = mid_q + series.quat_nb
        mid = rotation.mat_from_quat(mid_q / np.linalg.norm(mid_q, axis=1, keepdims=True))
        del mats
        gamma = _input_sums(mid, th, vv, dt, step, a_mat)
        x, p, innov = _kalman(gamma, e_mat, qd, vel, vel_sigma, p0)
        values = values + x[6:]
        cov = p[6:, 6:]
    terms = imu_model.ImuTerms(dict(zip(NAMES, values, strict=True)))
    th, vv = imu_model.compensate(dtheta, dv, dt, terms)
    _, series = _navigate(th, vv, dt, lla, n_align)
    after = series.vel_n[step - 1 : k * step : step]
    return SystemFit(
        NAMES,
        values,
        np.sqrt(np.diag(cov)),
        cov,
        t_step * (np.arange(k) + 1),
        innov,
        before,
        after,
        passes,
    )
