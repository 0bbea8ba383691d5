"""Uncertainty budget of a tilt-formula bias estimate: the random part and the systematic
parts from the sensor errors the calibration does not estimate (issue 7 item 6).

Every gyro error is a body-frame rate error ``e(t)`` (rad/s) on top of the bias. By
eq. (1) of :mod:`.tilt_model` it enters a formula exactly like the bias and the noise do
(:func:`inins.calibration.tilt_model.arw_sigma`)::

    dF = int w(s) . e(s) ds,   w(s) = mat_bn(s) Phi(s) R(s)                         (6)

with the estimate's combined weights (its formulas solved for the bias), so (6) is the
error of the estimate directly. After a gyrocompass alignment the error during the
alignment also moves the initial heading, ``phi_D0 += (mat_nb e)_E / (W cos lat)``, seen
through the estimate's ``phi_gain[:, 2]``. The terms:

- accelerometer bias through levelling: a bias ``nabla`` tilts the levelled attitude by
  ``phi_N = nabla_E / g``, ``phi_E = -nabla_N / g``, and a gyrocompass turns the north tilt
  into a heading error ``phi_N omega_D / omega_N`` (the vertical Earth rate seen on the
  east axis): for eq. 38 about ``Omega_D nabla / g`` (4.6e-4 deg/h for 50 ug at 37 deg);
- the vertical gyro bias taken as known: ``e = delta_b_z`` along the vertical axis (the
  heading drift ``delta_b_z t`` tilts the east axis, ``~ delta_b_z Omega_N T / 2``);
- gyro scale factor: ``e_i = s_i omega_i(t)``, the table turns and the Earth rate
  (``Omega_N pi s_z / 2`` from the 180 deg turns for z);
- gyro misalignment: ``e_i = beta_ij omega_j(t)``;
- bias instability (first-order Gauss-Markov, sigma, tau): the estimate weighs the bias
  along the sequence by (6) (and over the alignment window through the heading), the
  truth is its plain mean over the navigation; the variance of the difference is the
  double integral of the weight difference against ``sigma^2 exp(-|s - s'| / tau)``.

All stated 1-sigma values are independent; the terms add in quadrature.
"""

from dataclasses import dataclass, field

import numpy as np

from inins.core import earth, rotation

TERMS = (
    "random",
    "accel_bias",
    "gyro_bias_z",
    "gyro_scale",
    "misalignment",
    "bias_instability",
)
"""Names of the budget terms, in report order."""

MISALIGNMENT_PAIRS = ((0, 1), (0, 2), (1, 0), (1, 2), (2, 0), (2, 1))
"""(gyro i, axis j) of ``beta_ij`` in the order ``[xy, xz, yx, yz, zx, zy]``."""

BI_GRID = 600
"""Bins of the bias-instability double integral (an O(n^2) sum)."""


@dataclass(frozen=True)
class StatedErrors:
    """1-sigma of the sensor errors calibrate-bias does not estimate (SI).

    Attributes
    ----------
    accel_bias : float
        Accelerometer bias per horizontal axis (m/s^2).
    gyro_bias_z : float
        Error of the vertical gyro bias taken as known (rad/s).
    gyro_scale : ndarray, shape (3,)
        Gyro scale-factor errors (1).
    gyro_misalignment : ndarray, shape (6,)
        ``beta_ij`` (rad), order of :data:`MISALIGNMENT_PAIRS`.
    bias_instability : float
        Gauss-Markov sigma of each gyro bias (rad/s).
    corr_time : float
        Its correlation time (s).
    """

    accel_bias: float = 0.0
    gyro_bias_z: float = 0.0
    gyro_scale: np.ndarray = field(default_factory=lambda: np.zeros(3))
    gyro_misalignment: np.ndarray = field(default_factory=lambda: np.zeros(6))
    bias_instability: float = 0.0
    corr_time: float = 3600.0


@dataclass(frozen=True)
class Budget:
    """1-sigma terms (rad/s) per horizontal axis of one estimate, ``terms[name]`` (2,)."""

    terms: dict

    @property
    def total(self):
        """Combined 1-sigma (rad/s), shape (2,): the terms in quadrature."""
        return np.sqrt(sum(np.asarray(v) ** 2 for v in self.terms.values()))


def body_rates(track):
    """True-rate proxy ``omega_ib_b`` (rad/s) on each output interval, shape (m - 1, 3):
    the computed attitude's turn over the interval plus the Earth rate."""
    dt = np.diff(track.time)[:, None]
    step = rotation.rotvec_from_mat(np.swapaxes(track.mat_nb[:-1], 1, 2) @ track.mat_nb[1:])
    w_ie = earth.rate_ie_n(track.lat)
    mid = 0.5 * (track.mat_nb[:-1] + track.mat_nb[1:])
    return step / dt + np.einsum("mji,j->mi", mid, w_ie)


def interval_weights(response, weights):
    """``w(s)`` of (6) at the middle of each output interval, shape (k, m - 1, 3).

    As in ``arw_sigma``, but ``Phi^T mat_nb`` is taken at the interval's middle: during a
    10 deg/s turn sampled at 10 Hz the end point is 0.5 deg off, which moves the turn
    integral of a misalignment error by ~1 % of itself (half of what is left after the
    two turns cancel)."""
    r = (response.phit_nb @ weights[..., None])[..., 0]
    tail = np.cumsum(r[:, ::-1], axis=1)[:, ::-1][:, 1:]
    mid = 0.5 * (response.phit_nb[1:] + response.phit_nb[:-1])
    return (np.swapaxes(mid, 1, 2) @ tail[..., None])[..., 0]


def rate_error_effect(ctx, est, rate_error, align_error=None, w=None):
    """Error of ``est`` (rad/s, (2,)) from a body rate error, by (6).

    Parameters
    ----------
    ctx : inins.calibration.methods.Context
    est : inins.calibration.methods.Estimate
        With tilt weights (combined).
    rate_error : ndarray, shape (m - 1, 3)
        ``e`` on each output interval (rad/s).
    align_error : ndarray, shape (3,), optional
        ``e`` during the alignment (moves a gyrocompass heading); default the first interval's.
    w : ndarray, shape (2, m - 1, 3), optional
        :func:`interval_weights` of ``est`` if already formed.
    """
    w = interval_weights(ctx.response, est.weights) if w is None else w
    dt = np.diff(ctx.track.time)
    effect = np.einsum("kmi,mi,m->k", w, rate_error, dt)
    align_error = rate_error[0] if align_error is None else align_error
    # the gyrocompass heading follows the error whatever the estimate assumed (eq. 45
    # assumes zero and carries it); ctx.heading_per_bias is zero for a known heading
    return effect + est.phi_gain[:, 2] * (ctx.heading_per_bias @ align_error)


def _accel_term(ctx, est, sigma):
    w_ie = earth.rate_ie_n(ctx.track.lat)
    g = earth.gravity(ctx.track.lat, 0.0)
    heading_per_tilt = w_ie[2] / w_ie[0] if ctx.gyrocompass else 0.0
    k_n = est.phi_gain[:, 0] + est.phi_gain[:, 2] * heading_per_tilt
    return sigma / g * np.hypot(k_n, est.phi_gain[:, 1])


def _bias_instability(ctx, est, w, align, sigma, tau):
    """1-sigma (2,) of the weighted bias minus its navigation mean, for a GM bias."""
    return instability_sigma(ctx, w, est.phi_gain[:, 2], align, sigma, tau, True)


def instability_sigma(ctx, w, heading_gain, align, sigma, tau, minus_mean):
    """1-sigma (k,) of ``int w . db ds + heading_gain (h . mean db over the alignment)``
    for a first-order Gauss-Markov bias ``db`` (sigma rad/s, tau s) on each gyro.

    Parameters
    ----------
    w : ndarray, shape (k, m - 1, 3)
        Interval weights (:func:`interval_weights`).
    heading_gain : ndarray, shape (k,)
        Sensitivity to the initial heading, moved by the bias during the alignment
        through the gyrocompass (``ctx.heading_per_bias``; zero for a known heading).
    align : (float, float)
        Alignment window (s).
    minus_mean : bool
        Subtract the mean bias over the navigation from row k's own axis (the truth an
        estimate is compared with); False for a residual that a constant bias leaves zero.
    """
    rows = w.shape[0]
    if sigma == 0.0:
        return np.zeros(rows)
    track = ctx.track
    t1 = track.time[-1]
    edges = np.linspace(align[0], t1, BI_GRID + 1)
    centre = 0.5 * (edges[1:] + edges[:-1])
    dt = np.diff(track.time)
    mid = 0.5 * (track.time[1:] + track.time[:-1])
    b = np.clip(np.searchsorted(edges, mid) - 1, 0, BI_GRID - 1)
    a = (centre < align[1]) & (centre >= align[0])
    nav = (centre >= track.time[0]) & (centre <= t1)
    kernel = np.exp(-np.abs(centre[:, None] - centre[None, :]) / tau)
    out = np.zeros(rows)
    for k in range(rows):
        var = 0.0
        for i in range(3):
            mass = np.bincount(b, w[k, :, i] * dt, minlength=BI_GRID)
            if ctx.gyrocompass and np.any(a):  # the alignment sets the heading
                mass[a] += heading_gain[k] * ctx.heading_per_bias[i] / np.count_nonzero(a)
            if minus_mean and i == track.horizontal[k]:
                mass[nav] -= 1.0 / np.count_nonzero(nav)
            var += mass @ kernel @ mass
        out[k] = sigma * np.sqrt(max(var, 0.0))
    return out


def budget(ctx, est, stated, align_window):
    """The uncertainty budget of one tilt-formula estimate.

    Parameters
    ----------
    ctx : inins.calibration.methods.Context
    est : inins.calibration.methods.Estimate
        ``est.sigma`` is the random term.
    stated : StatedErrors
    align_window : (float, float)
        Alignment window (s).

    Returns
    -------
    Budget
    """
    terms = {"random": np.asarray(est.sigma, float)}
    terms.update({t: np.zeros(2) for t in TERMS[1:]})
    gyro = (stated.gyro_bias_z, *stated.gyro_scale, *stated.gyro_misalignment)
    if not any(gyro) and stated.bias_instability == 0.0:
        terms["accel_bias"] = _accel_term(ctx, est, stated.accel_bias)
        return Budget(terms)
    w = interval_weights(ctx.response, est.weights)
    terms["accel_bias"] = _accel_term(ctx, est, stated.accel_bias)
    omega = body_rates(ctx.track)
    at_rest = np.einsum("ji,j->i", ctx.track.mat_nb[0], earth.rate_ie_n(ctx.track.lat))
    unit_z = np.zeros_like(omega)
    unit_z[:, ctx.track.down_axis] = 1.0
    z = np.zeros(3)
    z[ctx.track.down_axis] = 1.0
    terms["gyro_bias_z"] = stated.gyro_bias_z * np.abs(rate_error_effect(ctx, est, unit_z, z, w))
    scale = np.zeros(2)
    for i in range(3):
        if stated.gyro_scale[i] > 0.0:
            e, e0 = np.zeros_like(omega), np.zeros(3)
            e[:, i], e0[i] = omega[:, i], at_rest[i]
            scale = np.hypot(scale, stated.gyro_scale[i] * rate_error_effect(ctx, est, e, e0, w))
    terms["gyro_scale"] = scale
    mis = np.zeros(2)
    for (i, j), s in zip(MISALIGNMENT_PAIRS, stated.gyro_misalignment, strict=True):
        if s > 0.0:
            e, e0 = np.zeros_like(omega), np.zeros(3)
            e[:, i], e0[i] = omega[:, j], at_rest[j]
            mis = np.hypot(mis, s * rate_error_effect(ctx, est, e, e0, w))
    terms["misalignment"] = mis
    terms["bias_instability"] = _bias_instability(
        ctx, est, w, align_window, stated.bias_instability, stated.corr_time
    )
    return Budget(terms)
