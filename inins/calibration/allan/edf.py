"""Equivalent degrees of freedom of the Allan, modified and total variances.

Greenhall & Riley, "Uncertainty of stability variances based on finite differences",
PTTI 2003 (the algorithm of Stable32; their eqs. 7-13 and Tables 1-3) for the Allan
and modified variances, NIST SP 1065 Table 7 for the total variance. They assume one
power-law noise ``S_y(f) ~ f^alpha`` at each tau (the overview:
:mod:`inins.calibration.allan`).
"""

import functools
import math

import numpy as np

# --------------------------------------------------------------------------- edf


def _sw(t, alpha):
    """Greenhall & Riley eq. 7: generalised autocovariance of the power-law phase."""
    t = np.asarray(t, dtype=float)
    a = np.abs(t)
    with np.errstate(divide="ignore", invalid="ignore"):
        log = np.where(a > 0, np.log(np.where(a > 0, a, 1.0)), 0.0)
    table = {
        2: -a,
        1: t**2 * log,
        0: a**3,
        -1: t**4 * log,
        -2: a**5,
        -3: t**6 * log,
        -4: a**7,
    }
    return table[int(alpha)]


def _sx(t, f, alpha):
    """Eq. 8: the filter of length 1/F applied (F infinite: the limit sw(t, alpha+2))."""
    if math.isinf(f):
        return _sw(t, alpha + 2)
    return f * f * (2.0 * _sw(t, alpha) - _sw(t - 1.0 / f, alpha) - _sw(t + 1.0 / f, alpha))


def _sz(t, f, alpha, d):
    """Eq. 9: the d-th difference, ``sum_k (-1)^k C(2d, d+k) sx(t + k)``."""
    return sum(
        (-1) ** abs(k) * math.comb(2 * d, d + k) * _sx(t + k, f, alpha) for k in range(-d, d + 1)
    )


def _basic_sum(j, big_m, s, f, alpha, d):
    """Eq. 10."""
    lags = np.arange(1, int(j))
    total = _sz(0.0, f, alpha, d) ** 2 + (1.0 - j / big_m) * _sz(j / s, f, alpha, d) ** 2
    if lags.size:
        total = total + np.sum(2.0 * (1.0 - lags / big_m) * _sz(lags / s, f, alpha, d) ** 2)
    return float(total)


_TABLE1 = {  # modified variances, large r: (a0, a1) for d = 1, 2, 3 (G&R Table 1)
    2: ((2 / 3, 1 / 3), (7 / 9, 1 / 2), (22 / 25, 2 / 3)),
    1: ((0.840, 0.345), (0.997, 0.616), (1.141, 0.843)),
    0: ((1.079, 0.368), (1.033, 0.607), (1.184, 0.848)),
    -1: (None, (1.048, 0.534), (1.180, 0.816)),
    -2: (None, (1.302, 0.535), (1.175, 0.777)),
    -3: (None, None, (1.194, 0.703)),
    -4: (None, None, (1.489, 0.702)),
}
_TABLE2 = {  # unmodified variances, large r (G&R Table 2)
    2: ((3 / 2, 1 / 2), (35 / 18, 1.0), (231 / 100, 3 / 2)),
    1: ((78.6, 25.2), (790.0, 410.0), (9950.0, 6520.0)),
    0: ((2 / 3, 1 / 6), (2 / 3, 1 / 3), (7 / 9, 1 / 2)),
    -1: (None, (0.852, 0.375), (0.997, 0.617)),
    -2: (None, (1.079, 0.368), (1.033, 0.607)),
    -3: (None, None, (1.053, 0.553)),
    -4: (None, None, (1.302, 0.535)),
}
_TABLE3 = ((6.0, 4.0), (15.23, 12.0), (47.8, 40.0))  # alpha = 1, unmodified (G&R Table 3)
J_MAX = 100


@functools.lru_cache(maxsize=4096)
def edf_greenhall(alpha, m, n, kind="adev", d=2, overlapping=True, starts=None):
    """Equivalent degrees of freedom (Greenhall & Riley 2003, eqs. 7-13, Tables 1-3).

    alpha: power-law exponent (+2 .. -4, alpha + 2 d > 1); m averaging factor; n number
    of phase points; kind ``adev`` (unmodified, F = m) or ``mdev`` (modified, F = 1);
    d = 2 for the Allan variances; overlapping: S = m starts per m (else 1); ``starts``
    another S (the streaming estimator's decimated tau use S = M starts per m).
    """
    modified = kind == "mdev"
    f = 1.0 if modified else float(m)
    s = float(starts) if starts is not None else (float(m) if overlapping else 1.0)
    if alpha + 2 * d <= 1:
        raise ValueError(f"edf undefined for alpha {alpha} with d {d}")
    length = m / f + m * d
    big_m = 1.0 + math.floor(s * (n - length) / m)
    j = min(big_m, (d + 1) * s)
    r = big_m / s
    if modified:
        if j <= J_MAX:
            return _sz(0.0, 1.0, alpha, d) ** 2 * big_m / _basic_sum(j, big_m, s, 1.0, alpha, d)
        if r > d + 1:
            a0, a1 = _TABLE1[alpha][d - 1]
            return r / (a0 - a1 / r)
        mp = J_MAX / r
        return _sz(0.0, 1.0, alpha, d) ** 2 * J_MAX / _basic_sum(J_MAX, J_MAX, mp, 1.0, alpha, d)
    if alpha <= 0:
        if j <= J_MAX:
            fp = float(m) if m * (d + 1) <= J_MAX else math.inf
            return _sz(0.0, fp, alpha, d) ** 2 * big_m / _basic_sum(j, big_m, s, fp, alpha, d)
        if r > d + 1:
            a0, a1 = _TABLE2[alpha][d - 1]
            return r / (a0 - a1 / r)
        mp = J_MAX / r
        return (
            _sz(0.0, math.inf, alpha, d) ** 2
            * J_MAX
            / _basic_sum(J_MAX, J_MAX, mp, math.inf, alpha, d)
        )
    if alpha == 1:
        if j <= J_MAX:
            return _sz(0.0, float(m), 1, d) ** 2 * big_m / _basic_sum(j, big_m, s, float(m), 1, d)
        b0, b1 = _TABLE3[d - 1]
        if r > d + 1:
            a0, a1 = _TABLE2[1][d - 1]
            return (b0 + b1 * math.log(m)) ** 2 * r / (a0 - a1 / r)
        mp = J_MAX / r
        return (b0 + b1 * math.log(m)) ** 2 * J_MAX / _basic_sum(J_MAX, J_MAX, mp, mp, 1, d)
    # alpha = 2, unmodified: eq. 13 closed form (r > d)
    a0 = math.comb(4 * d, 2 * d) / math.comb(2 * d, d) ** 2
    a1 = d / 2.0
    return big_m / (a0 - a1 / r)


_TABLE7 = {0: (1.50, 0.0), -1: (1.17, 0.22), -2: (0.93, 0.36)}
"""Total variance edf = b N / m - c (NIST SP 1065 Table 7)."""


def edf_totdev(alpha, m, n):
    """Total-variance edf: ``b (n/m) - c`` (SP 1065 Table 7) for alpha 0, -1, -2;
    other alpha fall back to the Allan edf (stated in the report)."""
    if alpha in _TABLE7:
        b, c = _TABLE7[alpha]
        return b * (n / m) - c
    return edf_greenhall(alpha, m, n, "adev")


def edf_for(kind, alpha, m, n, starts=None):
    """edf of deviation ``kind`` (:data:`KINDS`) at alpha, m, n phase points (``starts``
    per m where not all m of them are used: :func:`edf_greenhall`).

    alpha below -2 (rate ramp) is taken as -2 for the Allan variances (d = 2 needs
    alpha > -3)."""
    alpha = max(int(alpha), -2)
    if kind == "totdev":
        return edf_totdev(alpha, m, n)
    return edf_greenhall(
        alpha,
        m,
        n,
        "mdev" if kind == "mdev" else "adev",
        overlapping=kind != "adev",
        starts=starts,
    )
