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
again on the data compensated with the terms found (:func:`imu_model.compensate`), and
from the initial attitude corrected by the filter's estimate of its error, so that the
terms converge like Gauss-Newton iterations and the second-order error of a pass does
not remain. The initial attitude error ``phi_0`` is carried as three constant states (a
copy of ``phi`` at the start, fully correlated with it): the filter estimates it with
the terms, and the next pass starts from ``exp([phi_0 x]) C_nb``. A gyrocompass heading
is only as good as ``ARW / (W cos lat sqrt(T))`` (4 deg for a MEMS gyro of 0.1
deg/sqrt(h) over 60 s): kept as the start of every pass it would leak, through the
second-order terms the linear model leaves out, into the accelerometer scale factors;
estimated and corrected it does not. Passes continue until the correction of the
attitude and of every term is below a hundredth of its 1-sigma (at most
:data:`MAX_PASSES`). The 1-sigma is the filter's final covariance.

What the sequence determines is decided from the filter's own information (its
posterior precision less its prior's, in units of the prior; a term the data alone fix
to less than a tenth of its prior 1-sigma, information 99, is resolved:
:func:`inins.calibration.verdict.from_information`): a yaw-only or level-only
sequence leaves combinations of terms free, named, and their terms are not separable
(no sigma), instead of a sigma sitting at the prior.
"""

from dataclasses import dataclass, replace

import numpy as np

from inins.calibration import alignment, imu_model, verdict
from inins.calibration.verdict import Verdict
from inins.core import earth, jit, rotation, strapdown

NAMES = imu_model.SENSOR_TERMS
_PAIRS_A = [("xyz".index(n[-2]), "xyz".index(n[-1])) for n in NAMES if n.startswith("ma_")]
_PAIRS_G = [("xyz".index(n[-2]), "xyz".index(n[-1])) for n in NAMES if n.startswith("mg_")]
PRIOR = {"ba": 1e-2, "bg": 1e-4, "sa": 1e-2, "sg": 1e-2, "ma": 1e-2, "mg": 1e-2}
"""1-sigma of the filter's prior per term kind (SI): wide, so the data decide."""
PRIOR_TILT, PRIOR_HEADING = 1e-2, 0.1
"""1-sigma of the prior initial tilt and heading error (rad): wide against what the
levelling (a 1 mg bias: 1e-4 rad) and a gyrocompass left by the previous pass give."""
MIN_INFORMATION = 99.0
"""Data information (in units of the prior) below which a direction is not resolved:
its 1-sigma would stay above a tenth of the prior's."""
NULL_INFORMATION = 1e-6
"""Data information (in units of the prior) at or below which a direction is in the
null space (the rounding of ``P^-1 - P0^-1`` is ~1e-12)."""
MAX_PASSES = 6
N_STATES = 30
"""dv 3, phi 3, the 21 terms, phi_0 3."""


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
    verdict : inins.calibration.verdict.Verdict
        What the sequence resolves (the filter's data information, module docstring).
    attitude0 : ndarray, shape (3, 3)
        Initial attitude ``C_nb`` found (the alignment corrected by ``phi_0``).
    alignment_correction : ndarray, shape (3,)
        ``phi_0`` of all passes together: the correction of the gyrocompass alignment
        (rad, NED).
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
    verdict: Verdict = None
    attitude0: np.ndarray = None
    alignment_correction: np.ndarray = None

    @property
    def terms(self):
        return imu_model.ImuTerms(dict(zip(self.names, self.values, strict=True)))


def _navigate(dtheta, dv, dt, lla, mat0):
    """Stationary navigation from ``mat0`` (the attitude at the first sample)."""
    state = strapdown.NavState.from_attitude(mat0, np.zeros(3), lla)
    _, series = strapdown.integrate(
        state, dtheta, dv, dt, fixed_position=True, zero_velocity=True, decimation=1
    )
    return series


def error_dynamics(lla):
    """``A`` (6, 6) of the stationary error model (module docstring) in ``(dv, phi)``:
    ``dv' = f_n x phi``, ``phi' = -w_ie x phi`` (NED, at rest)."""
    f_n = -earth.gravity_n(lla[0], lla[2])
    w_ie = earth.rate_ie_n(lla[0])
    a_mat = np.zeros((6, 6))
    a_mat[:3, 3:] = rotation.skew(f_n)
    a_mat[3:, 3:] = -rotation.skew(w_ie)
    return a_mat


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


def prior(tilt=PRIOR_TILT, heading=PRIOR_HEADING):
    """Prior covariance (30, 30): dv (known zero), phi, the terms (:data:`PRIOR`),
    and phi_0 equal to phi at the start (fully correlated)."""
    s_phi = np.array([tilt, tilt, heading])
    p0 = np.zeros((N_STATES, N_STATES))
    p0[:3, :3] = np.eye(3) * 1e-18
    p0[3:6, 3:6] = p0[27:, 27:] = p0[3:6, 27:] = p0[27:, 3:6] = np.diag(s_phi**2)
    p0[6:27, 6:27] = np.diag([PRIOR[n[:2]] ** 2 for n in NAMES])
    return p0


def data_verdict(p_post, p0):
    """What the data resolve of the 21 terms: information ``P^-1 - P0^-1`` of the terms'
    marginal (the prior is independent of everything else), scaled by the prior 1-sigma,
    directions below :data:`MIN_INFORMATION` unresolved."""
    s0 = np.sqrt(np.diag(p0))
    post = p_post / np.outer(s0, s0)
    info = np.linalg.inv(0.5 * (post + post.T)) - np.eye(s0.size)
    v = verdict.from_information(
        info / np.outer(s0, s0),
        NAMES,
        s0,
        rel_tol=0.0,
        min_information=MIN_INFORMATION,
        abs_tol=NULL_INFORMATION,
    )
    # the covariance is the filter's own (prior included) on the separable terms
    cov = p_post.copy()
    cov[~v.separable, :] = np.nan
    cov[:, ~v.separable] = np.nan
    sigma = np.where(v.separable, np.sqrt(np.diag(p_post)), np.inf)
    return replace(v, covariance=cov, sigma=sigma)


def _discretised(a_mat, t_step, arw, vrw):
    """Transition ``e^{AT}`` and process noise (third order in T) of one filter step."""
    from scipy.linalg import expm

    qc = np.diag(np.r_[np.full(3, vrw**2), np.full(3, arw**2)])
    qd = (
        qc * t_step
        + (a_mat @ qc + qc @ a_mat.T) * t_step**2 / 2.0
        + a_mat @ qc @ a_mat.T * t_step**3 / 3.0
    )
    return expm(a_mat * t_step), qd


def _one_pass(dtheta, dv, dt, lla, mat0, step, a_mat, e_mat, qd, r, p0):
    """The filter along the record, its velocity and tilt errors fed back at every step.

    The filter predicts and updates with the velocity at the end of each step, and the
    navigation is corrected by the estimated velocity and tilt errors (north and east
    components of ``phi``), which are then zero; the heading error, the terms and
    ``phi_0`` stay states. Fed back, the tilt stays at the filter's 1-sigma, so the
    second-order errors the linear model leaves out (``g |phi|^2 / 2`` in the vertical
    channel: ppm of scale factor for a tilt that wanders by milliradians under a MEMS
    gyro's angle random walk) do not build up. The heading is not fed back: early in the
    record it is poorly observed, and its noisy estimate, fed into the navigation, would
    itself be a second-order error (measured: gyro-bias errors of 7 sigma on a
    navigation-grade unit); the passes correct it through ``phi_0``.

    The fed-back navigation is the open-loop one (from ``mat0``, one pass of
    :func:`inins.core.strapdown.integrate`) turned by the corrections so far: with
    ``C_cl = Q C_ol``, ``Q`` is carried by the Earth's rotation between corrections
    (``Q <- E Q E^T``, ``E = exp(-[w_ie x] T)``) and turned by each (``Q <- exp([phi x])
    Q``), the velocity grows by ``Q (dv_ol - g_n T) + g_n T`` over a step (``Q`` held
    over the step: an error of ``W T |phi| g T``, 1e-6 m/s) and the input matrix of a
    step is ``diag(Q, Q)`` times the open-loop one.

    Returns
    -------
    x : ndarray, shape (30,)
        Final estimate (``dv`` and the tilt zero: fed back).
    p : ndarray, shape (30, 30)
    innov : ndarray, shape (k, 3)
    """
    k_steps = dtheta.shape[0] // step
    series = _navigate(dtheta, dv, dt, lla, mat0)
    vel_ol = np.concatenate([np.zeros((1, 3)), series.vel_n[step - 1 : k_steps * step : step]])
    mid_q = np.concatenate([rotation.quat_from_mat(mat0)[None], series.quat_nb[:-1]])
    mid_q = mid_q + series.quat_nb
    mid = rotation.mat_from_quat(mid_q / np.linalg.norm(mid_q, axis=1, keepdims=True))
    gamma = _input_sums(mid, dtheta, dv, dt, step, a_mat)
    g_t = earth.gravity_n(lla[0], lla[2]) * step * dt
    q = np.zeros((N_STATES, N_STATES))
    q[:6, :6] = qd
    x, p = np.zeros(N_STATES), p0.copy()
    innov = np.empty((k_steps, 3))
    _filter(gamma, vel_ol, g_t, np.ascontiguousarray(e_mat), q, float(r), x, p, innov)
    return x, p, innov


@jit.njit(cache=True, nogil=True)
def _filter(gamma, vel_ol, g_t, e_mat, q, r, x, p, innov):
    """The loop of :func:`_one_pass` (its docstring): ``x`` (30,), ``p`` (30, 30) the
    prior in, the estimate out; ``innov`` (k, 3) filled. Joseph-form update."""
    n = x.shape[0]
    k_steps = gamma.shape[0]
    earth_turn = e_mat[3:6, 3:6].copy()  # exp(-[w_ie x] T)
    phi = np.eye(n)
    phi[:6, :6] = e_mat
    turn = np.eye(3)
    vel = np.zeros(3)
    rr = np.eye(3) * r * r
    eye = np.eye(n)
    for k in range(k_steps):
        vel = vel + turn @ (vel_ol[k + 1] - vel_ol[k] - g_t) + g_t
        phi[:3, 6:27] = turn @ gamma[k, :3]
        phi[3:6, 6:27] = turn @ gamma[k, 3:]
        x[:] = phi @ x
        p[:, :] = phi @ p @ phi.T + q
        nu = vel - x[:3]
        innov[k] = nu
        gain = np.linalg.solve(p[:3, :3] + rr, p[:3, :]).T
        x[:] = x + gain @ nu
        ikh = eye.copy()
        ikh[:, :3] -= gain
        p[:, :] = ikh @ p @ ikh.T + gain @ rr @ gain.T
        p[:, :] = 0.5 * (p + p.T)
        # feedback: mat_nb = (I - [phi x]) true, so true = exp([phi x]) mat_nb
        vel = vel - x[:3]
        tilt = np.array([x[3], x[4], 0.0])
        turn = earth_turn @ _rotation(tilt) @ turn @ earth_turn.T
        x[:5] = 0.0


@jit.njit(cache=True, nogil=True)
def _rotation(v):
    """``exp([v x])`` (Rodrigues)."""
    a = np.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    k = np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])
    if a < 1e-8:
        return np.eye(3) + k + 0.5 * (k @ k)
    return np.eye(3) + np.sin(a) / a * k + (1.0 - np.cos(a)) / (a * a) * (k @ k)


def initial_attitude(dtheta, dv, dt, lla, holds, iterations=3):
    """Gyro bias and initial attitude from the static holds (a gyrocompass of every
    position): levelled on the first hold, then ``w_k = b + C_bn,k w_ie`` solved for
    ``b`` and ``(cos psi_0, sin psi_0)`` by least squares, ``C_bn,k`` the attitude at
    hold ``k`` navigated from heading ``psi_0`` with the bias ``b`` removed, repeated
    ``iterations`` times from the bias of the mean of the holds. Unlike a gyrocompass
    of the first position it does not need the bias below the Earth rate (a MEMS gyro).

    Parameters
    ----------
    holds : sequence of (int, int)
        Samples [start, stop) of the holds, the first at the start of the record.

    Returns
    -------
    bias : ndarray, shape (3,)
        rad/s.
    mat0 : ndarray, shape (3, 3)
        ``C_nb`` at the first sample.
    """
    holds = [(int(a), int(b)) for a, b in holds if b > a]
    means = np.array([dtheta[a:b].sum(axis=0) / ((b - a) * dt) for a, b in holds])
    weights = np.array([b - a for a, b in holds], float)
    bias = weights @ means / weights.sum()
    a0, b0 = holds[0]
    f0 = dv[a0:b0].sum(axis=0) / ((b0 - a0) * dt)
    level = alignment.level(f0)
    w = earth.rate_ie_n(lla[0])
    heading = 0.0
    mids = np.array([(a + b) // 2 for a, b in holds])
    for _ in range(iterations):
        mat0 = rotation.axis_rotation(2, heading) @ level
        series = _navigate(dtheta - bias * dt, dv, dt, lla, mat0)
        mats = rotation.axis_rotation(2, -heading) @ series.mat_nb()[mids - 1]
        c_bn = np.swapaxes(mats, 1, 2)
        a = np.zeros((3 * len(holds), 5))
        a[:, :3] = np.tile(np.eye(3), (len(holds), 1))
        a[:, 3] = (c_bn[:, :, 0] * w[0]).ravel()
        a[:, 4] = (-c_bn[:, :, 1] * w[0]).ravel()
        rhs = (means - c_bn[:, :, 2] * w[2]).ravel()
        x = np.linalg.lstsq(a, rhs, rcond=None)[0]
        bias, heading = x[:3], float(np.arctan2(x[4], x[3]))
    return bias, rotation.axis_rotation(2, heading) @ level


def _converged(x, p, found, fraction):
    """Every separable term's and the initial attitude's correction within ``fraction``
    sigma (a direction the data do not resolve moves with the prior, not the data)."""
    small = np.abs(x[6:]) <= fraction * np.sqrt(np.diag(p)[6:])
    small[:21] |= ~found.separable
    return bool(np.all(small))


def calibrate(
    dtheta, dv, dt, lla, n_align, step, arw, vrw, vel_sigma=1e-4, passes=None, holds=None
):
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
    passes : int, optional
        Filter runs (each on the data compensated with the terms found so far, from the
        corrected initial attitude); default: until converged (module docstring).
    holds : sequence of (int, int), optional
        The static holds (samples [start, stop)): the first pass starts from their
        gyrocompass (:func:`initial_attitude`) instead of the first position's.

    Raises
    ------
    ValueError
        The passes do not converge (the last one still corrects a term or the initial
        attitude by more than its 1-sigma).
    """
    a_mat = error_dynamics(lla)
    t_step = step * dt
    e_mat, qd = _discretised(a_mat, t_step, arw, vrw)
    p0 = prior()
    values = np.zeros(21)
    if holds is None:
        mat0 = alignment.align_stationary(dtheta[:n_align], dv[:n_align], dt, lla[0]).mat_nb
    else:
        values[3:6], mat0 = initial_attitude(dtheta, dv, dt, lla, holds)
    start = mat0
    before = p = innov = x = None
    done = 0
    for done in range(1, (passes or MAX_PASSES) + 1):
        terms = imu_model.ImuTerms(dict(zip(NAMES, values, strict=True)))
        th, vv = imu_model.compensate(dtheta, dv, dt, terms)
        x, p, innov = _one_pass(th, vv, dt, lla, mat0, step, a_mat, e_mat, qd, vel_sigma, p0)
        if before is None:
            before = _navigate(dtheta, dv, dt, lla, mat0).vel_n[step - 1 :: step]
        values = values + x[6:27]
        mat0 = rotation.mat_from_rotvec(x[27:]) @ mat0
        found = data_verdict(p[6:27, 6:27], p0[6:27, 6:27])
        if passes is None and done >= 2 and _converged(x, p, found, 0.01):
            break
    if passes is None and not _converged(x, p, found, 1.0):
        z = np.abs(x[6:]) / np.sqrt(np.diag(p)[6:])
        z[:21][~found.separable] = 0.0
        worst = int(np.argmax(z))
        what = (*NAMES, "initial tilt x", "initial tilt y", "initial heading")[worst]
        raise ValueError(
            f"the filter passes do not converge: after {done} the last still corrects "
            f"{what} by {z[worst]:.3g} sigma (the gyros too noisy or biased for the "
            "linear model from this alignment)"
        )
    terms = imu_model.ImuTerms(dict(zip(NAMES, values, strict=True)))
    th, vv = imu_model.compensate(dtheta, dv, dt, terms)
    k = dtheta.shape[0] // step
    after = _navigate(th, vv, dt, lla, mat0).vel_n[step - 1 : k * step : step]
    before = before[:k]
    return SystemFit(
        NAMES,
        values,
        found.sigma,
        found.covariance,
        t_step * (np.arange(k) + 1),
        innov,
        before,
        after,
        done,
        found,
        mat0,
        rotation.rotvec_from_mat(mat0 @ start.T),
    )
