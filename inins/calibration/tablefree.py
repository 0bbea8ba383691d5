"""Table-free multi-position calibration (D. Tedaldi, A. Pretto, E. Menegatti, "A Robust
and Easy to Implement Method for IMU Calibration without External Equipments",
ICRA 2014; the method as imu_tk implements it, and with the Earth rate modelled).

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
   minimise ``sum_k (||M_a^-1 (a_k - b_a)|| - g)^2 / s_k^2`` over the interval means
   ``a_k`` (``s_k = VRW / sqrt(T_k)``; in imu_tk's formulation all alike, as imu_tk).
   Gravity fixes no rotation: the body frame is the accelerometer triad.
3. **Gyros from the rotations between static intervals** (Tedaldi eq. 15), in one of the
   two formulations of :mod:`inins.calibration.tablefree_gyro`: imu_tk's (the bias the
   initial interval's mean, the Earth rate left in the data) or, with the latitude
   given, the Earth rate modelled (the heading of the first position estimated with
   the bias and the 9 terms of ``M_g``).

The fits are ``scipy.optimize.least_squares`` (trust region) on residuals whitened by
the sensor white noise found within the static intervals (or given, for the planner).
Each block's information ``J^T J`` at the solution decides what the positions separate
(:func:`inins.calibration.verdict.from_information`: a rolls-only schedule leaves
``ba_x, sa_x, ma_yx, ma_zx`` free, named, never shown with a sigma); the 1-sigma of the
separable terms is its inverse, inflated by the residual chi-square per degree of
freedom where that exceeds 1.

Model limits: g-sensitivity and mounting are not estimable without a reference; in
imu_tk's formulation the gyro bias carries the Earth-rate component of the initial
position (up to 15 deg/h) and the rotations the Earth rate times the motion time.
"""

from dataclasses import dataclass, replace

import numpy as np

from inins.calibration import imu_model, verdict
from inins.calibration.static_detector import (  # noqa: F401 - the method's names
    GYRO_STILL,
    Detector,
    StaticInterval,
    detect_static,
)
from inins.calibration.tablefree_gyro import BIAS_NAMES, GYRO_NAMES, GyroProblem

DEFAULT = Detector()
"""The detector's defaults (imu_tk's)."""
ACCEL_NAMES = ("ba_x", "ba_y", "ba_z", "sa_x", "sa_y", "sa_z", "ma_yx", "ma_zx", "ma_zy")


def _accel_params(p):
    ba = p[:3]
    mat = np.array([[1 + p[3], 0, 0], [p[6], 1 + p[4], 0], [p[7], p[8], 1 + p[5]]])
    return ba, mat


MIN_INFORMATION = 0.01
"""A term whose 1-sigma exceeds ten times its typical size (1000 ppm, 206 arcsec, 1 mg,
20 deg/h: :data:`inins.calibration.verdict.TYPICAL`) is not determined
(:func:`inins.calibration.verdict.from_information`)."""
VRW_FLOOR, ARW_FLOOR = 1e-9, 1e-12
"""Smallest white-noise densities the weights take (m/s/sqrt(s), rad/sqrt(s))."""
SCALE = 1e-3
"""Step size of the least-squares solver (``x_scale``) for the matrix terms."""


@dataclass(frozen=True)
class TableFreeFit:
    """Result of :func:`calibrate`.

    Attributes
    ----------
    names : tuple of str
        The 21 sensor terms (:data:`inins.calibration.imu_model.SENSOR_TERMS` order).
    values, sigma : ndarray, shape (21,)
        ``sigma`` is ``inf`` for a term the positions do not separate.
    covariance : ndarray, shape (21, 21)
        Accelerometer and gyro blocks (NaN rows and columns: not separable).
    verdict : inins.calibration.verdict.Verdict
        What the positions separate (the information of each block).
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
    earth_rate : bool
        The Earth rate modelled (latitude given); else the gyro bias carries it.
    heading : float or None
        Heading of the first position (rad) with the Earth rate modelled.
    heading_sigma : float or None
        Its 1-sigma (rad): a nuisance parameter, fixed by the Earth rate alone (a MEMS
        unit's is degrees).
    lat : float or None
        The latitude of the Earth-rate model (rad).
    chi2 : dict
        Residual chi-square and degrees of freedom of each block (``accel``, ``gyro``).
    """

    names: tuple
    values: np.ndarray
    sigma: np.ndarray
    covariance: np.ndarray
    verdict: verdict.Verdict
    intervals: list
    used: tuple
    norm_before: np.ndarray
    norm_after: np.ndarray
    gravity_residual_before: np.ndarray
    gravity_residual_after: np.ndarray
    threshold: float
    earth_rate: bool = False
    heading: float | None = None
    chi2: dict | None = None
    lat: float | None = None
    heading_sigma: float | None = None

    @property
    def terms(self):
        return imu_model.ImuTerms(dict(zip(self.names, self.values, strict=True)))


def _jacobian(fun, x, h):
    """Central differences of ``fun`` at ``x`` (steps ``h``), shape (m, n)."""
    h = np.broadcast_to(np.asarray(h, float), x.shape)
    cols = []
    for k in range(x.size):
        e = np.zeros(x.size)
        e[k] = h[k]
        cols.append((fun(x + e) - fun(x - e)) / (2 * h[k]))
    return np.stack(cols, axis=-1)


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


def _inflation(chi2, dof, given):
    """Covariance factor: the chi-square per degree of freedom where the chi-square says
    the residuals exceed the white noise (above its 99 % point; with a few degrees of
    freedom the ratio alone is mostly noise, and would inflate a consistent fit by a
    third on average); 1 for the planner, whose noise is given."""
    from inins.core.stats import chi2_ppf

    if given or dof < 1 or chi2 <= float(chi2_ppf(0.99, dof)):
        return 1.0
    return chi2 / dof


def _fit_accel(means, dur, gravity, vrw, given, equal=False):
    """Accelerometer terms from the gravity norm: values, verdict, chi2, dof; ``equal``:
    every position weighted alike (imu_tk), by its mean length."""
    from scipy.optimize import least_squares

    sig = np.mean(vrw) / np.sqrt(np.full_like(dur, dur.mean()) if equal else dur)

    def res(p):
        ba, mat = _accel_params(p)
        f = np.linalg.solve(mat, (means - ba).T).T
        return (np.linalg.norm(f, axis=1) - gravity) / sig

    sol = least_squares(res, np.zeros(9), x_scale=np.full(9, SCALE), method="trf")
    chi2 = float(sol.fun @ sol.fun)
    dof = means.shape[0] - 9
    v = _verdict(res, np.zeros(9), sol.x, 1e-6, ACCEL_NAMES)
    v = _inflated(v, _inflation(chi2, dof, given))
    return sol.x, v, chi2, dof, sol.fun * sig


def _verdict(res, nominal, solution, step, names, marginal=None):
    """What the positions separate: decided at the nominal unit (where a schedule's null
    space is exact: a fit wandering along it would find another), the covariance at the
    solution when everything is separable. ``marginal`` reduces an information to the
    terms (eliminating nuisance parameters)."""

    def information(x):
        jac = _jacobian(res, x, step)
        info = jac.T @ jac
        return info if marginal is None else marginal(info)

    scale = verdict.typical_scale(names)
    first = verdict.from_information(
        information(nominal), names, scale, min_information=MIN_INFORMATION
    )
    if first.inseparable:
        return first
    return verdict.from_information(
        information(solution), names, scale, min_information=MIN_INFORMATION
    )


def _inflated(v, factor):
    """The verdict with its covariance (and sigma) times ``factor``."""
    if factor == 1.0:
        return v
    return replace(v, covariance=v.covariance * factor, sigma=v.sigma * np.sqrt(factor))


def _fit_gyro_imu_tk(problem, bias, sig_b, sig_d, given):
    """imu_tk: the bias of the initial interval held, the 9 matrix terms fitted; the
    bias error passes into them (``cov_p + K S_b K^T``, ``K = cov_p J_p^T J_b``)."""
    from scipy.optimize import least_squares

    def res(p):
        return problem.direction_residuals(p, bias) / sig_d

    sol = least_squares(res, np.zeros(9), x_scale=np.full(9, SCALE), method="trf")
    jp = _jacobian(res, sol.x, 1e-6)
    jb = _jacobian(lambda b: problem.direction_residuals(sol.x, b) / sig_d, bias, 1e-8)
    v = _verdict(res, np.zeros(9), sol.x, 1e-6, GYRO_NAMES)
    cov_p = np.nan_to_num(v.covariance)
    k = cov_p @ jp.T @ jb
    s_b = np.diag(sig_b**2)
    chi2, dof = float(sol.fun @ sol.fun), sol.fun.size - 9
    factor = _inflation(chi2, dof, given)
    cov = np.zeros((12, 12))
    cov[:9, :9] = (cov_p + k @ s_b @ k.T) * factor
    cov[:9, 9:] = -k @ s_b * np.sqrt(factor)
    cov[9:, :9] = cov[:9, 9:].T
    cov[9:, 9:] = s_b
    info = np.zeros((12, 12))
    info[:9, :9] = v.information
    info[9:, 9:] = np.diag(1.0 / sig_b**2)
    ok = np.r_[v.separable, np.ones(3, bool)]
    cov[~ok, :] = np.nan
    cov[:, ~ok] = np.nan
    sigma = np.where(ok, np.sqrt(np.abs(np.diag(np.nan_to_num(cov)))), np.inf)
    gv = verdict.Verdict(GYRO_NAMES + BIAS_NAMES, sigma, ok, v.combinations, info, cov, v.rank + 3)

    def res_of(prob, x):
        return prob.direction_residuals(x, bias) / sig_d

    return np.r_[sol.x, bias], gv, chi2, dof, None, (res_of, sol.x, np.full(9, 1e-6), factor)


def _fit_gyro_earth(problem, sig_s, sig_d, given):
    """Earth rate modelled: the 9 matrix terms, the bias and the first heading jointly;
    the terms' information is the marginal over the heading (Schur complement)."""
    from scipy.optimize import least_squares

    bias = problem.means[0]
    for _ in range(2):
        bias, heading = problem.initial_heading(bias)

    def res(x):
        p, b, h = x[:9], x[9:12], x[12]
        return np.r_[
            problem.static_residuals(p, b, h) / sig_s, problem.direction_residuals(p, b, h) / sig_d
        ]

    x0 = np.r_[np.zeros(9), bias, heading]
    scale = np.r_[np.full(9, SCALE), np.full(3, 1e-5), 1e-2]
    sol = least_squares(res, x0, x_scale=scale, method="trf")

    def marginal(info):  # the heading eliminated (Schur complement)
        i_hh = info[12, 12]
        out = info[:12, :12]
        if i_hh > 1e-12 * np.max(np.abs(np.diag(info))):
            out = out - np.outer(info[:12, 12], info[:12, 12]) / i_hh
        return out

    step = np.r_[np.full(9, 1e-6), np.full(3, 1e-8), 1e-6]
    v = _verdict(res, x0, sol.x, step, GYRO_NAMES + BIAS_NAMES, marginal)
    chi2, dof = float(sol.fun @ sol.fun), sol.fun.size - 13
    factor = _inflation(chi2, dof, given)

    def res_of(prob, x):
        p, b, h = x[:9], x[9:12], x[12]
        return np.r_[
            prob.static_residuals(p, b, h) / sig_s, prob.direction_residuals(p, b, h) / sig_d
        ]

    propagation = (res_of, sol.x, step, factor)
    jac = _jacobian(res, sol.x, step)
    with np.errstate(divide="ignore", invalid="ignore"):
        cov = np.linalg.pinv(jac.T @ jac)
    heading_sigma = float(np.sqrt(max(cov[12, 12], 0.0) * factor))
    heading = (float(sol.x[12]), heading_sigma)
    return sol.x[:12], _inflated(v, factor), chi2, dof, heading, propagation


def _accel_into_gyro(problem, u_of, x_a, cov_a, propagation):
    """Covariance the accelerometer fit's error adds to the gyro terms through the
    gravity directions ``u`` the gyro fit takes as known: ``K cov_a K^T`` (and the cross
    covariance ``-K cov_a``), ``K = (J^T J)^+ J^T J_a``, ``J``, ``J_a`` the whitened gyro
    residuals' Jacobians in the fitted parameters and in the accelerometer terms. For a
    navigation-grade unit this is most of the gyro misalignments' 1-sigma (the gravity
    directions are the reference the rotations are measured against)."""
    res_of, x_fit, step, factor = propagation
    j = _jacobian(lambda x: res_of(problem, x), x_fit, step)
    j_a = _jacobian(lambda xa: res_of(problem.with_u(u_of(xa)), x_fit), x_a, 1e-7)
    k = np.zeros((12, x_a.size))  # the 9 matrix terms, then the bias (its own in imu_tk)
    fitted = (np.linalg.pinv(j.T @ j) @ j.T @ j_a)[:12] * np.sqrt(factor)
    k[: fitted.shape[0]] = fitted
    return k @ cov_a @ k.T, -k @ cov_a


def _reordered(v, names):
    """A verdict's terms in the order ``names``."""
    idx = [v.names.index(n) for n in names]
    ix = np.ix_(idx, idx)
    return verdict.Verdict(
        tuple(names),
        v.sigma[idx],
        v.separable[idx],
        v.combinations,
        v.information[ix],
        v.covariance[ix],
        v.rank,
    )


def _positions(time, acc, detector, use, gyro=None):
    """The static intervals found and the ones used (indices among the kept ones)."""
    found, threshold = detect_static(time, acc, detector, gyro)
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
    return found, kept, threshold


def calibrate(time, acc, gyro, gravity, detector=DEFAULT, use=None, lat=None, noise=None):
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
    lat : float, optional
        Latitude (rad): the Earth rate is modelled; None: imu_tk's formulation.
    noise : tuple of ndarray, optional
        ``(vrw, arw)`` (m/s/sqrt(s), rad/sqrt(s)) per axis for the weights (the
        planner); default: found within the static intervals, and the covariance
        inflated by the misfit.

    Raises
    ------
    ValueError
        Fewer than 9 usable static intervals (not enough to fix the 9 accelerometer
        terms), or no initial static interval.
    """
    found, kept, threshold = _positions(time, acc, detector, use, None if lat is None else gyro)
    ivs = [found[i] for i in kept]
    init = found[0]
    if init.flag or time[init.start] - time[0] > detector.window:
        raise ValueError("the record does not start at rest: no initial static interval")
    dts = np.empty(time.size)
    dts[1:] = np.diff(time)
    dts[0] = dts[1]
    step = float(np.median(dts))
    means = np.array([acc[iv.start : iv.stop].mean(axis=0) for iv in ivs])
    dur = np.array([(iv.stop - iv.start) * step for iv in ivs])
    given = noise is not None
    vrw, arw = noise if given else (_white_density(acc, dts, ivs), _white_density(gyro, dts, ivs))
    # floors for noise-free data (1e-9 m/s/sqrt(s), 2e-7 deg/sqrt(h)): the weights stay finite
    vrw = np.maximum(np.broadcast_to(np.asarray(vrw, float), (3,)), VRW_FLOOR)
    arw = np.maximum(np.broadcast_to(np.asarray(arw, float), (3,)), ARW_FLOOR)
    x_a, v_a, chi2_a, dof_a, norm_after = _fit_accel(means, dur, gravity, vrw, given, lat is None)
    ba, mat_a = _accel_params(x_a)
    f_cal = np.linalg.solve(mat_a, (means - ba).T).T
    u = f_cal / np.linalg.norm(f_cal, axis=1, keepdims=True)
    starts = np.array([ivs[k].stop for k in range(len(ivs) - 1)], dtype=np.int64)
    stops = np.array([ivs[k + 1].start for k in range(len(ivs) - 1)], dtype=np.int64)
    gap = (stops - starts) * step
    ends = np.mean(vrw) / gravity * np.sqrt(1.0 / dur[:-1] + 1.0 / dur[1:])
    sig_d = np.repeat(np.hypot(ends, np.mean(arw) * np.sqrt(gap)), 3)
    g_means = np.array([gyro[iv.start : iv.stop].mean(axis=0) for iv in ivs])
    problem = GyroProblem(gyro, dts, starts, stops, u, g_means, dur, lat)
    if lat is None:
        n_init = min(init.stop, init.start + round(detector.init / step))
        bias = gyro[init.start : n_init].mean(axis=0)
        sig_b = arw / np.sqrt((n_init - init.start) * step)
        x_g, v_g, chi2_g, dof_g, heading, propagation = _fit_gyro_imu_tk(
            problem, bias, sig_b, sig_d, given
        )
        before = problem.direction_residuals(np.zeros(9), bias)
    else:
        sig_s = (arw[None, :] / np.sqrt(dur)[:, None]).ravel()
        x_g, v_g, chi2_g, dof_g, heading, propagation = _fit_gyro_earth(
            problem, sig_s, sig_d, given
        )
        before = problem.direction_residuals(np.zeros(9), g_means[0])
    heading, heading_sigma = (None, None) if heading is None else heading
    after = problem.direction_residuals(x_g[:9], x_g[9:12], 0.0 if heading is None else heading)
    names = ACCEL_NAMES + GYRO_NAMES + BIAS_NAMES
    both = verdict.merge(v_a, v_g)
    if not both.inseparable:

        def u_of(xa):
            ba_, mat_ = _accel_params(xa)
            f = np.linalg.solve(mat_, (means - ba_).T).T
            return f / np.linalg.norm(f, axis=1, keepdims=True)

        add, cross = _accel_into_gyro(problem, u_of, x_a, v_a.covariance, propagation)
        cov = both.covariance.copy()
        cov[9:, 9:] += add
        cov[9:, :9], cov[:9, 9:] = cross, cross.T
        both = replace(both, covariance=cov, sigma=np.sqrt(np.diag(cov)))
    both = _reordered(both, imu_model.SENSOR_TERMS)
    values = dict(zip(names, np.r_[x_a, x_g], strict=True))
    return TableFreeFit(
        both.names,
        np.array([values[n] for n in both.names]),
        both.sigma,
        both.covariance,
        both,
        found,
        tuple(kept),
        np.linalg.norm(means, axis=1) - gravity,
        norm_after,
        before.reshape(-1, 3),
        after.reshape(-1, 3),
        threshold,
        lat is not None,
        heading,
        {"accel": (chi2_a, dof_a), "gyro": (chi2_g, dof_g)},
        lat,
        heading_sigma,
    )


@dataclass(frozen=True)
class TableFreePlan:
    """Predicted 1-sigma of the table-free terms (:func:`plan`).

    Attributes
    ----------
    names : tuple of str
        The 21 sensor terms.
    sigma : ndarray, shape (21,)
        ``inf`` where not separable.
    separable : ndarray of bool
    positions : int
        Static intervals the detector finds.
    verdict : inins.calibration.verdict.Verdict
    earth_rate : bool
    """

    names: tuple
    sigma: np.ndarray
    separable: np.ndarray
    positions: int
    verdict: verdict.Verdict
    earth_rate: bool

    @property
    def inseparable(self):
        return self.verdict.inseparable

    @property
    def combinations(self):
        return self.verdict.combinations


def plan(time, acc, gyro, gravity, vrw, arw, detector=DEFAULT, lat=None):
    """Table-free planner: the terms' 1-sigma and what the positions separate, from the
    increments of an ideal unit on the motion program and the given white noise (the
    method's own residuals and information, :func:`calibrate` with ``noise`` given)."""
    fit = calibrate(time, acc, gyro, gravity, detector, None, lat, (vrw, arw))
    v = fit.verdict
    return TableFreePlan(v.names, v.sigma, v.separable, len(fit.used), v, fit.earth_rate)
