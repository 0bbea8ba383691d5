"""The IEEE Std 952-1997 five-term fit of an Allan deviation (Annex C, Table C.1), and
increments with the five terms for tests (the model and its units: the "Noise terms"
part of :mod:`inins.calibration.allan`).
"""

import itertools
import math
from dataclasses import dataclass
from statistics import NormalDist

import numpy as np

from inins.calibration.allan.deviation import chi2_interval

TERMS = ("quantization", "random_walk", "bias_instability", "rate_random_walk", "rate_ramp")
"""Names of the five IEEE terms, in the order of their slope -1, -1/2, 0, +1/2, +1."""
SLOPES = (-1.0, -0.5, 0.0, 0.5, 1.0)
"""Log-log slope of the deviation of each term."""
BIAS_FACTOR = math.sqrt(2.0 * math.log(2.0) / math.pi)
"""0.664: the flat Allan deviation of a bias instability B is 0.664 B."""


def basis(tau):
    """Allan variance per unit squared coefficient of each term, shape (j, 5)."""
    tau = np.asarray(tau, dtype=float)
    return np.stack(
        [3.0 / tau**2, 1.0 / tau, np.full_like(tau, BIAS_FACTOR**2), tau / 3.0, tau**2 / 2.0],
        axis=-1,
    )


# --------------------------------------------------------------------------- fit


@dataclass(frozen=True)
class Term:
    """One fitted noise term of one channel (SI).

    Attributes
    ----------
    name : str
        One of :data:`TERMS`.
    value : float
        Coefficient (Q rad, N rad/sqrt(s), B rad/s, K rad/s/sqrt(s), R rad/s^2; for an
        accelerometer m/s in place of rad); 0 when the fit leaves it out.
    lo, hi : float
        Its interval at the fit's confidence.
    tau_range : tuple
        (first, last) tau (s) where it carries at least half the model variance, or
        None when it dominates nowhere (then the value is a bound, not a measurement).
    """

    name: str
    value: float
    lo: float
    hi: float
    tau_range: tuple | None

    @property
    def resolved(self):
        """True when the curve shows this term somewhere."""
        return self.tau_range is not None


@dataclass(frozen=True)
class Fit:
    """The five-term fit of one channel.

    Attributes
    ----------
    terms : tuple of Term
    model : ndarray (j,)
        Model deviation at each tau of the curve.
    inside : ndarray of bool (j,)
        The model lies within the curve's interval at ``check_confidence`` (per tau, for
        the report and the figure).
    chi2_per_dof : float
        Residual chi-square per degree of freedom with the full covariance of the
        estimates (correlated across tau: :mod:`inins.calibration.allan.covariance`).
    dof : int
    p_value : float
        Probability of a chi-square at least this large if the curve were the model.
    """

    terms: tuple
    model: np.ndarray
    inside: np.ndarray
    chi2_per_dof: float
    dof: int = 1
    p_value: float = 1.0

    def term(self, name):
        """The term called ``name``."""
        return next(t for t in self.terms if t.name == name)

    @property
    def reproduces(self):
        """The curve is the model by the fit's own statistic: the chi-square of the
        residuals below its 99 % point (``p_value >= 0.01``)."""
        return bool(self.p_value >= MODEL_P)


EDF_CAP = 1000.0
"""The fit weighs no tau as if it had more degrees of freedom than this (a relative
sd of 4.5 % in the variance): real curves are not exactly the five-term model, and
the thousands of degrees of freedom at the shortest tau would otherwise decide the
whole fit (the covariance of the estimate uses the true edf)."""
MIN_DOMINANT_EDF = 30.0
"""A term whose dominant tau hold fewer degrees of freedom than this gets the interval
[0, bound] (see fit_terms)."""
MODEL_P = 0.01
"""The model check: a chi-square beyond its 1 - MODEL_P point rejects the model."""


def nnls(a, b, upper=None):
    """Bounded least squares ``min |a x - b|, 0 <= x <= upper`` for a few unknowns (here
    at most 5): every assignment of each unknown to its lower bound, its upper bound or
    free, the best feasible one (exact; 3^n small solves instead of scipy.optimize, whose
    import costs more than a short run). ``upper`` None: no upper bounds."""
    n = a.shape[1]
    upper = np.full(n, np.inf) if upper is None else np.asarray(upper, float)
    best, best_x = math.inf, np.zeros(n)
    states = [(0, 2) if np.isfinite(upper[i]) else (0,) for i in range(n)]
    for fixed in itertools.product(*[(None, *s) for s in states]):
        x = np.zeros(n)
        for i, f in enumerate(fixed):
            if f == 2:
                x[i] = upper[i]
        free = [i for i, f in enumerate(fixed) if f is None]
        if free:
            sol = np.linalg.lstsq(a[:, free], b - a @ x, rcond=None)[0]
            if np.any(sol < 0) or np.any(sol > upper[free]):
                continue
            x[free] = sol
        r = float(np.sum((a @ x - b) ** 2))
        if r < best * (1 - 1e-12):
            best, best_x = r, x
    return best_x


def _curve_bounds(a, s2, edf, confidence):
    """Largest squared coefficient of each term whose variance alone stays within the
    curve's upper limit at every tau (the curve allows no more). The limit of each tau
    is taken at ``1 - (1 - confidence) / (10 j)`` (Bonferroni: the bound cuts the truth
    with a tenth of the interval's own risk over all j tau together; at ``confidence``
    each, one of twenty tau would dip below the truth by chance and cut a white noise
    short)."""
    risk = (1.0 - confidence) / (10 * max(s2.size, 1))
    _, hi = chi2_interval(np.sqrt(s2), edf, 1.0 - risk)
    return np.min(hi[:, None] ** 2 / a, axis=0)


def _covariance(a, coef, model, s2, w2, edf, ms, cols, active):
    """Sandwich covariance of the squared coefficients ``(A'WA)^-1 A'W S W A (A'WA)^-1``
    with ``S`` the covariance of the Allan variance estimates (variance ``2 s2^2 / edf``,
    correlation across tau from :func:`inins.calibration.allan.covariance.correlation`),
    the residual chi-square and its degrees of freedom. The chi-square takes each
    variance with the edf capped at :data:`EDF_CAP` as the fit weighs it (the model is not
    asked to agree with a point better than the fit asks it to)."""
    from inins.calibration.allan.covariance import TERMS as STOCHASTIC
    from inins.calibration.allan.covariance import correlation

    shares = np.zeros((s2.size, 4))
    for k, c in enumerate(cols):
        if TERMS[c] in STOCHASTIC:
            shares[:, STOCHASTIC.index(TERMS[c])] = a[:, k] * coef[k]
    rho = correlation(ms, shares)
    sd = np.sqrt(2.0 / edf) * model
    cov_s = rho * np.outer(sd, sd)
    sd_check = np.sqrt(2.0 / np.minimum(edf, EDF_CAP)) * model
    resid = s2 - model
    dof = max(1, s2.size - int(active.sum()))
    check = rho * np.outer(sd_check, sd_check)
    try:
        chi2 = float(resid @ np.linalg.solve(check, resid))
    except np.linalg.LinAlgError:
        chi2 = float(resid @ np.linalg.lstsq(check, resid, rcond=None)[0])
    cov = np.zeros((len(cols), len(cols)))
    if active.any():
        aa = a[:, active]
        info = aa.T @ (aa * w2[:, None])
        gain = np.linalg.pinv(info) @ (aa * w2[:, None]).T
        cov[np.ix_(active, active)] = gain @ cov_s @ gain.T
    return cov, chi2, dof


def fit_terms(dev, channel=0, confidence=0.95, check_confidence=0.95, use=TERMS):
    """Fit the IEEE five-term model to one channel of a :class:`Deviation`.

    Weighted least squares on the Allan variance ``s2(tau) = A c`` (:func:`basis`, c the
    squared coefficients), weights ``edf / (2 s2_model^2)`` (edf capped at
    :data:`EDF_CAP`), six passes re-weighting on the model, each coefficient bounded by
    ``0 <= c_i <= u_i``: ``u_i`` the largest squared coefficient whose variance alone
    stays within the curve's upper limit at every tau (:func:`_curve_bounds`), so that no
    fitted term exceeds what the curve allows. The covariance of the coefficients is the
    sandwich of the weighted fit with the full covariance of the estimates (correlated
    across tau for the fitted mixture of noises: :func:`_covariance`; a random-walk rate
    correlates neighbouring octaves by 0.9, white rate by 0.5), multiplied by the residual
    chi-square per degree of freedom where the chi-square rejects the model
    (:data:`MODEL_P`). Each squared coefficient gets a normal interval at ``confidence``,
    taken to the coefficient by the square root (clipped at 0, and at the curve's bound).
    A term left out of the model, or whose dominant tau hold fewer than
    :data:`MIN_DOMINANT_EDF` degrees of freedom (a chi-square of few degrees is far from
    normal), gets the interval from 0 to its curve bound. ``use`` restricts the terms.
    The model check is the chi-square (:attr:`Fit.reproduces`).
    """
    from inins.core.stats import chi2_cdf, chi2_ppf

    tau = dev.tau
    s2 = dev.dev[:, channel] ** 2
    edf = np.maximum(dev.edf[:, channel], 1.0)
    good = np.isfinite(s2) & (s2 > 0)
    tau, s2, edf, ms = tau[good], s2[good], edf[good], dev.m[good]
    cols = [TERMS.index(u) for u in use]
    a = basis(tau)[:, cols]
    bound = _curve_bounds(a, s2, edf, confidence)
    model = s2.copy()
    coef = np.zeros(len(cols))
    weight_edf = np.minimum(edf, EDF_CAP)
    for _ in range(6):
        w = np.sqrt(weight_edf / 2.0) / model
        scale = np.linalg.norm(a * w[:, None], axis=0)
        scale[scale == 0] = 1.0
        coef = nnls(a * w[:, None] / scale, s2 * w, bound * scale) / scale
        model = np.maximum(a @ coef, 1e-300)
    w2 = weight_edf / (2.0 * model**2)
    active = coef > 0
    # the covariance over every fitted term, those at 0 or at their bound too: which
    # terms a noisy curve switches on moves the others (white noise alone: the random
    # walk's estimate scatters 4x more than the covariance of the active terms says)
    cov, chi2, dof = _covariance(a, coef, model, s2, w2, edf, ms, cols, np.ones(len(cols), bool))
    dof = max(1, s2.size - int(active.sum()))
    if chi2 > float(chi2_ppf(1.0 - MODEL_P, dof)):
        cov = cov * (chi2 / dof)
    z = NormalDist().inv_cdf(0.5 + confidence / 2.0)
    share = (a * coef) / model[:, None]
    lo_dev, hi_dev = chi2_interval(np.sqrt(s2), weight_edf, check_confidence)
    inside = (np.sqrt(model) >= lo_dev) & (np.sqrt(model) <= hi_dev)
    terms = []
    for i, c in enumerate(cols):
        dom = share[:, i] >= 0.5
        rng = (float(tau[dom].min()), float(tau[dom].max())) if dom.any() else None
        if coef[i] <= 0 or edf[dom].sum() < MIN_DOMINANT_EDF:
            lo, hi = 0.0, math.sqrt(bound[i])
        else:
            sd = math.sqrt(max(cov[i, i], 0.0))
            lo = math.sqrt(max(coef[i] - z * sd, 0.0))
            hi = math.sqrt(min(coef[i] + z * sd, bound[i]))
        terms.append(Term(TERMS[c], math.sqrt(coef[i]), lo, hi, rng))
    full_model = np.full(dev.tau.size, np.nan)
    full_model[good] = np.sqrt(model)
    full_inside = np.zeros(dev.tau.size, dtype=bool)
    full_inside[good] = inside
    p_value = float(1.0 - chi2_cdf(chi2, dof))
    return Fit(tuple(terms), full_model, full_inside, chi2 / dof, dof, p_value)


# --------------------------------------------------------------------------- simulation


def simulate_increments(
    rng, n, tau0, shape=(), q=0.0, arw=0.0, bias=0.0, rrw=0.0, ramp=0.0, span=4
):
    """Increments (n, *shape) of a sensor at rest with the five IEEE noise terms (SI).

    - ``arw`` N: white rate of density N (increments ``N sqrt(tau0)`` per sample);
    - ``bias`` B: flicker rate, one-sided PSD ``h/f`` with ``h = B^2 / pi`` (so the flat
      Allan variance is ``2 ln 2 h = (2 ln 2 / pi) B^2``, IEEE Std 952-1997 Table C.1), made by
      shaping white noise in the frequency domain over ``span`` times the record (the
      first part kept), so it is flicker down to ``1 / (span n tau0)``;
    - ``rrw`` K: a random-walk rate, steps ``K sqrt(tau0)``;
    - ``ramp`` R: a rate growing as ``R t``;
    - ``q`` Q: white angle noise, uniform over a pulse of ``sqrt(12) Q`` (the
      quantization error of a pulse output whose input moves by many pulses between
      readings), standard deviation Q: the increments get its first difference.
    """
    shape = tuple(shape)
    rate = np.zeros((n, *shape))
    if arw:
        rate += arw / math.sqrt(tau0) * rng.standard_normal((n, *shape))
    if bias:
        white = rng.standard_normal((span * n, *shape))
        spec = np.fft.rfft(white, axis=0)
        freq = np.fft.rfftfreq(span * n, tau0)
        gain = np.zeros_like(freq)
        gain[1:] = np.sqrt(bias**2 / math.pi / (freq[1:] * 2.0 * tau0))
        spec *= gain.reshape((-1,) + (1,) * len(shape))
        rate += np.fft.irfft(spec, span * n, axis=0)[:n]
        del white, spec
    if rrw:
        rate += np.cumsum(rrw * math.sqrt(tau0) * rng.standard_normal((n, *shape)), axis=0)
    if ramp:
        rate += (ramp * tau0 * np.arange(n)).reshape((-1,) + (1,) * len(shape))
    inc = rate * tau0
    if q:
        pulse = math.sqrt(12.0) * q
        error = pulse * (rng.random((n + 1, *shape)) - 0.5)
        inc += np.diff(error, axis=0)
    return inc
