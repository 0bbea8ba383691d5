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


def _jacobian(fun, x, h=1e-6):
    """Central differences of ``fun`` at ``x``, shape (m, n)."""
    cols = []
    for k in range(x.size):
        e = np.zeros(x.size)
        e[k] = h
        cols.append((fun(x + e) - fun(x - e)) / (2 * h))
    return np.stack(cols, axis=-1)


def _noise_cov(acc_res, gyro_res, x_a, x_g, sig_a, sig_g, sig_b):
    """Covariances of the accelerometer terms, the gyro matrix terms and the gyro bias
    from the sensor noise (module docstring of :func:`plan`).

    ``gyro_res(p, db)`` is the gyro residual with the rates offset by ``db``: the bias
    taken from the initial interval (1-sigma ``sig_b`` per axis) is held in the fit, so
    its error passes into the matrix terms, ``cov_p = N^-1 + K S_b K^T`` with
    ``K = N^-1 J_p^T J_b``.

    Returns
    -------
    cov_a (9, 9), cov_g (9, 9), cross (9, 3) gyro matrix - bias, chi2_a, chi2_g (the
    whitened residual sums) and their degrees of freedom.
    """
    ja = _jacobian(acc_res, x_a) / sig_a[:, None]
    cov_a = np.linalg.pinv(ja.T @ ja)
    jp = _jacobian(lambda p: gyro_res(p, np.zeros(3)), x_g) / sig_g[:, None]
    jb = _jacobian(lambda b: gyro_res(x_g, b), np.zeros(3)) / sig_g[:, None]
    n_inv = np.linalg.pinv(jp.T @ jp)
    k = n_inv @ jp.T @ jb
    s_b = np.diag(sig_b**2)
    cov_g = n_inv + k @ s_b @ k.T
    chi2_a = float(np.sum((acc_res(x_a) / sig_a) ** 2))
    chi2_g = float(np.sum((gyro_res(x_g, np.zeros(3)) / sig_g) ** 2))
    return cov_a, cov_g, -k @ s_b, chi2_a, chi2_g


def _white_density(x, dts, ivs):
    """White-noise density per axis (unit sqrt(s)) from the scatter within the static
    intervals: the robust spread of successive differences (1.4826 MAD / sqrt(2)),
    which a slow turn inside an interval (about the vertical, unseen by the detector)
    does not inflate, times ``sqrt(dt)``; median over the intervals."""
    per = []
    for iv in ivs:
        d = np.diff(x[iv.start : iv.stop], axis=0)
        mad = np.median(np.abs(d - np.median(d, axis=0)), axis=0)
        per.append(1.4826 * mad / np.sqrt(2.0) * np.sqrt(np.median(dts)))
    return np.median(np.array(per), axis=0)


def _sigmas(means, dur, gap, gravity, vrw, arw):
    """1-sigma of the gravity-norm and gravity-direction residuals from white noise."""
    sig_a = np.mean(vrw) / np.sqrt(dur)
    ends = np.mean(vrw) / gravity * np.sqrt(1.0 / dur[:-1] + 1.0 / dur[1:])
    sig_g = np.repeat(np.hypot(ends, np.mean(arw) * np.sqrt(gap)), 3)
    return sig_a, sig_g


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
    ba, mat_a = _accel_params(sol_a.x)

    init = found[0]
    if init.flag or time[init.start] - time[0] > detector.window:
        raise ValueError("the record does not start at rest: no initial static interval")
    n_init = min(init.stop, init.start + round(detector.init / np.median(np.diff(time))))
    bg = gyro[init.start : n_init].mean(axis=0)

    f_cal = np.linalg.solve(mat_a, (means - ba).T).T
    u = f_cal / np.linalg.norm(f_cal, axis=1, keepdims=True)
    starts = np.array([ivs[k].stop for k in range(len(ivs) - 1)], dtype=np.int64)
    stops = np.array([ivs[k + 1].start for k in range(len(ivs) - 1)], dtype=np.int64)
    dts = np.empty(time.size)
    dts[1:] = np.diff(time)
    dts[0] = dts[1]
    rates = np.ascontiguousarray(gyro - bg)
    rot = np.empty((starts.size, 3, 3))

    def gyro_res_b(p, db):
        inv = np.linalg.inv(_gyro_matrix(p))
        _integrate(
            np.ascontiguousarray(rates - db), dts, np.ascontiguousarray(inv), starts, stops, rot
        )
        pred = np.einsum("kji,kj->ki", rot, u[:-1])
        return (u[1:] - pred).ravel()

    def gyro_res(p):
        inv = np.linalg.inv(_gyro_matrix(p))
        _integrate(rates, dts, np.ascontiguousarray(inv), starts, stops, rot)
        pred = np.einsum("kji,kj->ki", rot, u[:-1])
        return (u[1:] - pred).ravel()

    before = gyro_res(np.zeros(9)).reshape(-1, 3)
    sol_g = least_squares(gyro_res, np.zeros(9), x_scale=np.full(9, 1e-3), method="trf")

    # 1-sigma from the white noise found within the static intervals, inflated by the
    # misfit where the residuals exceed it (sqrt of chi-square per degree of freedom)
    vrw = _white_density(acc, dts, ivs)
    arw = _white_density(gyro, dts, ivs)
    dur = np.array([(iv.stop - iv.start) * np.median(dts) for iv in ivs])
    gap = (stops - starts) * np.median(dts)
    sig_a, sig_g = _sigmas(means, dur, gap, gravity, vrw, arw)
    sig_b = arw / np.sqrt((n_init - init.start) * np.median(dts))
    cov_a, cov_g, cross, chi2_a, chi2_g = _noise_cov(
        acc_res, gyro_res_b, sol_a.x, sol_g.x, sig_a, sig_g, sig_b
    )
    cov_a *= max(1.0, chi2_a / max(sig_a.size - 9, 1))
    inflate_g = max(1.0, chi2_g / max(sig_g.size - 9, 1))
    cov_g *= inflate_g
    cross *= np.sqrt(inflate_g)

    names = ACCEL_NAMES + BIAS_NAMES + GYRO_NAMES
    values = np.concatenate([sol_a.x, bg, sol_g.x])
    cov = np.zeros((21, 21))
    cov[:9, :9], cov[9:12, 9:12], cov[12:, 12:] = cov_a, np.diag(sig_b**2), cov_g
    cov[12:, 9:12], cov[9:12, 12:] = cross, cross.T
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


@dataclass(frozen=True)
class TableFreePlan:
    """Predicted 1-sigma of the table-free terms (:func:`plan`).

    Attributes
    ----------
    names : tuple of str
        The 9 accelerometer terms and the 9 gyro-matrix terms.
    sigma : ndarray, shape (18,)
        ``inf`` where not separable.
    separable : ndarray of bool
    positions : int
        Static intervals the detector finds.
    """

    names: tuple
    sigma: np.ndarray
    separable: np.ndarray
    positions: int


def plan(time, acc, gyro, gravity, vrw, arw, detector=Detector()):
    """Table-free planner: the terms' 1-sigma from the sensor white noise along a motion
    (the increments of an ideal unit on the motion program), before any data.

    The accelerometer residuals ``||a_k|| - g`` have the noise ``vrw / sqrt(T_k)``; the
    gravity-direction residuals that of both ends (``vrw / (g sqrt(T))``) and of the
    angle random walk over the motion between them (``arw sqrt(T_gap)``); the gyro bias
    of the initial interval, held in the fit, adds its own error to the gyro terms.
    Jacobians at the nominal unit (central differences of the method's residuals).
    """
    found, _ = detect_static(time, acc, detector)
    ivs = [iv for iv in found if not iv.flag]
    dts = np.empty(time.size)
    dts[1:] = np.diff(time)
    dts[0] = dts[1]
    means = np.array([acc[iv.start : iv.stop].mean(axis=0) for iv in ivs])
    dur = np.array([(iv.stop - iv.start) * np.median(dts) for iv in ivs])

    def acc_res(p):
        ba, mat = _accel_params(p)
        return np.linalg.norm(np.linalg.solve(mat, (means - ba).T).T, axis=1) - gravity

    u = means / np.linalg.norm(means, axis=1, keepdims=True)
    starts = np.array([ivs[k].stop for k in range(len(ivs) - 1)], dtype=np.int64)
    stops = np.array([ivs[k + 1].start for k in range(len(ivs) - 1)], dtype=np.int64)
    rot = np.empty((starts.size, 3, 3))

    def gyro_res_b(p, db):
        inv = np.ascontiguousarray(np.linalg.inv(_gyro_matrix(p)))
        _integrate(np.ascontiguousarray(gyro - db), dts, inv, starts, stops, rot)
        return (u[1:] - np.einsum("kji,kj->ki", rot, u[:-1])).ravel()

    gap = (stops - starts) * np.median(dts)
    sig_a, sig_g = _sigmas(means, dur, gap, gravity, vrw, arw)
    n_init = min(ivs[0].stop - ivs[0].start, round(detector.init / np.median(dts)))
    sig_b = np.broadcast_to(np.mean(arw) / np.sqrt(n_init * np.median(dts)), (3,))
    cov_a, cov_g, _, _, _ = _noise_cov(
        acc_res, gyro_res_b, np.zeros(9), np.zeros(9), sig_a, sig_g, sig_b
    )
    s_a, ok_a = _separable_sigma_cov(cov_a, ivs, 9)
    s_g, ok_g = _separable_sigma_cov(cov_g, ivs, 9)
    return TableFreePlan(ACCEL_NAMES + GYRO_NAMES, np.r_[s_a, s_g], np.r_[ok_a, ok_g], len(ivs))


def _separable_sigma_cov(cov, ivs, n_par):
    """1-sigma from a covariance; all inf with fewer positions than terms."""
    if len(ivs) < n_par:
        return np.full(n_par, np.inf), np.zeros(n_par, bool)
    sigma = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    return sigma, np.isfinite(sigma)
