"""Rate-table kinematics: the true attitude, angular rate and specific force of an IMU
on a gimbaled table through an anti-vibration mount.

Chain of frames (package docstring): n (local level NED at the site) -> table
base -> gimbals, outer first -> t (table platform, innermost gimbal) -> b (IMU)::

    mat_nt = mat_n_base @ R_1(theta_1) @ ... @ R_g(theta_g)
    mat_tb = mat_tb0 @ exp([m x])          (m: mount rotation vector, b frame)
    mat_nb = mat_nt @ mat_tb

``R_i`` turns about gimbal axis ``a_i`` (unit vector in its parent frame; the
nominal axes are table x = roll, y = pitch, z = yaw, and may carry small
non-orthogonality). The rate of gimbal i's frame relative to n, in its own
axes, is ``w_i = R_i^T w_(i-1) + a_i dtheta_i/dt`` (``w_0 = 0``). The mount
rate is ``omega_tb_b = J_r(m) dm/dt`` with the right Jacobian of SO(3).
The table stands still on the Earth and the IMU sits at the centre of
rotation (no lever arm), so::

    omega_ib_b = mat_bn omega_ie_n + mat_bt omega_nt_t + omega_tb_b
    f_b        = -mat_bn g_n
"""

import math
from dataclasses import dataclass

import numpy as np

from inins.core import earth, jit, rotation
from inins.table.program import Hold, Program, compile_program

GIMBAL_AXES = {"roll": 0, "pitch": 1, "yaw": 2}
"""Nominal gimbal axis names -> table axis index (x, y, z of the FRD table frame)."""


@dataclass(frozen=True)
class MountRotation:
    """A rotation of the IMU on its mount about a fixed body axis.

    Attributes
    ----------
    axis : ndarray, shape (3,)
        Unit rotation axis in the b frame.
    angle : float
        Total rotation (rad).
    start, duration : float
        Time (s) the rotation starts and how long it takes (> 0).
    smooth : bool
        False: constant rate (linear ramp). True: ``(1 - cos(pi s)) / 2`` ramp,
        rate continuous at both ends.
    """

    axis: np.ndarray
    angle: float
    start: float
    duration: float
    smooth: bool = False


# numpy error model: no ZeroDivisionError branches (every divisor here is checked
# non-zero before the kernel runs), which numba would otherwise compile and test.
# 3x3 matrices are 9-tuples (row-major) and vectors 3-tuples inside the kernel: tuple
# arithmetic compiles in a fraction of the time of small-array indexing. Helpers
# called once per sample site are inlined by numba (_inl: no separate compilation);
# the small ones called several times are compiled once and inlined by LLVM.
_jit = jit.njit(cache=True, nogil=True, error_model="numpy")
_inl = jit.njit(error_model="numpy", inline="always")


@_jit
def _mm(a, b):
    """``a @ b`` for 3x3 matrices as row-major 9-tuples."""
    return (
        a[0] * b[0] + a[1] * b[3] + a[2] * b[6],
        a[0] * b[1] + a[1] * b[4] + a[2] * b[7],
        a[0] * b[2] + a[1] * b[5] + a[2] * b[8],
        a[3] * b[0] + a[4] * b[3] + a[5] * b[6],
        a[3] * b[1] + a[4] * b[4] + a[5] * b[7],
        a[3] * b[2] + a[4] * b[5] + a[5] * b[8],
        a[6] * b[0] + a[7] * b[3] + a[8] * b[6],
        a[6] * b[1] + a[7] * b[4] + a[8] * b[7],
        a[6] * b[2] + a[7] * b[5] + a[8] * b[8],
    )


@_jit
def _mtv(a, v):
    """``a.T @ v`` for a 3x3 matrix (9-tuple) and a 3-tuple."""
    return (
        a[0] * v[0] + a[3] * v[1] + a[6] * v[2],
        a[1] * v[0] + a[4] * v[1] + a[7] * v[2],
        a[2] * v[0] + a[5] * v[1] + a[8] * v[2],
    )


@_jit
def _rodrigues(x, y, z, angle):
    """``exp(angle [axis x])`` for a unit axis ``[x, y, z]``, as a 9-tuple."""
    s, c = np.sin(angle), np.cos(angle)
    v = 1.0 - c
    return (
        c + v * x * x,
        v * x * y - s * z,
        v * x * z + s * y,
        v * x * y + s * z,
        c + v * y * y,
        v * y * z - s * x,
        v * x * z - s * y,
        v * y * z + s * x,
        c + v * z * z,
    )


@_jit
def _series(angle2):
    """sin(x)/x, (1 - cos x)/x^2 and (x - sin x)/x^3 of x^2, exact in double for x < 1e-3."""
    if angle2 < 1e-6:
        a = 1.0 - angle2 / 6.0 * (1.0 - angle2 / 20.0)
        b = 0.5 - angle2 / 24.0 * (1.0 - angle2 / 30.0)
        c = 1.0 / 6.0 - angle2 / 120.0 * (1.0 - angle2 / 42.0)
    else:
        x = np.sqrt(angle2)
        a = np.sin(x) / x
        b = (1.0 - np.cos(x)) / angle2
        c = (x - np.sin(x)) / (angle2 * x)
    return a, b, c


@_jit
def _rotate_back(m, a, b, u):
    """``exp(-[m x]) @ u = u - a (m x u) + b m x (m x u)`` (3-tuples)."""
    c0 = m[1] * u[2] - m[2] * u[1]
    c1 = m[2] * u[0] - m[0] * u[2]
    c2 = m[0] * u[1] - m[1] * u[0]
    return (
        u[0] - a * c0 + b * (m[1] * c2 - m[2] * c1),
        u[1] - a * c1 + b * (m[2] * c0 - m[0] * c2),
        u[2] - a * c2 + b * (m[0] * c1 - m[1] * c0),
    )


@_inl
def _mount_state(t, m_axis, m_angle, m_start, m_duration, m_smooth):
    """Mount rotation vector m (rad) and its rate (rad/s) at time t, and False if m = 0."""
    moved = False
    mx, my, mz, rx, ry, rz = 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    for j in range(m_angle.size):
        s = (t - m_start[j]) / m_duration[j]
        if s <= 0.0:
            continue
        moved = True
        if s >= 1.0:
            theta, rate = m_angle[j], 0.0
        elif m_smooth[j]:
            theta = m_angle[j] * 0.5 * (1.0 - math.cos(math.pi * s))
            rate = m_angle[j] * 0.5 * math.pi * math.sin(math.pi * s) / m_duration[j]
        else:
            theta, rate = m_angle[j] * s, m_angle[j] / m_duration[j]
        mx, my, mz = mx + m_axis[j, 0] * theta, my + m_axis[j, 1] * theta, mz + m_axis[j, 2] * theta
        rx, ry, rz = rx + m_axis[j, 0] * rate, ry + m_axis[j, 1] * rate, rz + m_axis[j, 2] * rate
    return moved, (mx, my, mz), (rx, ry, rz)


@_inl
def _platform(
    k,
    s,
    tau,
    seg_theta0,
    seg_rate0,
    seg_accel,
    axes,
    mat_n_base,
    mat_tb0,
    omega_ie_n,
    f_n,
    angles_out,
):
    """Gimbal chain at one time: ``mat_nt`` and the platform terms seen by a mount at rest,
    ``u_omega = mat_tb0^T (mat_nt^T omega_ie_n + omega_nt_t)``, ``u_force = mat_tb0^T
    mat_nt^T f_n``; and True if a gimbal moves. Matrices are 9-tuples, vectors 3-tuples."""
    moving = False
    mat_nt, w = mat_n_base, (0.0, 0.0, 0.0)
    for g in range(axes.shape[0]):
        theta = seg_theta0[s, g] + tau * (seg_rate0[s, g] + 0.5 * tau * seg_accel[s, g])
        rate = seg_rate0[s, g] + seg_accel[s, g] * tau
        moving = moving or seg_rate0[s, g] != 0.0 or seg_accel[s, g] != 0.0
        angles_out[k, g] = theta
        ax, ay, az = axes[g, 0], axes[g, 1], axes[g, 2]
        rot = _rodrigues(ax, ay, az, theta)
        mat_nt = _mm(mat_nt, rot)
        v = _mtv(rot, w)
        w = (v[0] + ax * rate, v[1] + ay * rate, v[2] + az * rate)
    v = _mtv(mat_nt, omega_ie_n)
    u_omega = _mtv(mat_tb0, (v[0] + w[0], v[1] + w[1], v[2] + w[2]))
    u_force = _mtv(mat_tb0, _mtv(mat_nt, f_n))
    return moving, mat_nt, u_omega, u_force


@_inl
def _segment(seg_t0, t):
    """Index of the last segment starting at or before t (0 if none): a bisection,
    ``max(searchsorted(seg_t0, t, 'right') - 1, 0)``."""
    lo, hi = 0, seg_t0.size
    while lo < hi:
        mid = (lo + hi) // 2
        if seg_t0[mid] <= t:
            lo = mid + 1
        else:
            hi = mid
    return lo - 1 if lo > 0 else 0


@_jit
def _rodrigues_vec(m, a, b):
    """``exp([m x]) = I + a [m x] + b [m x]^2`` for a rotation vector m, as a 9-tuple."""
    m2 = m[0] * m[0] + m[1] * m[1] + m[2] * m[2]
    d = 1.0 - b * m2
    return (
        b * m[0] * m[0] + d,
        b * m[0] * m[1] - a * m[2],
        b * m[0] * m[2] + a * m[1],
        b * m[1] * m[0] + a * m[2],
        b * m[1] * m[1] + d,
        b * m[1] * m[2] - a * m[0],
        b * m[2] * m[0] - a * m[1],
        b * m[2] * m[1] + a * m[0],
        b * m[2] * m[2] + d,
    )


@jit.njit(cache=True, nogil=True, error_model="numpy")
def _kinematics_kernel(
    time,
    seg_t0,
    seg_theta0,
    seg_rate0,
    seg_accel,
    axes,
    mat_n_base,
    mat_tb0,
    m_axis,
    m_angle,
    m_start,
    m_duration,
    m_smooth,
    omega_ie_n,
    f_n,
    want_mat,
    omega_ib_b,
    f_b,
    mat_nb,
    angles_out,
):
    n, n_gimbals, n_seg = time.size, axes.shape[0], seg_t0.size
    base = (
        mat_n_base[0, 0],
        mat_n_base[0, 1],
        mat_n_base[0, 2],
        mat_n_base[1, 0],
        mat_n_base[1, 1],
        mat_n_base[1, 2],
        mat_n_base[2, 0],
        mat_n_base[2, 1],
        mat_n_base[2, 2],
    )
    tb0 = (
        mat_tb0[0, 0],
        mat_tb0[0, 1],
        mat_tb0[0, 2],
        mat_tb0[1, 0],
        mat_tb0[1, 1],
        mat_tb0[1, 2],
        mat_tb0[2, 0],
        mat_tb0[2, 1],
        mat_tb0[2, 2],
    )
    w_ie = omega_ie_n[0], omega_ie_n[1], omega_ie_n[2]
    f_ref = f_n[0], f_n[1], f_n[2]
    mat_nt, u_omega, u_force = base, w_ie, f_ref
    s, cached, moving = 0, -1, True
    for k in range(n):
        t = time[k]
        # segments are walked forward; a time earlier than the current segment searches
        if t < seg_t0[s]:
            s = _segment(seg_t0, t)
        while s + 1 < n_seg and t >= seg_t0[s + 1]:
            s += 1
        tau = t - seg_t0[s]
        if moving or s != cached:  # a hold reuses the platform terms of its segment
            moving, mat_nt, u_omega, u_force = _platform(
                k,
                s,
                tau,
                seg_theta0,
                seg_rate0,
                seg_accel,
                axes,
                base,
                tb0,
                w_ie,
                f_ref,
                angles_out,
            )
            cached = s
        else:
            for g in range(n_gimbals):
                angles_out[k, g] = seg_theta0[s, g]
        moved, m, mdot = _mount_state(t, m_axis, m_angle, m_start, m_duration, m_smooth)
        if moved:
            a, b, c = _series(m[0] * m[0] + m[1] * m[1] + m[2] * m[2])
            v = _rotate_back(m, a, b, u_omega)
            # omega_tb_b = J_r(m) mdot = mdot - b (m x mdot) + c m x (m x mdot)
            c0 = m[1] * mdot[2] - m[2] * mdot[1]
            c1 = m[2] * mdot[0] - m[0] * mdot[2]
            c2 = m[0] * mdot[1] - m[1] * mdot[0]
            omega_ib_b[k, 0] = v[0] + mdot[0] - b * c0 + c * (m[1] * c2 - m[2] * c1)
            omega_ib_b[k, 1] = v[1] + mdot[1] - b * c1 + c * (m[2] * c0 - m[0] * c2)
            omega_ib_b[k, 2] = v[2] + mdot[2] - b * c2 + c * (m[0] * c1 - m[1] * c0)
            f_b[k, 0], f_b[k, 1], f_b[k, 2] = _rotate_back(m, a, b, u_force)
        else:
            a, b = 1.0, 0.5
            omega_ib_b[k, 0], omega_ib_b[k, 1], omega_ib_b[k, 2] = u_omega
            f_b[k, 0], f_b[k, 1], f_b[k, 2] = u_force
        if want_mat:  # mat_nb = mat_nt mat_tb0 exp([m x])
            r = _mm(mat_nt, _mm(tb0, _rodrigues_vec(m, a, b)))
            mat_nb[k, 0, 0], mat_nb[k, 0, 1], mat_nb[k, 0, 2] = r[0], r[1], r[2]
            mat_nb[k, 1, 0], mat_nb[k, 1, 1], mat_nb[k, 1, 2] = r[3], r[4], r[5]
            mat_nb[k, 2, 0], mat_nb[k, 2, 1], mat_nb[k, 2, 2] = r[6], r[7], r[8]


@dataclass(frozen=True)
class TableTrajectory:
    """Truth of an IMU on a rate table: implements the trajectory protocol of
    :mod:`inins.core.trajectory` (``breakpoints``, ``rates``, ``state``).

    Attributes
    ----------
    program : Program
        Compiled motion program (:func:`inins.table.program.compile_program`).
    axes : ndarray, shape (g, 3)
        Unit gimbal axes, outer first, each in its parent frame.
    mat_n_base : ndarray, shape (3, 3)
        Table base to NED (azimuth of the base from true north and base tilt).
    mat_tb0 : ndarray, shape (3, 3)
        IMU body to table platform with the mount at rest (nominal mounting
        times the constant mount misalignment).
    mounts : tuple of MountRotation
        Time-varying mount rotations.
    lla : ndarray, shape (3,)
        Site latitude (rad), longitude (rad), height (m).
    """

    program: Program
    axes: np.ndarray
    mat_n_base: np.ndarray
    mat_tb0: np.ndarray
    mounts: tuple
    lla: np.ndarray

    @property
    def breakpoints(self):
        """Times (s) where gimbal or mount rates are not smooth."""
        mount_times = [t for mr in self.mounts for t in (mr.start, mr.start + mr.duration)]
        return np.unique(np.concatenate([self.program.breakpoints, mount_times]))

    def _evaluate(self, time, want_mat):
        time = np.ascontiguousarray(np.atleast_1d(time), dtype=float)
        n = time.size
        seg = self.program.segments
        n_mounts = len(self.mounts)
        m_axis = np.array([mr.axis for mr in self.mounts], dtype=float).reshape(n_mounts, 3)
        omega_ib_b, f_b = np.empty((n, 3)), np.empty((n, 3))
        mat_nb = np.empty((n if want_mat else 1, 3, 3))
        angles = np.empty((n, seg.theta0.shape[1]))
        f_n = -earth.gravity_n(self.lla[0], self.lla[2])
        _kinematics_kernel(
            time,
            seg.t0,
            seg.theta0,
            seg.rate0,
            seg.accel,
            np.asarray(self.axes, float),
            np.asarray(self.mat_n_base, float),
            np.asarray(self.mat_tb0, float),
            m_axis,
            np.array([mr.angle for mr in self.mounts], dtype=float),
            np.array([mr.start for mr in self.mounts], dtype=float),
            np.array([mr.duration for mr in self.mounts], dtype=float),
            np.array([mr.smooth for mr in self.mounts], dtype=np.bool_),
            earth.rate_ie_n(self.lla[0]),
            f_n,
            want_mat,
            omega_ib_b,
            f_b,
            mat_nb,
            angles,
        )
        return omega_ib_b, f_b, mat_nb, angles

    def rates(self, time):
        """True ``omega_ib_b`` (rad/s) and ``f_b`` (m/s^2), each shape (n, 3)."""
        omega_ib_b, f_b, _, _ = self._evaluate(time, False)
        return omega_ib_b, f_b

    def state(self, time):
        """True ``mat_nb`` (n, 3, 3), ``vel_n`` (n, 3) (zero) and ``lla`` (n, 3)."""
        _, _, mat_nb, _ = self._evaluate(time, True)
        n = mat_nb.shape[0]
        return mat_nb, np.zeros((n, 3)), np.broadcast_to(self.lla, (n, 3)).copy()

    def table_angles(self, time):
        """True gimbal angles (rad), shape (n, g), outer first."""
        return self.program.segments.evaluate(time)[0]

    def mount_rotvec(self, time):
        """Mount rotation vector m (rad, b frame), shape (n, 3)."""
        time = np.atleast_1d(np.asarray(time, dtype=float))
        m = np.zeros((time.size, 3))
        for mr in self.mounts:
            s = np.clip((time - mr.start) / mr.duration, 0.0, 1.0)
            ramp = 0.5 * (1.0 - np.cos(np.pi * s)) if mr.smooth else s
            m += np.outer(ramp * mr.angle, mr.axis)
        return m


def platform_matrix(axes, mat_n_base, angles):
    """``mat_nt`` of the table platform from gimbal angles, shape (..., 3, 3).

    Parameters
    ----------
    axes : ndarray, shape (g, 3)
        Unit gimbal axes, outer first, each in its parent frame.
    mat_n_base : ndarray, shape (3, 3)
        Table base to NED.
    angles : array_like, shape (..., g)
        Gimbal angles (rad), e.g. encoder readings.
    """
    angles = np.asarray(angles, dtype=float)
    mat = np.broadcast_to(mat_n_base, (*angles.shape[:-1], 3, 3))
    for g in range(axes.shape[0]):
        mat = mat @ rotation.mat_from_rotvec(angles[..., g, None] * axes[g])
    return mat


def gimbal_axes(names, nonorthogonality=None):
    """Unit gimbal axes from names (outer first), optionally tilted by small angles.

    Parameters
    ----------
    names : sequence of str
        ``"yaw"``, ``"pitch"`` or ``"roll"`` per gimbal, outer first.
    nonorthogonality : array_like, shape (g, 2), optional
        Small tilts (rad) of each axis toward the two other table axes, in
        cyclic order (yaw axis z tilts toward x then y; pitch y toward z then x;
        roll x toward y then z).
    """
    axes = np.zeros((len(names), 3))
    for g, name in enumerate(names):
        i = GIMBAL_AXES[name]
        axes[g, i] = 1.0
        if nonorthogonality is not None:
            axes[g, (i + 1) % 3] += nonorthogonality[g][0]
            axes[g, (i + 2) % 3] += nonorthogonality[g][1]
    return axes / np.linalg.norm(axes, axis=1, keepdims=True)


def base_matrix(azimuth, tilt_roll=0.0, tilt_pitch=0.0):
    """``mat_n_base`` of a table base whose x axis points at ``azimuth`` (rad from north)."""
    return rotation.mat_from_euler(tilt_roll, tilt_pitch, azimuth)


def warm_up():
    """Compile (or load from the on-disk cache) the kinematics kernel on a tiny table.

    The kernel gets the argument types every caller passes, so that a later
    :meth:`TableTrajectory.rates` or ``state`` runs without compiling.
    """
    program = compile_program([Hold(1.0)], np.zeros(2))
    table = TableTrajectory(
        program,
        gimbal_axes(["yaw", "pitch"]),
        base_matrix(0.0),
        np.eye(3),
        (MountRotation(np.array([0.0, 0.0, 1.0]), 0.1, 0.0, 1.0),),
        np.array([0.6, 2.2, 0.0]),
    )
    table.rates(np.array([0.5]))
    table.state(np.array([0.5]))
