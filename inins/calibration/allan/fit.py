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
        The model lies within the curve's interval at ``check_confidence``, with the
        edf capped at :data:`EDF_CAP` as in the fit (a point is not asked to agree
        better than 4.5 % in variance).
    chi2_per_dof : float
        Weighted residual sum of squares per degree of freedom.
    """

    terms: tuple
    model: np.ndarray
    inside: np.ndarray
    chi2_per_dof: float

    def term(self, name):
        """The term called ``name``."""
        return next(t for t in self.terms if t.name == name)

    @property
    def reproduces(self):
        """The model lies within the curve's interval at all but a tenth of the fitted tau."""
        fitted = self.inside[np.isfinite(self.model)]
        return bool(fitted.mean() >= 0.9) if fitted.size else False


EDF_CAP = 1000.0
"""The fit weighs no tau as if it had more degrees of freedom than this (a relative
sd of 4.5 % in the variance): real curves are not exactly the five-term model, and
the thousands of degrees of freedom at the shortest tau would otherwise decide the
whole fit."""
MIN_DOMINANT_EDF = 30.0
"""A term whose dominant tau hold fewer degrees of freedom than this gets the interval
[0, bound] (see fit_terms)."""
CORRELATION_INFLATION = 2.0
"""Variance factor for the correlation of overlapping Allan estimates at neighbouring
octave tau: the least-squares covariance treats the points as independent; with
the overlap each point shares about half its information with its neighbours, so the
fit's parameter variance is widened by this factor (coverage measured in the tests)."""


def nnls(a, b):
    """Non-negative least squares ``min |a x - b|, x >= 0`` for a few unknowns (here at
    most 5): the least-squares solution of every subset of columns, the best one with
    no negative coefficient (exact; 2^n small solves instead of scipy.optimize, whose
    import costs more than a short run)."""
    n = a.shape[1]
    best, best_x = math.inf, np.zeros(n)
    for size in range(n + 1):
        for cols in itertools.combinations(range(n), size):
            x = np.zeros(n)
            if cols:
                sol = np.linalg.lstsq(a[:, cols], b, rcond=None)[0]
                if np.any(sol < 0):
                    continue
                x[list(cols)] = sol
            r = float(np.sum((a @ x - b) ** 2))
            if r < best * (1 - 1e-12):
                best, best_x = r, x
    return best_x


def fit_terms(dev, channel=0, confidence=0.95, check_confidence=0.95, use=TERMS):
    """Fit the IEEE five-term model to one channel of a :class:`Deviation`.

    Weighted non-negative least squares on the Allan variance ``s2(tau) = A c``
    (:func:`basis`, c the squared coefficients), weights ``edf / (2 s2_model^2)``
    (edf capped at :data:`EDF_CAP`), six passes re-weighting on the model. The
    covariance ``(A' W A)^-1`` of the terms the fit keeps (times
    :data:`CORRELATION_INFLATION`) gives each squared coefficient a normal interval at
    ``confidence`` (its variance also multiplied by the residual chi-square per degree
    of freedom where that exceeds 1, the Birge ratio: the curve is then not the model
    and the scatter says how far), taken to the coefficient by the square root
    (clipped at 0). A term left out of the model, or whose dominant tau hold
    fewer than :data:`MIN_DOMINANT_EDF` degrees of freedom (a chi-square of few degrees
    is far from normal), gets the interval from 0 to the largest coefficient whose variance
    alone stays below the curve's upper limit at every tau. ``use`` restricts the
    terms fitted.
    """
    tau = dev.tau
    s2 = dev.dev[:, channel] ** 2
    edf = np.maximum(dev.edf[:, channel], 1.0)
    good = np.isfinite(s2) & (s2 > 0)
    tau, s2, edf = tau[good], s2[good], edf[good]
    cols = [TERMS.index(u) for u in use]
    a_full = basis(tau)
    a = a_full[:, cols]
    model = s2.copy()
    coef = np.zeros(len(cols))
    weight_edf = np.minimum(edf, EDF_CAP)
    for _ in range(6):
        w = np.sqrt(weight_edf / 2.0) / model
        scale = np.linalg.norm(a * w[:, None], axis=0)
        scale[scale == 0] = 1.0
        sol = nnls(a * w[:, None] / scale, s2 * w)
        coef = sol / scale
        model = np.maximum(a @ coef, 1e-300)
    w2 = weight_edf / (2.0 * model**2)
    resid = (s2 - model) * np.sqrt(w2)
    active = coef > 0
    dof = max(1, tau.size - int(active.sum()))
    birge = max(1.0, float(resid @ resid / dof))
    cov = np.zeros((len(cols), len(cols)))
    if active.any():
        aa = a[:, active]
        info = aa.T @ (aa * w2[:, None])
        try:
            cov_a = np.linalg.inv(info) * CORRELATION_INFLATION * birge
        except np.linalg.LinAlgError:
            cov_a = np.linalg.pinv(info) * CORRELATION_INFLATION * birge
        cov[np.ix_(active, active)] = cov_a
    z = NormalDist().inv_cdf(0.5 + confidence / 2.0)
    share = (a * coef) / model[:, None]
    # the check allows each point the scatter the fit allows it (edf capped)
    lo_dev, hi_dev = chi2_interval(np.sqrt(s2), weight_edf, check_confidence)
    inside = (np.sqrt(model) >= lo_dev) & (np.sqrt(model) <= hi_dev)
    _, hi_curve = chi2_interval(np.sqrt(s2), edf, confidence)
    bound = np.min(hi_curve[:, None] ** 2 / a, axis=0)
    terms = []
    for i, c in enumerate(cols):
        dom = share[:, i] >= 0.5
        rng = (float(tau[dom].min()), float(tau[dom].max())) if dom.any() else None
        if not active[i] or edf[dom].sum() < MIN_DOMINANT_EDF:
            # shown with too few degrees of freedom: only a bound, 0 up to the largest
            # coefficient the curve's upper limit allows at every tau
            lo, hi = 0.0, math.sqrt(max(bound[i], coef[i]))
        else:
            sd = math.sqrt(max(cov[i, i], 0.0))
            lo = math.sqrt(max(coef[i] - z * sd, 0.0))
            hi = math.sqrt(coef[i] + z * sd)
        terms.append(Term(TERMS[c], math.sqrt(coef[i]), lo, hi, rng))
    full_model = np.full(dev.tau.size, np.nan)
    full_model[good] = np.sqrt(model)
    full_inside = np.zeros(dev.tau.size, dtype=bool)
    full_inside[good] = inside
    return Fit(tuple(terms), full_model, full_inside, float(resid @ resid / dof))


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
