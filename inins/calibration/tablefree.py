"""Table-free multi-position calibration (D. Tedaldi, A. Pretto, E. Menegatti, "A Robust
and Easy to Implement Method for IMU Calibration without External Equipments",
ICRA 2014; the method as imu_tk implements it).

1. **Static detector** (Tedaldi §IV-A): the variance of each accelerometer axis over a
   centred sliding window of ``window`` s; its norm ``||(var_x, var_y, var_z)||`` is
   compared with ``threshold_factor`` times the same norm over the initial static
   interval (``init`` s, which must be at rest; the threshold is at least
   (1e-5 m/s^2)^2). Runs of samples below it, at least ``min_interval`` s long, are
   static intervals. An interval whose gravity direction
   turns by more than ``max_tilt`` between its first and last fifth is flagged as moving
   and dropped.
2. **Accelerometers from the gravity norm** (Tedaldi eq. 10): the 9 terms of
   ``f_meas = M_a f + b_a`` (``M_a`` lower triangular, as in :mod:`inins.core.imu`)
   minimise ``sum_k (||M_a^-1 (a_k - b_a)|| - g)^2`` over the interval means ``a_k``.
   Gravity fixes no rotation: the body frame is the accelerometer triad.
3. **Gyros from the rotations between static intervals** (Tedaldi eq. 15): gyro bias is
   the mean over the initial interval (imu_tk), then the 9 terms of ``M_g`` minimise
   ``sum_k ||u_{k+1} - R_k^T u_k||^2``, ``u_k`` the calibrated gravity direction of
   interval ``k`` and ``R_k`` the rotation integrated from the calibrated rates
   ``M_g^-1 (w_meas - b_g)`` over the motion between them (sample by sample, exact
   rotation vector per sample).

Both fits are ``scipy.optimize.least_squares`` (trust region), 1-sigma from the
Jacobian at the solution scaled by the residual variance (``s^2 (J^T J)^-1``).

Model limits: the Earth rate is not modelled (no heading is known), so the gyro bias
carries the Earth-rate component of the initial position (up to 15 deg/h) and the
rotations carry Earth rate times the motion time; g-sensitivity and mounting are not
estimable without a reference.
"""

from dataclasses import dataclass

import numpy as np

from inins.calibration import imu_model
from inins.core import jit

ACCEL_NAMES = ("ba_x", "ba_y", "ba_z", "sa_x", "sa_y", "sa_z", "ma_yx", "ma_zx", "ma_zy")
GYRO_NAMES = ("sg_x", "sg_y", "sg_z", "mg_xy", "mg_xz", "mg_yx", "mg_yz", "mg_zx", "mg_zy")
BIAS_NAMES = ("bg_x", "bg_y", "bg_z")


@dataclass(frozen=True)
class Detector:
    """Static-detector settings (SI); see the module docstring."""

    window: float = 1.0
    init: float = 30.0
    threshold_factor: float = 6.0
    min_interval: float = 2.0
    max_tilt: float = np.radians(0.2)


@dataclass(frozen=True)
class StaticInterval:
    """Samples [start, stop) at rest; ``flag`` says why it was dropped ("" = kept)."""

    start: int
    stop: int
    flag: str = ""


def _moving_variance_norm(acc, w):
    """Norm of the per-axis variance over a centred window of ``w`` samples, shape (n,)."""
    n = acc.shape[0]
    c1 = np.vstack([np.zeros((1, 3)), np.cumsum(acc, axis=0)])
    c2 = np.vstack([np.zeros((1, 3)), np.cumsum(acc * acc, axis=0)])
    half = w // 2
    lo = np.clip(np.arange(n) - half, 0, n)
    hi = np.clip(np.arange(n) + half + 1, 0, n)
    cnt = (hi - lo)[:, None]
    mean = (c1[hi] - c1[lo]) / cnt
    var = np.clip((c2[hi] - c2[lo]) / cnt - mean * mean, 0.0, None)
    return np.linalg.norm(var, axis=1)


def detect_static(time, acc, detector):
    """Static intervals of a record (module docstring, step 1).

    Returns
    -------
    intervals : list of StaticInterval
        All candidate runs, the flagged ones with their reason.
    threshold : float
        The variance-norm threshold ((m/s^2)^2).
    """
    dt = float(np.median(np.diff(time)))
    w = max(3, round(detector.window / dt) | 1)
    vnorm = _moving_variance_norm(acc, w)
    n_init = round(detector.init / dt)
    init_var = np.var(acc[:n_init], axis=0)
    # floor (1e-5 m/s^2)^2: noise-free data would otherwise have a zero threshold
    threshold = max(detector.threshold_factor * float(np.linalg.norm(init_var)), 1e-10)
    static = vnorm < threshold
    edges = np.flatnonzero(np.diff(np.concatenate([[0], static.astype(int), [0]])))
    out = []
    min_n = round(detector.min_interval / dt)
    for a, b in zip(edges[::2], edges[1::2], strict=True):
        flag = ""
        if b - a < min_n:
            flag = f"shorter than {detector.min_interval:g} s"
        else:
            fifth = max(1, (b - a) // 5)
            u0 = acc[a : a + fifth].mean(axis=0)
            u1 = acc[b - fifth : b].mean(axis=0)
            cosang = u0 @ u1 / (np.linalg.norm(u0) * np.linalg.norm(u1))
            turn = float(np.arccos(np.clip(cosang, -1.0, 1.0)))
            if turn > detector.max_tilt:
                flag = f"moving: gravity direction turns {np.degrees(turn):.3f} deg"
        out.append(StaticInterval(int(a), int(b), flag))
    return out, threshold


def _accel_params(p):
    ba = p[:3]
    mat = np.array([[1 + p[3], 0, 0], [p[6], 1 + p[4], 0], [p[7], p[8], 1 + p[5]]])
    return ba, mat


def _gyro_matrix(p):
    return np.array([[1 + p[0], p[3], p[4]], [p[5], 1 + p[1], p[6]], [p[7], p[8], 1 + p[2]]])


@jit.njit(cache=True, nogil=True, error_model="numpy")
def _integrate(rates, dts, inv, starts, stops, out):
    """Rotation matrices body(stop) -> body(start) of each gap, rates calibrated by ``inv``.

    Quaternion product of the exact per-sample rotations ``exp(inv @ rate * dt)``;
    ``out`` (k, 3, 3) is filled in place.
    """
    for g in range(starts.shape[0]):
        q0, q1, q2, q3 = 1.0, 0.0, 0.0, 0.0
        for k in range(starts[g], stops[g]):
            wx = (
                inv[0, 0] * rates[k, 0] + inv[0, 1] * rates[k, 1] + inv[0, 2] * rates[k, 2]
            ) * dts[k]
            wy = (
                inv[1, 0] * rates[k, 0] + inv[1, 1] * rates[k, 1] + inv[1, 2] * rates[k, 2]
            ) * dts[k]
            wz = (
                inv[2, 0] * rates[k, 0] + inv[2, 1] * rates[k, 1] + inv[2, 2] * rates[k, 2]
            ) * dts[k]
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


@dataclass(frozen=True)
class TableFreeFit:
    """Result of :func:`calibrate`.

    Attributes
    ----------
    names : tuple of str
        The 21 sensor terms (accelerometer 9, gyro bias 3, gyro matrix 9).
    values, sigma : ndarray, shape (21,)
    covariance : ndarray, shape (21, 21)
        Block diagonal: accelerometer, gyro bias, gyro matrix.
    intervals : list of StaticInterval
        Every candidate interval (flagged ones not used).
    used : tuple of int
        Indices into ``intervals`` of the intervals used.
    norm_before, norm_after : ndarray, shape (k,)
        ``||a_k|| - g`` of the used intervals with the nominal scale and after (m/s^2).
    gravity_residual_before, gravity_residual_after : ndarray, shape (k - 1, 3)
        Gravity-direction residuals ``u_{k+1} - R_k^T u_k`` before (nominal gyros) and
        after.
    threshold : float
    """

    names: tuple
    values: np.ndarray
    sigma: np.ndarray
    covariance: np.ndarray
    intervals: list
    used: tuple
    norm_before: np.ndarray
    norm_after: np.ndarray
    gravity_residual_before: np.ndarray
    gravity_residual_after: np.ndarray
    threshold: float

    @property
    def terms(self):
        return imu_model.ImuTerms(dict(zip(self.names, self.values, strict=True)))


def _cov(jac, res, n_par):
    dof = max(res.size - n_par, 1)
    s2 = float(res @ res) / dof
    return s2 * np.linalg.pinv(jac.T @ jac)


def calibrate(time, acc, gyro, gravity, detector=Detector(), use=None):
    """Table-free calibration of both triads (module docstring).

    Parameters
    ----------
    time : ndarray, shape (n,)
        Sample times (s), increasing.
    acc, gyro : ndarray, shape (n, 3)
        Specific force (m/s^2) and angular rate (rad/s) with the nominal scale.
    gravity : float
        Local gravity (m/s^2).
    detector : Detector
    use : sequence of int, optional
        Which of the kept static intervals to use (indices among the kept ones).

    Raises
    ------
    ValueError
        Fewer than 9 usable static intervals (not enough to fix the 9 accelerometer
        terms), or no initial static interval.
    """
    from scipy.optimize import least_squares

    found, threshold = detect_static(time, acc, detector)
    kept = [i for i, iv in enumerate(found) if not iv.flag]
    if use is not None:
        bad = [i for i in use if not 0 <= i < len(kept)]
        if bad:
            raise ValueError(
                f"use_positions {bad}: only {len(kept)} static intervals were found "
                f"(indices 0-{len(kept) - 1})"
            )
        kept = [kept[i] for i in use]
    if len(kept) < 9:
        raise ValueError(
            f"{len(kept)} static intervals usable; the 9 accelerometer terms need >= 9 "
            "positions (Tedaldi recommend 36-50)"
        )
    ivs = [found[i] for i in kept]
    means = np.array([acc[iv.start : iv.stop].mean(axis=0) for iv in ivs])

    def acc_res(p):
        ba, mat = _accel_params(p)
        f = np.linalg.solve(mat, (means - ba).T).T
        return np.linalg.norm(f, axis=1) - gravity

    sol_a = least_squares(acc_res, np.zeros(9), x_scale=np.full(9, 1e-3), method="trf")
    cov_a = _cov(sol_a.jac, sol_a.fun, 9)
    ba, mat_a = _accel_params(sol_a.x)

    init = found[0]
    if init.flag or time[init.start] - time[0] > detector.window:
        raise ValueError("the record does not start at rest: no initial static interval")
    n_init = min(init.stop, init.start + round(detector.init / np.median(np.diff(time))))
    bg = gyro[init.start : n_init].mean(axis=0)
    bg_cov = np.diag(gyro[init.start : n_init].var(axis=0) / max(n_init - init.start, 1))

    f_cal = np.linalg.solve(mat_a, (means - ba).T).T
    u = f_cal / np.linalg.norm(f_cal, axis=1, keepdims=True)
    starts = np.array([ivs[k].stop for k in range(len(ivs) - 1)], dtype=np.int64)
    stops = np.array([ivs[k + 1].start for k in range(len(ivs) - 1)], dtype=np.int64)
    dts = np.empty(time.size)
    dts[1:] = np.diff(time)
    dts[0] = dts[1]
    rates = np.ascontiguousarray(gyro - bg)
    rot = np.empty((starts.size, 3, 3))

    def gyro_res(p):
        inv = np.linalg.inv(_gyro_matrix(p))
        _integrate(rates, dts, np.ascontiguousarray(inv), starts, stops, rot)
        pred = np.einsum("kji,kj->ki", rot, u[:-1])
        return (u[1:] - pred).ravel()

    before = gyro_res(np.zeros(9)).reshape(-1, 3)
    sol_g = least_squares(gyro_res, np.zeros(9), x_scale=np.full(9, 1e-3), method="trf")
    cov_g = _cov(sol_g.jac, sol_g.fun, 9)

    names = ACCEL_NAMES + BIAS_NAMES + GYRO_NAMES
    values = np.concatenate([sol_a.x, bg, sol_g.x])
    cov = np.zeros((21, 21))
    cov[:9, :9], cov[9:12, 9:12], cov[12:, 12:] = cov_a, bg_cov, cov_g
    order = [names.index(n) for n in imu_model.SENSOR_TERMS]
    names = tuple(names[i] for i in order)
    values, cov = values[order], cov[np.ix_(order, order)]
    return TableFreeFit(
        names,
        values,
        np.sqrt(np.diag(cov)),
        cov,
        found,
        tuple(kept),
        np.linalg.norm(means, axis=1) - gravity,
        acc_res(sol_a.x),
        before,
        sol_g.fun.reshape(-1, 3),
        threshold,
    )
