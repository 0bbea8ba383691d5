"""IMU-GNSS time mapping fitted before the run, from the turn rate seen by both.

The IMU's yaw rate about the vertical, ``omega_D``, and the GNSS course rate,
``d/dt atan2(v_E, v_N)`` (where the speed exceeds ``min_speed``), are the same
signal on two time axes. In each window the lag ``L`` maximising their correlation
coefficient (grid search at ``step``, refined by a parabola through the peak and its
neighbours) is the GNSS time of an IMU instant minus that instant:
``t_gnss = t_imu + L(t)``. A straight line ``L(t) = a + b (t - t_ref)`` through the
window lags, weighted equally, gives the offset ``a`` at ``t_ref`` (stored on the IMU
axis) and the rate error
``b`` (a clock rate error of the IMU's time base: ``b = 1e-4`` is 100 ppm); their
1-sigma are those of the least-squares line from the scatter of the window lags
about it (with fewer than three windows: the mean lag, no rate, sigmas NaN).

A bias of the method: the course is the direction of the velocity of the antenna,
not of the vehicle's heading. A point a distance ``l`` ahead of the rear axle of a
car slips by ``beta = atan(l omega / v)``, so the course rate is
``omega + (l / v) omega'``: it leads the yaw rate by ``l / v`` (0.1 s for 1.5 m at
15 m/s) and the fitted lag comes out that much late. On the lc-drive car the
filter's offset state finds a residual 0.10-0.13 s of that sign (a line or a
piecewise mapping alike), which this would explain (the antenna's distance from the
rear axle is not in the data, so this is not verified).

The mapping model (one, chosen before the filter runs): a **constant offset** by
default, ``t_gnss = t_imu + a`` with ``a`` the mean of the window lags (1-sigma their
standard deviation over sqrt(n)) stated at ``t_ref``, the mean window centre; a
**rate** only when the data demand it (``model="auto"``): the line's rate ``b`` is kept
when its t statistic ``|b| / sigma_b`` exceeds the two-sided Student quantile
``t(1 - alpha/2, n - 2)`` of the false-alarm probability ``alpha`` (the F test of the
line against the constant, F = t^2, one numerator degree of freedom; Draper & Smith,
Applied Regression Analysis, sec. 1.4 / 6.1). The test is the split-halves check made
automatic: the lag's change from the first windows to the last compared with its own
scatter. On the lc-drive car the line's rate is -551 +- 418 ppm (t = 1.32 over 8
windows, threshold 3.71 at alpha = 0.01): a constant. Issue 33's check by the filter
agrees: run on each half of the drive separately, its residual offsets differ by
-0.3 ms with no rate and by -96 ms with the fitted one.

A constant residual offset is then a state of the loosely coupled filter
(:mod:`inins.ekf.loose`, ``time_offset``): this fit takes out the gross offset (and
a demanded rate), the state the rest with its Kalman 1-sigma.
"""

from dataclasses import dataclass

import numpy as np
from scipy import stats

from inins.exceptions import InputError

MODELS = ("auto", "constant", "line", "piecewise")
"""Mapping models of :func:`fit_clock`."""


@dataclass(frozen=True)
class RateTest:
    """The test of the line's rate against zero (module docstring): the fitted ``rate``
    and its 1-sigma ``sigma`` (s/s), ``t = |rate| / sigma``, the ``threshold`` it is
    compared with at the false-alarm probability ``alpha`` over ``dof`` degrees of
    freedom; ``significant`` when ``t`` exceeds it."""

    rate: float
    sigma: float
    t: float
    threshold: float
    alpha: float
    dof: int

    @property
    def significant(self):
        return bool(self.t > self.threshold)


@dataclass(frozen=True)
class ClockFit:
    """``t_gnss = t_imu + offset + rate (t_imu - t_ref)`` (s), ``t_ref`` on the IMU axis
    (:attr:`t_ref_gnss` on the GNSS axis); ``rate`` 0 for the ``constant`` model;
    ``lags`` per window (centre time, lag, correlation); ``rate_test`` the line's rate
    tested against zero (None with fewer than three windows). ``piecewise``: the lag
    interpolated between the window lags instead (held beyond the first and last),
    after dropping windows whose lag is more than 3 robust sigma (1.4826 MAD) from the
    median of it and its two neighbours."""

    offset: float
    offset_sigma: float
    rate: float
    rate_sigma: float
    t_ref: float
    lags: np.ndarray
    piecewise: bool = False
    model: str = "line"
    rate_test: RateTest | None = None

    @property
    def t_ref_gnss(self):
        """GNSS time (s) of the reference instant, at which ``offset`` holds."""
        return self.t_ref + self.offset

    def to_gnss(self, t_imu):
        """GNSS time of IMU times (s)."""
        t_imu = np.asarray(t_imu, float)
        if self.piecewise:
            keep = _inliers(self.lags[:, 1])
            centre, lag = self.lags[keep, 0], self.lags[keep, 1]
            return t_imu + np.interp(t_imu, centre - lag, lag)
        return t_imu + self.offset + self.rate * (t_imu - self.t_ref)

    def residual_rms(self):
        """RMS (s) of the window lags about the mapping: each window centre mapped back
        to the IMU axis by its own lag, then forward by the mapping."""
        centre, lag = self.lags[:, 0], self.lags[:, 1]
        return float(np.sqrt(np.mean((self.to_gnss(centre - lag) - centre) ** 2)))


def _inliers(lag):
    """Windows whose lag is within 3 robust sigma of the median of it and its neighbours."""
    if lag.size < 3:
        return np.ones(lag.size, bool)
    local = np.array([np.median(lag[max(i - 1, 0) : i + 2]) for i in range(lag.size)])
    dev = np.abs(lag - local)
    scale = max(1.4826 * float(np.median(dev)), 1e-3)
    return dev <= 3.0 * scale


def course_rate(time, vel_ned, min_speed=3.0):
    """GNSS course rate (rad/s) from NED velocities; zero where slower than ``min_speed``."""
    speed = np.hypot(vel_ned[:, 0], vel_ned[:, 1])
    course = np.unwrap(np.arctan2(vel_ned[:, 1], vel_ned[:, 0]))
    rate = np.gradient(course, time)
    rate[~(speed > min_speed)] = 0.0
    return rate


def _corr(a, b):
    a = a - a.mean()
    b = b - b.mean()
    den = np.sqrt(np.dot(a, a) * np.dot(b, b))
    return float(np.dot(a, b) / den) if den > 0 else 0.0


def window_lag(t_imu, rate_imu, t_gnss, rate_gnss, lo, hi, search, step=0.01, grid=0.01):
    """Lag (s) maximising the correlation over GNSS times ``[lo, hi)``; (lag, correlation)."""
    g = np.arange(lo, hi, grid)
    ref = np.interp(g, t_gnss, rate_gnss)
    lags = np.arange(search[0], search[1] + 0.5 * step, step)
    c = np.array([_corr(np.interp(g, t_imu + lag, rate_imu), ref) for lag in lags])
    k = int(np.argmax(c))
    if 0 < k < lags.size - 1:
        y0, y1, y2 = c[k - 1], c[k], c[k + 1]
        den = y0 - 2 * y1 + y2
        shift = 0.5 * (y0 - y2) / den if den < 0 else 0.0
        return float(lags[k] + shift * step), float(y1)
    return float(lags[k]), float(c[k])


def fit_clock(
    t_imu,
    rate_imu,
    t_gnss,
    rate_gnss,
    windows,
    search=(-10.0, 10.0),
    min_corr=0.8,
    model="auto",
    alpha=0.01,
):
    """Fit the time mapping over windows of GNSS time (module docstring).

    Parameters
    ----------
    t_imu, rate_imu : ndarray (n,)
        IMU times (its own axis, s) and yaw rate about the vertical (rad/s).
    t_gnss, rate_gnss : ndarray (m,)
        GNSS times and course rate (rad/s).
    windows : sequence of (lo, hi)
        GNSS-time windows (s), each with turns in it.
    search : (float, float)
        Lag range searched (s).
    min_corr : float
        Windows whose peak correlation is below are dropped.
    model : {"auto", "constant", "line", "piecewise"}
        ``auto``: the constant offset unless the line's rate passes the test at
        ``alpha`` (module docstring); ``piecewise``: the window lags interpolated
        (:class:`ClockFit`).
    alpha : float
        False-alarm probability of the rate test (1).

    Returns
    -------
    ClockFit
    """
    if model not in MODELS:
        raise ValueError(f"model {model!r} not in {MODELS}")
    rows = []
    for lo, hi in windows:
        coarse, _ = window_lag(t_imu, rate_imu, t_gnss, rate_gnss, lo, hi, search, step=0.05)
        fine, c = window_lag(
            t_imu, rate_imu, t_gnss, rate_gnss, lo, hi, (coarse - 0.1, coarse + 0.1), step=0.002
        )
        if c >= min_corr:
            rows.append((0.5 * (lo + hi), fine, c))
    if not rows:
        raise InputError(
            "no window where the IMU turn rate and the GNSS course rate correlate "
            f"(>= {min_corr}): cannot find the time mapping",
            key="time_offset",
        )
    lags = np.array(rows)
    n = len(rows)
    t_ref = float(np.mean(lags[:, 0]))
    piecewise = model == "piecewise"
    if n < 3:
        off = float(np.mean(lags[:, 1]))
        kind = "piecewise" if piecewise else "constant"
        return ClockFit(off, np.nan, 0.0, np.nan, t_ref - off, lags, piecewise, kind)
    off, off_sigma, test = line_fit(lags[:, 0] - t_ref, lags[:, 1], alpha)
    if model == "constant" or (model == "auto" and not test.significant):
        # the mean lag (the line's offset at the mean centre), its scatter about the mean
        sigma = float(np.std(lags[:, 1], ddof=1) / np.sqrt(n))
        return ClockFit(off, sigma, 0.0, np.nan, t_ref - off, lags, False, "constant", test)
    kind = "piecewise" if piecewise else "line"
    # the reference instant on the IMU axis
    return ClockFit(off, off_sigma, test.rate, test.sigma, t_ref - off, lags, piecewise, kind, test)


def line_fit(x, y, alpha=0.01):
    """Least-squares line ``y = a + b x`` through ``n >= 3`` points (``x`` centred by the
    caller: ``a`` is then the mean of ``y``); the 1-sigma from the scatter about it.

    Returns
    -------
    (float, float, RateTest)
        ``a``, its 1-sigma, and the t test of ``b`` against zero at the false-alarm
        probability ``alpha`` (module docstring).
    """
    n = len(x)
    A = np.column_stack([np.ones(n), x])
    coef, *_ = np.linalg.lstsq(A, y, rcond=None)
    res = y - A @ coef
    cov = float(res @ res) / (n - 2) * np.linalg.inv(A.T @ A)
    rate, rate_sigma = float(coef[1]), float(np.sqrt(cov[1, 1]))
    t_stat = abs(rate) / rate_sigma if rate_sigma > 0 else np.inf
    threshold = float(stats.t.ppf(1 - alpha / 2, n - 2))
    test = RateTest(rate, rate_sigma, float(t_stat), threshold, alpha, n - 2)
    return float(coef[0]), float(np.sqrt(cov[0, 0])), test
