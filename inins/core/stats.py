"""Chi-square quantiles without scipy: thresholds of the statistical tests.

``scipy.stats`` (and even ``scipy.special``) costs 0.5 s or more to import, more
than a short run computes, for one constant per test. The quantile is found here
from the regularised lower incomplete gamma function P(k/2, x/2), the chi-square
distribution function (Abramowitz & Stegun 26.4.19), evaluated by its power series
below a + 1 and its continued fraction above (A&S 6.5.29, 6.5.31; the Lentz
evaluation of Press et al., Numerical Recipes §6.2), and inverted by safeguarded
Newton steps from the Wilson-Hilferty approximation (A&S 26.4.17). Agrees with
``scipy.special.chdtri`` to about 1e-13 relative (tests/core/test_stats.py).
"""

import math

import numpy as np

__all__ = ["chi2_cdf", "chi2_ppf"]

_EPS = 1e-15
_TINY = 1e-300


def _regularised_gammas(a: float, x: float) -> tuple:
    """(P, Q): P(a, x) = γ(a, x) / Γ(a) and Q = 1 - P, for a > 0, x >= 0, each
    to full relative precision where it is the smaller of the two."""
    if x <= 0.0:
        return 0.0, 1.0
    log_prefactor = a * math.log(x) - x - math.lgamma(a)
    if x < a + 1.0:  # series: P = e^-x x^a / Γ(a+1) Σ x^n / ((a+1)...(a+n))
        term = total = 1.0 / a
        denominator = a
        for _ in range(10_000 + int(50.0 * math.sqrt(a))):
            denominator += 1.0
            term *= x / denominator
            total += term
            if abs(term) < abs(total) * _EPS:
                break
        lower = min(1.0, total * math.exp(log_prefactor))
        return lower, 1.0 - lower
    # continued fraction for Q = 1 - P (modified Lentz)
    b = x + 1.0 - a
    c = 1.0 / _TINY
    d = 1.0 / b
    h = d
    for i in range(1, 10_000 + int(50.0 * math.sqrt(a))):
        an = -i * (i - a)
        b += 2.0
        d = an * d + b
        d = _TINY if abs(d) < _TINY else d
        c = b + an / c
        c = _TINY if abs(c) < _TINY else c
        d = 1.0 / d
        delta = d * c
        h *= delta
        if abs(delta - 1.0) < _EPS:
            break
    upper = min(1.0, math.exp(log_prefactor) * h)
    return 1.0 - upper, upper


def chi2_cdf(x: float, dof: float) -> float:
    """Distribution function of the chi-square law with ``dof`` degrees of freedom."""
    if dof <= 0:
        raise ValueError(f"degrees of freedom must be > 0, got {dof}")
    return _regularised_gammas(0.5 * dof, 0.5 * x)[0]


def _ppf(p: float, k: float) -> float:
    if not 0.0 <= p <= 1.0:
        return math.nan
    if p == 0.0:
        return 0.0
    if p == 1.0:
        return math.inf
    # Wilson-Hilferty start: (k (1 - 2/(9k) + z sqrt(2/(9k)))^3, z the normal quantile
    z = _normal_ppf(p)
    s = 2.0 / (9.0 * k)
    x = k * max(1.0 - s + z * math.sqrt(s), 0.05) ** 3
    lo, hi = 0.0, math.inf
    a = 0.5 * k
    upper_tail = p > 0.5  # solve Q(x) = 1 - p there (1 - p is exact; 1 - Q is not)
    q = 1.0 - p
    for _ in range(200):
        lower, upper = _regularised_gammas(a, 0.5 * x)
        f = lower - p if not upper_tail else q - upper
        if f < 0.0:
            lo = x
        else:
            hi = x
        # density of chi-square: x^(a-1) e^(-x/2) / (2^a Γ(a))
        log_pdf = (a - 1.0) * math.log(x) - 0.5 * x - a * math.log(2.0) - math.lgamma(a)
        step = f / math.exp(log_pdf) if log_pdf > -700.0 else math.inf
        candidate = x - step
        if not lo < candidate < hi:  # Newton left the bracket: bisect
            candidate = 0.5 * (lo + hi) if math.isfinite(hi) else 2.0 * x
        if abs(candidate - x) <= 4.0 * _EPS * x:
            return candidate
        x = candidate
    return x


def _normal_ppf(p: float) -> float:
    """Standard normal quantile (Acklam's rational approximation, ~1e-9; a start only)."""
    a = (-39.69683028665376, 220.9460984245205, -275.9285104469687, 138.3577518672690)
    a += (-30.66479806614716, 2.506628277459239)
    b = (-54.47609879822406, 161.5858368580409, -155.6989798598866, 66.80131188771972)
    b += (-13.28068155288572,)
    c = (-0.007784894002430293, -0.3223964580411365, -2.400758277161838)
    c += (-2.549732539343734, 4.374664141464968, 2.938163982698783)
    d = (0.007784695709041462, 0.3224671290700398, 2.445134137142996, 3.754408661907416)
    if p < 0.02425:
        q = math.sqrt(-2.0 * math.log(p))
        num = ((((c[0] * q + c[1]) * q + c[2]) * q + c[3]) * q + c[4]) * q + c[5]
        return num / ((((d[0] * q + d[1]) * q + d[2]) * q + d[3]) * q + 1.0)
    if p > 1.0 - 0.02425:
        return -_normal_ppf(1.0 - p)
    q = p - 0.5
    r = q * q
    num = (((((a[0] * r + a[1]) * r + a[2]) * r + a[3]) * r + a[4]) * r + a[5]) * q
    return num / (((((b[0] * r + b[1]) * r + b[2]) * r + b[3]) * r + b[4]) * r + 1.0)


def chi2_ppf(p, dof):
    """Quantile of the chi-square law: x with P(χ²_dof <= x) = p.

    Parameters
    ----------
    p : float or array_like
        Probability in [0, 1] (outside: NaN).
    dof : float or array_like
        Degrees of freedom, > 0 (broadcast against ``p``).

    Returns
    -------
    float or ndarray
        A float for scalar arguments, else an array of the broadcast shape.
    """
    p_arr, dof_arr = np.broadcast_arrays(np.asarray(p, float), np.asarray(dof, float))
    if np.any(dof_arr <= 0) or not np.all(np.isfinite(dof_arr)):
        raise ValueError(f"degrees of freedom must be finite and > 0, got {dof}")
    pairs = p_arr.ravel() + 1j * dof_arr.ravel()  # one number per (p, dof) pair
    unique, inverse = np.unique(pairs, return_inverse=True)  # few distinct dof
    values = np.array([_ppf(float(z.real), float(z.imag)) for z in unique])
    out = values[inverse.ravel()].reshape(p_arr.shape)
    return float(out) if out.ndim == 0 else out
