"""Azimuth of an IMU on a rate table from its accelerometers only: the equivalent linear
transformation (ETT) of 000 §3.1, eqs. 46-48, and the gyrocompass it replaces.

000's recipe
------------
At table pitch 90 deg the horizontal accelerometers give the misalignment of the INS
relative to the table, ``A = C_RT^IN`` (000 eq. 46; alpha, beta measured, gamma ~ 0,
written in axes whose z is vertical at that position). The table's 90 deg pitch maps
those axes onto the level ones, ``U = W = [[1, 0, 0], [0, 0, 1], [0, -1, 0]]``
(000 eq. 47), so the level-position misalignment is (000 eq. 48)::

    B = W A U^-1 = W A W^T = [[1, alpha, gamma], [-alpha, 1, -beta], [-gamma, beta, 1]]

(the U^-1 printed in 000 eq. 48 has a typo: it is W^T). ``alpha`` is the azimuth of the
IMU relative to the table at the level position; with the table's known azimuth it is
the INS heading, from accelerometers only.

General form used here
----------------------
For any table geometry and IMU mounting, write the IMU body -> platform rotation as the
nominal mounting times a small rotation mu (rad, b frame)::

    mat_tb = mat_tb0 @ exp([mu x])

At rest at table position k the accelerometers see ``f_b,k = |g| mat_tb^T u_t,k`` with
``u_t,k = mat_nt,k^T [0, 0, -1]`` the up direction in platform axes (``mat_nt,k`` from
the encoder readings, :func:`inins.table.kinematics.platform_matrix`). To first order
``f_b,k / |g| = u_b0,k + u_b0,k x mu``: each position gives the two components of mu
about its horizontal axes. Two positions with different up directions (vertical and
level) give all three; the least-squares solution is Wahba's problem, solved exactly by
the SVD of ``sum_k w_k u_t,k f_b,k^T / |f_b,k|`` (weights ``w_k`` = window lengths).

Mapping to 000 eq. 48: let p be 000's level axes (x table right = pitch axis, y table
forward, z up; 000's IMU is mounted along them) and ``mu_p = mat_pt mat_tb0 mu``.
``B = C_RT^IN = exp(-[mu_p x])``, so::

    alpha = mu_p,z,   beta = -mu_p,x,   gamma = -mu_p,y

and the vertical-position accelerometers give ``alpha = f_x / g`` and ``beta = f_z / g``
(000 eq. 46) -- the same numbers (tests/calibration/test_ett.py proves it). The IMU
heading at the level position is the heading of ``mat_nt,level @ mat_tb``; on a level
platform it is the nominal heading minus alpha.

Error budget (first order)
--------------------------
An accelerometer bias ``nabla`` (b frame) turns the azimuth by ``nabla . (u_v x u_l) / g``
(``u_v``, ``u_l``: body up directions at the vertical and level positions; for 000's
IMU pitched nose up, ``-nabla_x / g`` in heading). White noise of the window means,
encoder noise and the base azimuth (1:1 in heading) are propagated through numerical
Jacobians of the exact solution. The gyrocompass at the level position
(:func:`inins.calibration.alignment.align_stationary`) errs by ``-eps_E / (W cos lat)``.

The results file layout (group ``ett``) is in :mod:`inins.io.ettresult`.
"""

from dataclasses import dataclass

import numpy as np

from inins.calibration import alignment
from inins.calibration.ett_positions import (
    METHOD,
    UP_N,
    EttPosition,
    hold_window,
    measure,
    select_positions,
    window_mean,
)
from inins.core import earth, rotation
from inins.core.units import DEG, UG
from inins.exceptions import InputError
from inins.table.kinematics import platform_matrix

W_PITCH90 = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])
"""000 eq. 47: U = W, the 90 deg pitch of the table in 000's axes."""
MAT_TP = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
"""000's level axes p (right, forward, up) -> table platform t (forward, right, down)."""


@dataclass(frozen=True)
class EttOptions:
    """Settings of :func:`align_ett`, SI.

    ``vertical_label``, ``level_label``: step labels of the positions (None: found from
    the schedule); ``settle`` (s) skipped at the start of each hold; ``window`` (s)
    averaged after it (None: the rest of the hold); ``mat_tb0`` nominal mounting (None:
    the nearest axis permutation of the estimate); ``table_azimuth`` (rad) replacing the
    record's base azimuth (None: keep) and its 1 sigma ``table_azimuth_sigma`` (rad);
    ``accel_bias_sigma`` (m/s^2, each axis); ``accel_vrw`` (m/s/sqrt(s)) and
    ``gyro_arw`` (rad/sqrt(s)), None: from the scatter of the data.
    """

    vertical_label: str | None = None
    level_label: str | None = None
    settle: float = 5.0
    window: float | None = None
    mat_tb0: np.ndarray | None = None
    table_azimuth: float | None = None
    table_azimuth_sigma: float = 0.0
    accel_bias_sigma: float = 10.0 * UG
    accel_vrw: float | None = None
    gyro_arw: float | None = None


@dataclass(frozen=True)
class EttResult:
    """What align-ett hands on (to calibrate-bias, through the ``ett`` group of its file).

    Attributes
    ----------
    mat_tb : ndarray, shape (3, 3)
        Estimated IMU body -> table platform.
    mat_tb0 : ndarray, shape (3, 3)
        Nominal mounting; ``mat_tb = mat_tb0 @ exp([mu x])``.
    mu : ndarray, shape (3,)
        Mounting misalignment (rad, b frame).
    heading, heading_sigma : float
        IMU heading (rad) at the level position and its 1 sigma (rad).
    level_angles : ndarray, shape (g,)
        Table angles (rad) of the level position, outer gimbal first.
    mat_n_base : ndarray, shape (3, 3)
        Table base -> NED used.
    axes : ndarray, shape (g, 3)
        Gimbal axes used.
    """

    mat_tb: np.ndarray
    mat_tb0: np.ndarray
    mu: np.ndarray
    heading: float
    heading_sigma: float
    level_angles: np.ndarray
    mat_n_base: np.ndarray
    axes: np.ndarray

    def mat_nb(self, angles):
        """IMU attitude ``mat_nt(angles) @ mat_tb`` at table ``angles`` (rad, (..., g))."""
        return platform_matrix(self.axes, self.mat_n_base, angles) @ self.mat_tb

    def heading_at(self, angles):
        """IMU heading (rad, [0, 2 pi)) at table ``angles`` (rad): calibrate-bias's start."""
        return rotation.euler_from_mat(self.mat_nb(angles))[..., 2]


@dataclass(frozen=True)
class EttTruth:
    """Simulation truth at the level position (rad): heading, mounting misalignment, the
    gyrocompass heading truth and the first-order predicted errors."""

    heading: float
    mu: np.ndarray
    gyrocompass_heading: float
    gyrocompass_err_pred: float
    heading_err_pred: float


@dataclass(frozen=True)
class HeadingSigma:
    """Contributions to the ETT heading 1 sigma (rad): accelerometer noise of the window
    means, accelerometer bias, encoder noise, table base azimuth."""

    noise: float
    bias: float
    encoder: float
    azimuth: float

    @property
    def total(self):
        """Root sum of squares (rad)."""
        return float(
            np.sqrt(sum(v * v for v in (self.noise, self.bias, self.encoder, self.azimuth)))
        )


@dataclass(frozen=True)
class EttEstimate:
    """Everything :func:`align_ett` found: the :class:`EttResult`, both positions, the
    000 eq. 48 angles ``alpha`` (azimuth offset), ``beta``, ``gamma`` (tilts about 000's
    x and y) in rad, the heading 1-sigma contributions ``sigma``, ``time_used`` (s:
    settle + window at both positions + the steps between), the gyrocompass over the
    level hold and its time (s), whether the noise figures were stated (else taken from
    the data), truth and warnings."""

    result: EttResult
    vertical: EttPosition
    level: EttPosition
    alpha: float
    beta: float
    gamma: float
    sigma: HeadingSigma
    time_used: float
    gyrocompass: alignment.StationaryAlignment
    gyrocompass_time: float
    noise_stated: bool
    truth: EttTruth | None
    warnings: tuple


def solve_mounting(f_b, mat_nt, weights):
    """``mat_tb`` from mean specific forces at table positions (Wahba's problem).

    Minimises ``sum_k w_k |u_t,k - mat_tb f_b,k / |f_b,k||^2`` with
    ``u_t,k = mat_nt,k^T [0, 0, -1]``: the least-squares form of 000 eqs. 46-48.

    Parameters
    ----------
    f_b : ndarray, shape (k, 3)
        Mean specific force (m/s^2) per position.
    mat_nt : ndarray, shape (k, 3, 3)
        Platform attitude per position.
    weights : ndarray, shape (k,)

    Returns
    -------
    ndarray, shape (3, 3)
    """
    u_t = np.einsum("kji,j->ki", mat_nt, UP_N)
    u_b = f_b / np.linalg.norm(f_b, axis=1, keepdims=True)
    u, _, vt = np.linalg.svd(np.einsum("k,ki,kj->ij", weights, u_t, u_b))
    return u @ np.diag([1.0, 1.0, np.linalg.det(u) * np.linalg.det(vt)]) @ vt


def nearest_axes(mat):
    """The signed axis permutation (a right-handed nominal mounting) nearest ``mat``."""
    out = np.zeros((3, 3))
    for j in range(3):
        i = int(np.argmax(np.abs(mat[:, j])))
        out[i, j] = np.sign(mat[i, j])
    if not np.allclose(out.T @ out, np.eye(3)) or np.linalg.det(out) < 0:
        raise InputError(f"{METHOD}: the IMU axes are not near table axes; give imu_axes")
    return out


def paper_angles(mu, mat_tb0):
    """000 eq. 48 angles (alpha, beta, gamma) (rad) of the misalignment mu (rad, b)."""
    mu_p = MAT_TP.T @ mat_tb0 @ mu
    return float(mu_p[2]), float(-mu_p[0]), float(-mu_p[1])


def misalignment_matrix(alpha, beta, gamma):
    """000 eq. 46: ``[[1, -gamma, alpha], [gamma, 1, -beta], [-alpha, beta, 1]]``."""
    return np.array([[1.0, -gamma, alpha], [gamma, 1.0, -beta], [-alpha, beta, 1.0]])


def base_with_azimuth(mat_n_base, azimuth):
    """``mat_n_base`` with its azimuth (rad) replaced, tilts kept."""
    roll, pitch, _ = rotation.euler_from_mat(mat_n_base)
    return rotation.mat_from_euler(roll, pitch, azimuth)


class _Solver:
    """Heading as a function of every measured input, for the exact solution and its
    numerical Jacobians."""

    def __init__(self, record, mat_n_base, vertical, level):
        self.axes, self.base = record.axes, mat_n_base
        self.weights = np.array(
            [vertical.time_end - vertical.time_start, level.time_end - level.time_start]
        )
        self.x0 = np.concatenate([vertical.f_b, level.f_b, vertical.angles, level.angles, [0.0]])
        self.g = vertical.angles.size

    def mat_tb(self, x):
        g = self.g
        base = rotation.axis_rotation(2, x[-1]) @ self.base
        mat_nt = platform_matrix(self.axes, base, np.stack([x[6 : 6 + g], x[6 + g : 6 + 2 * g]]))
        return solve_mounting(np.stack([x[:3], x[3:6]]), mat_nt, self.weights), mat_nt[1]

    def heading(self, x):
        mat_tb, mat_nt_level = self.mat_tb(x)
        return rotation.euler_from_mat(mat_nt_level @ mat_tb)[2]

    def jacobian(self):
        """d heading / d x by central differences (1e-6 m/s^2, 1e-8 rad steps)."""
        steps = np.concatenate([np.full(6, 1e-6), np.full(2 * self.g + 1, 1e-8)])
        jac = np.empty(self.x0.size)
        for i, h in enumerate(steps):
            dx = np.zeros_like(self.x0)
            dx[i] = h
            diff = self.heading(self.x0 + dx) - self.heading(self.x0 - dx)
            jac[i] = rotation.wrap_angle(diff) / (2.0 * h)
        return jac


def _sigma(jac, vertical, level, options):
    """Heading 1 sigma contributions (rad)."""
    g = vertical.angles.size
    noise = np.hypot(jac[:3] * vertical.f_sigma, jac[3:6] * level.f_sigma)
    encoder = np.hypot(
        jac[6 : 6 + g] * vertical.angles_sigma, jac[6 + g : 6 + 2 * g] * level.angles_sigma
    )
    return HeadingSigma(
        noise=float(np.linalg.norm(noise)),
        bias=float(np.linalg.norm(jac[:3] + jac[3:6]) * options.accel_bias_sigma),
        encoder=float(np.linalg.norm(encoder)),
        azimuth=float(abs(jac[-1]) * options.table_azimuth_sigma),
    )


def _gyrocompass(record, level_index, options):
    first, stop = hold_window(record, level_index, options.settle, None, "level")
    dtheta, dv = record.imu(first, stop)
    _, w_sigma = window_mean(dtheta, record.dt, options.gyro_arw)
    arw = float(np.sqrt(np.mean(w_sigma**2)) * np.sqrt((stop - first) * record.dt))
    vrw = options.accel_vrw if options.accel_vrw is not None else np.nan
    found = alignment.align_stationary(dtheta, dv, record.dt, record.lla[0], arw=arw, vrw=vrw)
    return found, (first, stop)


def _rows(truth, t_a, t_b):
    """Truth rows in [t_a, t_b] (the nearest one if none falls inside)."""
    idx = np.flatnonzero((truth.time >= t_a) & (truth.time <= t_b))
    return idx if idx.size else np.array([np.argmin(np.abs(truth.time - 0.5 * (t_a + t_b)))])


def _truth(record, vertical, level, gc_window, mat_tb0, jac):
    """Truth at the level position and the first-order predicted errors."""
    truth = record.truth
    k = _rows(truth, level.time_start, level.time_end)
    k = k[k.size // 2]
    mat_nb = rotation.mat_from_quat(truth.quat_nb[k])
    mat_nt = platform_matrix(record.axes, record.mat_n_base, truth.table_angles[k])
    mu = rotation.rotvec_from_mat(mat_tb0.T @ mat_nt.T @ mat_nb)
    gc = _rows(truth, *(record.t0 + i * record.dt for i in gc_window))
    mat_nb_gc = rotation.mat_from_quat(truth.quat_nb[gc[gc.size // 2]])
    eps_e = (mat_nb_gc @ truth.gyro_bias[gc].mean(axis=0))[1]
    ett_pred = sum(
        jac[3 * i : 3 * i + 3]
        @ truth.accel_bias[_rows(truth, p.time_start, p.time_end)].mean(axis=0)
        for i, p in enumerate((vertical, level))
    )
    return EttTruth(
        float(rotation.euler_from_mat(mat_nb)[2]),
        mu,
        float(rotation.euler_from_mat(mat_nb_gc)[2]),
        float(-eps_e / (earth.RATE * np.cos(record.lla[0]))),
        float(ett_pred),
    )


def align_ett(record, options=None):
    """ETT azimuth alignment (000 §3.1, eqs. 46-48) and the gyrocompass comparison.

    Parameters
    ----------
    record : inins.core.records.TableRecord
    options : EttOptions, optional

    Returns
    -------
    EttEstimate

    Raises
    ------
    InputError
        No vertical or level hold, an unknown label, a hold too short.
    """
    options = options or EttOptions()
    warnings = []
    mat_n_base = record.mat_n_base
    if options.table_azimuth is not None:
        mat_n_base = base_with_azimuth(mat_n_base, options.table_azimuth)
    i_vertical, i_level = select_positions(record, options)
    vertical = measure(record, i_vertical, options, "vertical")
    level = measure(record, i_level, options, "level")
    for p in (vertical, level):
        if options.window is not None and p.time_end - p.time_start < options.window - record.dt:
            warnings.append(
                f"hold {p.label!r} is shorter than settle_s + window_s: averaged "
                f"{p.time_end - p.time_start:g} s"
            )
    solver = _Solver(record, mat_n_base, vertical, level)
    mat_tb, mat_nt_level = solver.mat_tb(solver.x0)
    mat_tb0 = options.mat_tb0 if options.mat_tb0 is not None else nearest_axes(mat_tb)
    mu = rotation.rotvec_from_mat(mat_tb0.T @ mat_tb)
    if np.linalg.norm(mu) > 1.0 * DEG:
        warnings.append(
            f"the IMU is {np.degrees(np.linalg.norm(mu)):.2f} deg off its "
            "nominal mounting: check imu_axes"
        )
    heading = float(rotation.euler_from_mat(mat_nt_level @ mat_tb)[2])
    jac = solver.jacobian()
    sigma = _sigma(jac, vertical, level, options)
    between = sum(
        s.end_time - s.start_time
        for s in record.steps[min(i_vertical, i_level) + 1 : max(i_vertical, i_level)]
    )
    used = sum(p.time_end - record.steps[p.step].start_time for p in (vertical, level))
    gyrocompass, gc_window = _gyrocompass(record, i_level, options)
    result = EttResult(
        mat_tb,
        mat_tb0,
        mu,
        heading,
        sigma.total,
        level.angles,
        mat_n_base,
        np.asarray(record.axes, dtype=float),
    )
    truth = None
    if record.truth is not None:
        truth = _truth(record, vertical, level, gc_window, mat_tb0, jac)
    return EttEstimate(
        result,
        vertical,
        level,
        *paper_angles(mu, mat_tb0),
        sigma,
        float(used + between),
        gyrocompass,
        float((gc_window[1] - record.steps[i_level].start_index) * record.dt),
        options.accel_vrw is not None,
        truth,
        tuple(warnings),
    )
