"""Allan, modified and total deviation of a record in memory, their chi-square
intervals and the power-law noise identification (the overview: :mod:`inins.calibration.allan`).

At ``tau = m tau0``: the overlapping Allan variance (NIST SP 1065 eq. 14; IEEE Std
952-1997 eq. C.2), the non-overlapping one (SP 1065 eq. 7; Stable32's "Allan"), the
modified (SP 1065 eq. 15) and the total variance (SP 1065 eq. 25); the interval of
SP 1065 eq. 45 from the edf of :mod:`inins.calibration.allan.edf`; alpha by the lag-1
autocorrelation (Riley & Greenhall 2004).
"""

import math
from dataclasses import dataclass
from statistics import NormalDist

import numpy as np

from inins.calibration.allan.edf import edf_for
from inins.core.stats import chi2_ppf

ONE_SIGMA = math.erf(1.0 / math.sqrt(2.0))
"""Confidence of a 1-sigma interval, 0.6827 (Stable32's default)."""
ID_MIN_POINTS = 30
"""Fewest tau-averages the lag-1 noise identification works on."""


# --------------------------------------------------------------------------- tau grid


def tau_grid(n, per_octave=1, offsets=0, min_clusters=2):
    """Averaging factors m of an octave (or denser) grid for a record of n samples.

    With ``offsets > 0`` every m at or above ``offsets`` is ``M 2^l`` with
    ``offsets <= M < 2 offsets`` (the streaming levels); below, and with
    ``offsets = 0``, m is ``round(2^(j / per_octave))``. m runs while at least
    ``min_clusters`` non-overlapping pairs fit: ``2 m <= n / min_clusters * 2``.
    """
    top = n // (2 * max(min_clusters, 1)) * 2 if min_clusters > 1 else n // 2
    top = max(top // 1, 1)
    ms = []
    j = 0
    while True:
        m = round(2.0 ** (j / per_octave))
        if offsets and m >= offsets:
            level = math.floor(math.log2(m / offsets))
            big = round(m / 2**level)
            m = big << level
        if m > top or 2 * m >= n:
            break
        if not ms or m > ms[-1]:
            ms.append(m)
        j += 1
    return np.array(ms, dtype=np.int64)


_NO_ID = 99


def _fill_alpha(alpha, monotone=False):
    """Where no alpha was identified (too few averages), keep the last shorter tau's;
    ``monotone``: never above the shorter tau's either (sensor noise goes from
    quantization through white and flicker rate to random walk as tau grows; the lag-1
    estimate from 30-60 averages at the longest tau mistakes a white rate for flicker
    phase in a fifth of records, and the edf it then takes is 4x too large)."""
    out = alpha.copy()
    for a in range(out.shape[0]):
        for c in range(out.shape[1]):
            if out[a, c] == _NO_ID:
                out[a, c] = out[a - 1, c] if a else 0
            elif monotone and a:
                out[a, c] = min(out[a, c], out[a - 1, c])
    return out


@dataclass(frozen=True)
class Deviation:
    """A deviation curve per channel.

    Attributes
    ----------
    kind : str
        ``adev`` (overlapping Allan), ``mdev`` (modified), ``totdev`` (total).
    tau : ndarray (j,)
        s.
    m : ndarray (j,)
        Averaging factors.
    dev : ndarray (j, k)
        Deviation, unit of the rate (rad/s, m/s^2).
    edf : ndarray (j, k)
        Equivalent degrees of freedom.
    alpha : ndarray (j, k)
        Power-law noise exponent assumed for the edf.
    terms : ndarray (j,)
        Number of second differences averaged.
    """

    kind: str
    tau: np.ndarray
    m: np.ndarray
    dev: np.ndarray
    edf: np.ndarray
    alpha: np.ndarray
    terms: np.ndarray

    def interval(self, confidence=ONE_SIGMA):
        """Chi-square interval (lo, hi) of the deviation, each (j, k) (SP 1065 eq. 45)."""
        return chi2_interval(self.dev, self.edf, confidence)


def chi2_interval(dev, edf, confidence=ONE_SIGMA):
    """``dev sqrt(edf / chi2_hi)``, ``dev sqrt(edf / chi2_lo)`` (NIST SP 1065 eq. 45)."""
    p = (1.0 - confidence) / 2.0
    edf = np.asarray(edf, dtype=float)
    return dev * np.sqrt(edf / _chi2_quantile(1.0 - p, edf)), dev * np.sqrt(
        edf / _chi2_quantile(p, edf)
    )


WILSON_HILFERTY_DOF = 1e5
"""Above this many degrees of freedom the chi-square quantile is Wilson-Hilferty's
(A&S 26.4.17; relative error ~1e-8 there), below it the exact one of core.stats (whose
series takes ~sqrt(dof) steps)."""


def _chi2_quantile(p, dof):
    dof = np.asarray(dof, dtype=float)
    z = NormalDist().inv_cdf(p)
    big = dof > WILSON_HILFERTY_DOF
    out = np.empty_like(dof)
    d = dof[big]
    out[big] = d * (1.0 - 2.0 / (9.0 * d) + z * np.sqrt(2.0 / (9.0 * d))) ** 3
    if (~big).any():
        out[~big] = chi2_ppf(p, dof[~big])
    return out


# --------------------------------------------------------------------------- in memory


def phase_of(increments):
    """Phase (n + 1, ...) from increments (n, ...): ``x_0 = 0``, running sum."""
    inc = np.asarray(increments, dtype=float)
    inc = inc - inc.mean(axis=0)
    return np.concatenate([np.zeros((1, *inc.shape[1:])), np.cumsum(inc, axis=0)])


def oadev_phase(x, ms, tau0):
    """Overlapping Allan deviation from phase x (n + 1, ...) at averaging factors ms."""
    x = np.asarray(x, dtype=float)
    out = []
    for m in ms:
        d = x[2 * m :] - 2.0 * x[m:-m] + x[: -2 * m]
        out.append(np.sqrt(np.mean(d**2, axis=0) / 2.0) / (m * tau0))
    return np.array(out)


def adev_phase(x, ms, tau0):
    """Non-overlapping Allan deviation from phase x: the phase every m points
    (NIST SP 1065 eq. 7; Stable32's "Allan")."""
    x = np.asarray(x, dtype=float)
    out = []
    for m in ms:
        xs = x[::m]
        d = xs[2:] - 2.0 * xs[1:-1] + xs[:-2]
        out.append(np.sqrt(np.mean(d**2, axis=0) / 2.0) / (m * tau0))
    return np.array(out)


def mdev_phase(x, ms, tau0):
    """Modified Allan deviation from phase x (NIST SP 1065 eq. 15)."""
    x = np.asarray(x, dtype=float)
    c = np.concatenate([np.zeros((1, *x.shape[1:])), np.cumsum(x, axis=0)])
    n1 = x.shape[0]
    out = []
    for m in ms:
        j = np.arange(n1 - 3 * m + 1)

        def window(a, j=j, m=m):
            return c[j + a + m] - c[j + a]

        s = window(2 * m) - 2.0 * window(m) + window(0)
        out.append(np.sqrt(np.mean(s**2, axis=0) / 2.0) / (m * m * tau0))
    return np.array(out)


def totdev_phase(x, ms, tau0):
    """Total deviation from phase x (NIST SP 1065 eq. 25, reflection at both ends)."""
    x = np.asarray(x, dtype=float)
    n = x.shape[0]
    head = 2.0 * x[0] - x[n - 2 : 0 : -1]
    tail = 2.0 * x[-1] - x[-2:0:-1]
    ext = np.concatenate([head, x, tail])
    off = n - 2
    out = []
    for m in ms:
        i = np.arange(1, n - 1) + off
        d = ext[i - m] - 2.0 * ext[i] + ext[i + m]
        out.append(np.sqrt(np.sum(d**2, axis=0) / (2.0 * (n - 2))) / (m * tau0))
    return np.array(out)


KINDS = ("oadev", "adev", "mdev", "totdev")
"""Deviations: overlapping Allan, non-overlapping Allan, modified Allan, total."""


def deviations(increments, tau0, ms=None, kinds=("oadev",), per_octave=1, phase=None):
    """Deviations of an in-memory record: ``{kind: Deviation}``.

    increments (n, k) (rad or m/s), or ``phase`` (n + 1, k) instead; ``kinds`` of
    :data:`KINDS`. The noise identification works on the tau-averaged rate.
    """
    if phase is not None:
        x = np.asarray(phase, dtype=float)
        x = x.reshape(x.shape[0], -1)
        inc = np.diff(x, axis=0)
    else:
        inc = np.asarray(increments, dtype=float)
        inc = inc.reshape(inc.shape[0], -1)
        x = phase_of(inc)
    n = inc.shape[0]
    out = {}
    for kind in kinds:
        if ms is None:
            limit = {"oadev": 2, "adev": 2, "mdev": 3, "totdev": 2}[kind]
            grid = tau_grid(n, per_octave)
            grid = grid[limit * grid < n] if kind != "totdev" else grid
        else:
            grid = np.asarray(ms, dtype=np.int64)
        fn = {
            "oadev": oadev_phase,
            "adev": adev_phase,
            "mdev": mdev_phase,
            "totdev": totdev_phase,
        }[kind]
        dev = fn(x, grid, tau0).reshape(grid.size, -1)
        alpha = _fill_alpha(
            np.array(
                [
                    [
                        autocorr_alpha(_averages(inc[:, c], m), "frequency")
                        if n // m >= ID_MIN_POINTS
                        else _NO_ID
                        for c in range(inc.shape[1])
                    ]
                    for m in grid
                ],
                dtype=np.int64,
            ).reshape(grid.size, -1)
        )
        edf = np.array(
            [
                [edf_for(kind, int(a), int(m), n + 1) for a in row]
                for m, row in zip(grid, alpha, strict=True)
            ]
        ).reshape(dev.shape)
        terms = {
            "oadev": n + 1 - 2 * grid,
            "adev": n // grid - 1,
            "mdev": n + 2 - 3 * grid,
            "totdev": n - 1 + 0 * grid,
        }
        out[kind] = Deviation(kind, grid * tau0, grid, dev, edf, alpha, terms[kind])
    return out


def _averages(y, m):
    k = y.shape[0] // m
    return y[: k * m].reshape(k, m).mean(axis=1)


# --------------------------------------------------------------------------- noise id


def lag1(values):
    """Lag-1 autocorrelation ``sum (z_i - mean)(z_{i+1} - mean) / sum (z_i - mean)^2``."""
    z = values - values.mean()
    # elementwise sums, not np.dot: BLAS wakes its thread pool for each short call
    # (9 ms of wall time per call on a busy machine, 1.2 s of a 1-h record's run)
    den = float(np.sum(z * z))
    return float(np.sum(z[:-1] * z[1:]) / den) if den > 0 else 0.0


def _detrend(values, degree):
    t = np.arange(values.shape[0], dtype=float)
    t = (t - t.mean()) / max(t.std(), 1.0)
    if degree == 1:  # the straight line in closed form (t centred): polyfit's, 20x faster
        den = float(np.sum(t * t))
        slope = float(np.sum(t * values)) / den if den > 0 else 0.0
        return values - values.mean() - slope * t
    return values - np.polyval(np.polyfit(t, values, degree), t)


def frequency_alphas(values, dmax=2):
    """:func:`autocorr_alpha` of tau-averaged frequency, every column of ``values``
    (p, k) at once (the same sums per column; the streaming estimator's noise
    identification of six channels in one call instead of six). Returns int (k,)."""
    z = np.asarray(values, dtype=float)
    t = np.arange(z.shape[0], dtype=float)
    t = (t - t.mean()) / max(t.std(), 1.0)
    den = float(np.sum(t * t))
    slope = (np.sum(t[:, None] * z, axis=0) / den) if den > 0 else np.zeros(z.shape[1])
    z = z - z.mean(axis=0) - t[:, None] * slope
    out = np.zeros(z.shape[1], dtype=np.int64)
    todo = np.ones(z.shape[1], dtype=bool)
    d = 0
    while todo.any():
        zz = z - z.mean(axis=0)
        num, sq = np.sum(zz[:-1] * zz[1:], axis=0), np.sum(zz * zz, axis=0)
        with np.errstate(invalid="ignore", divide="ignore"):
            r1 = np.where(sq > 0, num / np.where(sq > 0, sq, 1.0), 0.0)
        delta = r1 / (1.0 + r1)
        done = todo & ((delta < 0.25) | (d >= dmax))
        out[done] = np.clip(-np.round(2.0 * delta[done]).astype(np.int64) - 2 * d, -4, 2)
        todo &= ~done
        z = np.diff(z, axis=0)
        d += 1
    return out


def autocorr_alpha(values, data="frequency", dmax=2):
    """Power-law exponent alpha by the lag-1 autocorrelation (Riley & Greenhall 2004).

    ``values``: tau-averaged frequency (the rate averaged over m samples; a linear
    trend is removed) or phase decimated by m (a quadratic trend is removed). The
    series is differenced d times until ``delta = r1 / (1 + r1) < 0.25`` (or d =
    dmax); then ``alpha = -round(2 delta) - 2 d`` (+2 for phase data). Returns an int.
    """
    z = _detrend(np.asarray(values, dtype=float), 1 if data == "frequency" else 2)
    d = 0
    while True:
        r1 = lag1(z)
        delta = r1 / (1.0 + r1)
        if delta < 0.25 or d >= dmax:
            alpha = int(-np.round(2.0 * delta) - 2 * d) + (2 if data == "phase" else 0)
            return min(max(alpha, -4), 2)
        z = np.diff(z)
        d += 1
