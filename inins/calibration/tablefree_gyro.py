"""The gyro part of the table-free method: the rotations integrated between the static
positions, with or without the Earth rate (:mod:`inins.calibration.tablefree`).

Two formulations:

- **imu_tk** (Tedaldi et al. 2014 eq. 15; ``lat = None``): the gyro bias is the mean of
  the initial static interval and the 9 terms of ``M_g`` minimise
  ``sum_k ||u_{k+1} - R_k^T u_k||^2``, ``u_k`` the calibrated gravity direction of
  position ``k`` and ``R_k`` the rotation integrated from ``M_g^-1 (w_meas - b_g)``
  between positions. No heading is known, so the Earth rate stays in the data: the bias
  carries the Earth rate of the first position (up to 15 deg/h) and every rotation the
  Earth rate times its duration.
- **Earth rate modelled** (latitude given): the unit's attitude at the first position
  is ``C_nb,0 = Rz(psi_0) L(u_0)`` (levelled by its gravity direction, heading
  ``psi_0`` unknown) and at the next ones ``C_nb,k+1 = C_nb,k R_k``; the rotations are
  integrated from ``M_g^-1 (w_meas - b_g) - C_bn(t) w_ie`` (the rotation relative to
  the Earth, which is what carries gravity), and every static interval's mean rate is a
  measurement ``w_k = M_g C_bn,k w_ie + b_g`` (a gyrocompass at every position). The
  13 unknowns (``M_g``, ``b_g``, ``psi_0``) are fitted jointly; the bias is then the
  sensor's alone, and the heading a nuisance parameter (the terms' covariance is its
  marginal). ``psi_0`` starts from the linear gyrocompass of all positions (bias and
  ``(cos psi_0, sin psi_0)`` by least squares).
"""

from dataclasses import dataclass

import numpy as np

from inins.calibration import alignment
from inins.core import earth, jit, rotation

GYRO_NAMES = ("sg_x", "sg_y", "sg_z", "mg_xy", "mg_xz", "mg_yx", "mg_yz", "mg_zx", "mg_zy")
BIAS_NAMES = ("bg_x", "bg_y", "bg_z")


def gyro_matrix(p):
    """``M_g`` from its 9 terms in :data:`GYRO_NAMES` order."""
    return np.array([[1 + p[0], p[3], p[4]], [p[5], 1 + p[1], p[6]], [p[7], p[8], 1 + p[2]]])


@jit.njit(cache=True, nogil=True, error_model="numpy")
def _integrate(gyro, bias, dts, inv, starts, stops, mat0, w_ie_n, out, mats):
    """Rotations body(stop) -> body(start) of each gap (``out`` (k, 3, 3)) and the
    attitude at every position (``mats`` (k + 1, 3, 3), ``mats[0] = mat0``).

    Per sample the exact rotation ``exp((inv @ (gyro - bias) - R^T C_bn w_ie_n) dt)``,
    ``R`` the rotation so far in the gap (quaternion product); ``C_nb,k+1 = C_nb,k R_k``.
    ``w_ie_n = 0``: no Earth rate (imu_tk).
    """
    for i in range(3):
        for j in range(3):
            mats[0, i, j] = mat0[i, j]
    for g in range(starts.shape[0]):
        ws = np.zeros(3)  # Earth rate in body(start)
        for i in range(3):
            ws[i] = (
                mats[g, 0, i] * w_ie_n[0] + mats[g, 1, i] * w_ie_n[1] + mats[g, 2, i] * w_ie_n[2]
            )
        q0, q1, q2, q3 = 1.0, 0.0, 0.0, 0.0
        for k in range(starts[g], stops[g]):
            r0, r1, r2 = gyro[k, 0] - bias[0], gyro[k, 1] - bias[1], gyro[k, 2] - bias[2]
            wx = inv[0, 0] * r0 + inv[0, 1] * r1 + inv[0, 2] * r2
            wy = inv[1, 0] * r0 + inv[1, 1] * r1 + inv[1, 2] * r2
            wz = inv[2, 0] * r0 + inv[2, 1] * r1 + inv[2, 2] * r2
            # Earth rate in body(t): R^T ws, R from the quaternion so far
            a00 = 1 - 2 * (q2 * q2 + q3 * q3)
            a01 = 2 * (q1 * q2 - q0 * q3)
            a02 = 2 * (q1 * q3 + q0 * q2)
            a10 = 2 * (q1 * q2 + q0 * q3)
            a11 = 1 - 2 * (q1 * q1 + q3 * q3)
            a12 = 2 * (q2 * q3 - q0 * q1)
            a20 = 2 * (q1 * q3 - q0 * q2)
            a21 = 2 * (q2 * q3 + q0 * q1)
            a22 = 1 - 2 * (q1 * q1 + q2 * q2)
            wx -= a00 * ws[0] + a10 * ws[1] + a20 * ws[2]
            wy -= a01 * ws[0] + a11 * ws[1] + a21 * ws[2]
            wz -= a02 * ws[0] + a12 * ws[1] + a22 * ws[2]
            wx, wy, wz = wx * dts[k], wy * dts[k], wz * dts[k]
            ang = np.sqrt(wx * wx + wy * wy + wz * wz)
            if ang > 1e-12:
                s = np.sin(0.5 * ang) / ang
            else:
                s = 0.5 - ang * ang / 48.0
            c = np.cos(0.5 * ang)
            rx, ry, rz = s * wx, s * wy, s * wz
            n0 = q0 * c - q1 * rx - q2 * ry - q3 * rz
            n1 = q0 * rx + q1 * c + q2 * rz - q3 * ry
            n2 = q0 * ry - q1 * rz + q2 * c + q3 * rx
            n3 = q0 * rz + q1 * ry - q2 * rx + q3 * c
            q0, q1, q2, q3 = n0, n1, n2, n3
        out[g, 0, 0] = 1 - 2 * (q2 * q2 + q3 * q3)
        out[g, 0, 1] = 2 * (q1 * q2 - q0 * q3)
        out[g, 0, 2] = 2 * (q1 * q3 + q0 * q2)
        out[g, 1, 0] = 2 * (q1 * q2 + q0 * q3)
        out[g, 1, 1] = 1 - 2 * (q1 * q1 + q3 * q3)
        out[g, 1, 2] = 2 * (q2 * q3 - q0 * q1)
        out[g, 2, 0] = 2 * (q1 * q3 - q0 * q2)
        out[g, 2, 1] = 2 * (q2 * q3 + q0 * q1)
        out[g, 2, 2] = 1 - 2 * (q1 * q1 + q2 * q2)
        for i in range(3):
            for j in range(3):
                mats[g + 1, i, j] = (
                    mats[g, i, 0] * out[g, 0, j]
                    + mats[g, i, 1] * out[g, 1, j]
                    + mats[g, i, 2] * out[g, 2, j]
                )


@dataclass
class GyroProblem:
    """The gyro residuals of a table-free record (module docstring).

    Attributes
    ----------
    gyro : ndarray, shape (n, 3)
        Rates with the nominal scale (rad/s).
    dts : ndarray, shape (n,)
        Sample intervals (s).
    starts, stops : ndarray of int64, shape (k - 1,)
        The gaps between the static positions (samples).
    u : ndarray, shape (k, 3)
        Calibrated gravity direction (unit specific force) of each position.
    means, durations : ndarray, shape (k, 3), (k,)
        Mean rate (rad/s) and length (s) of each static interval.
    lat : float or None
        Latitude (rad); None: the imu_tk formulation.
    """

    gyro: np.ndarray
    dts: np.ndarray
    starts: np.ndarray
    stops: np.ndarray
    u: np.ndarray
    means: np.ndarray
    durations: np.ndarray
    lat: float | None = None

    def __post_init__(self):
        self.gyro = np.ascontiguousarray(self.gyro, dtype=float)
        self.rot = np.empty((self.starts.size, 3, 3))
        self.mats = np.empty((self.starts.size + 1, 3, 3))
        self.w_ie_n = np.zeros(3) if self.lat is None else earth.rate_ie_n(self.lat)
        self.level0 = alignment.level(self.u[0])

    def with_u(self, u):
        """The same problem with other gravity directions (the kernel's buffers shared)."""
        from dataclasses import replace

        return replace(self, u=np.asarray(u, float))

    @property
    def earth(self):
        """True when the Earth rate is modelled."""
        return self.lat is not None

    def integrate(self, p, bias, heading=0.0):
        """Rotations of the gaps (k - 1, 3, 3) and attitudes (k, 3, 3)."""
        inv = np.ascontiguousarray(np.linalg.inv(gyro_matrix(p)))
        mat0 = np.ascontiguousarray(rotation.axis_rotation(2, heading) @ self.level0)
        _integrate(
            self.gyro,
            np.asarray(bias, float),
            self.dts,
            inv,
            self.starts,
            self.stops,
            mat0,
            self.w_ie_n,
            self.rot,
            self.mats,
        )
        return self.rot, self.mats

    def direction_residuals(self, p, bias, heading=0.0):
        """``u_{k+1} - R_k^T u_k``, shape (3 (k - 1),)."""
        rot, _ = self.integrate(p, bias, heading)
        return (self.u[1:] - np.einsum("kji,kj->ki", rot, self.u[:-1])).ravel()

    def static_residuals(self, p, bias, heading):
        """``w_k - M_g C_bn,k w_ie - b_g`` of every position, shape (3 k,)."""
        _, mats = self.integrate(p, bias, heading)
        w_b = np.einsum("kji,j->ki", mats, self.w_ie_n)
        return (self.means - w_b @ gyro_matrix(p).T - bias).ravel()

    def initial_heading(self, bias):
        """Bias and heading of the first position from the static means alone (the
        gyrocompass of all positions, linear in ``b``, ``cos psi``, ``sin psi``), the
        attitudes from the rotations integrated with the bias ``bias``."""
        _, mats = self.integrate(np.zeros(9), bias, 0.0)
        w = self.w_ie_n
        k = self.means.shape[0]
        a = np.zeros((3 * k, 5))
        rhs = self.means.ravel() - np.einsum("kji,j->ki", mats, [0.0, 0.0, w[2]]).ravel()
        for i in range(k):
            c_bn = mats[i].T  # heading 0; Rz(psi)^T w = [w_h cos, -w_h sin, w_d]
            a[3 * i : 3 * i + 3, :3] = np.eye(3)
            a[3 * i : 3 * i + 3, 3] = c_bn[:, 0] * w[0]
            a[3 * i : 3 * i + 3, 4] = -c_bn[:, 1] * w[0]
        x = np.linalg.lstsq(a, rhs, rcond=None)[0]
        return x[:3], float(np.arctan2(x[4], x[3]))
