"""Correlation of the overlapping Allan variances of one record at different tau, for a
mixture of the IEEE noise terms (the fit's covariance: :func:`inins.calibration.allan.fit_terms`).

The estimate at ``m`` is the mean of ``d_m(t)^2 / (2 tau^2)``, ``d_m(t) = x(t + 2m) -
2 x(t + m) + x(t)`` the second difference of the phase. For Gaussian noise and a record
long against the strides, ``cov(s2_a, s2_b)`` is proportional to ``S_ab = sum_u
R_ab(u)^2``, ``R_ab(u) = cov(d_a(t), d_b(t + u))``, so the correlation is
``rho_ab = S_ab / sqrt(S_aa S_bb)`` (the record length cancels). ``R_ab`` is a sum over
the noise terms (independent processes add), each a double second difference of the
generalised autocovariance ``sw`` of its phase (Greenhall & Riley 2003 eq. 7):
``R_ab(u) = sum_{i,l} c_i c_l SX(u + l m_b - i m_a)``, ``c = (1, -2, 1)``, with
``SX(t) = 2 sw(t) - sw(t - 1) - sw(t + 1)`` for the phase sampled from the rate averaged
over each sample (units of tau0; G&R eq. 8 with F = 1). From a shorter stride of
:data:`CONTINUOUS_FROM` samples on, the continuous limit ``SX = sw(t, alpha + 2)`` in units
of the shorter tau is integrated on a grid of 1/:data:`GRID` (the white phase term, which
has no continuous limit, stays discrete at its few lags). Each term is scaled so that
``R_aa(0) = 2 tau_a^2`` times its share of the model variance at ``tau_a``; ``S`` is then a
quadratic form in those scales, its Gram matrices computed once per grid of tau.

Power laws (S_y ~ f^alpha): quantization +2 (white phase), random walk 0 (white rate),
bias instability -1 (flicker rate), rate random walk -2; the rate ramp is deterministic
and left out. Pairs of tau more than :data:`MAX_RATIO` apart are taken as uncorrelated;
the flicker term is summed to :data:`FLICKER_REACH` strides of the longer tau beyond the
stencils (its covariance decays as a power of the lag).
"""

import functools

import numpy as np

TERMS = ("quantization", "random_walk", "bias_instability", "rate_random_walk")
ALPHA = (2, 0, -1, -2)
"""Power-law exponent of each stochastic term, in :data:`TERMS` order."""
MAX_RATIO = 16
FLICKER_REACH = 4
CONTINUOUS_FROM = 32
GRID = 16
_C = np.array([1.0, -2.0, 1.0])


def _sw(t, alpha):
    """Generalised autocovariance of the power-law phase (G&R eq. 7), one alpha."""
    a = np.abs(t)
    if alpha % 2 == 0:
        return (-1.0 if alpha == 2 else 1.0) * a ** (3 - alpha)
    with np.errstate(divide="ignore", invalid="ignore"):
        log = np.where(a > 0, np.log(np.where(a > 0, a, 1.0)), 0.0)
    return t ** (3 - alpha) * log


def _cross(ma, mb, lags, alpha, continuous):
    """``R_ab`` of a unit term at ``lags`` (samples; units of ``ma`` when continuous)."""
    shifts = (np.arange(3)[None, :] * mb - np.arange(3)[:, None] * ma).ravel()
    weights = np.outer(_C, _C).ravel()
    t = lags[:, None] + shifts[None, :]
    if continuous:
        sx = _sw(t, alpha + 2)
    else:
        sx = 2.0 * _sw(t, alpha) - _sw(t - 1.0, alpha) - _sw(t + 1.0, alpha)
    return sx @ weights


def _lags(ma, mb, continuous):
    reach = 2 * (ma + mb) + 2 + FLICKER_REACH * mb
    if continuous:
        return np.arange(-reach * GRID, reach * GRID + 1) / GRID
    return np.arange(-reach, reach + 1, dtype=float)


def _sparse_lags(ma, mb):
    """Lags (samples) where a white-phase ``R_ab`` can be non-zero."""
    pts = {int(j * mb - i * ma + k) for i in range(3) for j in range(3) for k in (-1, 0, 1)}
    return -np.array(sorted(pts), dtype=float)


def _pair(ma, mb):
    """Gram matrices (3, 4, 4) of the unit terms for (a, a), (b, b), (a, b) and the unit
    terms' ``R(0)`` at a and b (2, 4), in the pair's lag measure."""
    continuous = ma >= CONTINUOUS_FROM
    unit = ma if continuous else 1.0
    grams, zero = np.zeros((3, 4, 4)), np.zeros((2, 4))
    for k, (pa, pb) in enumerate(((ma, ma), (mb, mb), (ma, mb))):
        rows = np.zeros((4, 0))
        if continuous:
            lags = _lags(1.0, mb / ma, True)
            fm = np.array([_cross(pa / unit, pb / unit, lags, al, True) for al in ALPHA[1:]])
            grams[k, 1:, 1:] = fm @ fm.T * ma / GRID
            pm = _cross(pa, pb, _sparse_lags(pa, pb), 2, False)
            grams[k, 0, 0] = pm @ pm
        else:
            lags = _lags(ma, mb, False)
            rows = np.array([_cross(pa, pb, lags, al, False) for al in ALPHA])
            grams[k] = rows @ rows.T
    for k, m in enumerate((ma, mb)):
        for i, al in enumerate(ALPHA):
            cont = continuous and al != 2
            zero[k, i] = _cross(
                m / unit if cont else m, m / unit if cont else m, np.zeros(1), al, cont
            )[0]
    return grams, zero


@functools.lru_cache(maxsize=16)
def _pairs(ms):
    return {
        (a, b): _pair(float(ms[a]), float(ms[b]))
        for a in range(len(ms))
        for b in range(a + 1, len(ms))
        if ms[b] / ms[a] <= MAX_RATIO
    }


def correlation(ms, shares):
    """Correlation (j, j) of the Allan variance estimates at averaging factors ``ms``.

    Parameters
    ----------
    ms : array of int, shape (j,)
        Increasing.
    shares : ndarray, shape (j, 4)
        Each term's Allan variance in the model at every tau (:data:`TERMS` order; any
        common unit).
    """
    ms = tuple(int(m) for m in ms)
    shares = np.asarray(shares, float)
    rho = np.eye(len(ms))
    for (a, b), (grams, zero) in _pairs(ms).items():
        ka = 2.0 * ms[a] ** 2 * shares[a] / zero[0]
        kb = 2.0 * ms[b] ** 2 * shares[b] / zero[1]
        kab = np.sign(ka) * np.sqrt(np.abs(ka * kb))
        s_aa, s_bb, s_ab = ka @ grams[0] @ ka, kb @ grams[1] @ kb, kab @ grams[2] @ kab
        if s_aa > 0 and s_bb > 0:
            rho[a, b] = rho[b, a] = min(s_ab / np.sqrt(s_aa * s_bb), 1.0)
    return rho
