"""Allan, modified and total deviation with confidence intervals, and the IEEE noise-term fit.

Data
----
A sensor at rest gives increments (angle rad, velocity m/s) every ``tau0`` s. Their
running sum is the *phase* ``x`` (rad or m/s; ``x_0 = 0``), the increments divided
by ``tau0`` are the *frequency* ``y`` (rate rad/s or specific force m/s^2): the
time-and-frequency names of NIST SP 1065 carry over, with ``x`` in angle instead of
time. At ``tau = m tau0`` (NIST SP 1065 eq. 14, 16; IEEE Std 952-1997 eq. C.2):

- overlapping Allan variance
  ``s2_A = sum_i (x_{i+2m} - 2 x_{i+m} + x_i)^2 / (2 tau^2 (N - 2m))``, i over all
  ``N - 2m`` starts (N + 1 phase points);
- modified Allan variance (SP 1065 eq. 15) averages the second difference over m
  consecutive starts before squaring;
- total variance (SP 1065 eq. 25) extends the phase by reflection at both ends
  (``x*_{1-j} = 2 x_1 - x_{1+j}``, ``x*_{N+j} = 2 x_N - x_{N-j}``) and takes the
  second difference at every interior point.

Streaming (:class:`AllanAccumulator`)
-------------------------------------
The overlapping Allan variance at m needs only the phase at its starts. Above
``offsets`` starts per tau it is evaluated on the phase sampled every ``2^l``
points (level l: ``m = M 2^l`` with ``offsets <= M < 2 offsets``): the second
differences at every ``2^l``-th start, ``offsets`` of them per m. With 16 offsets
the result differs from the fully overlapping estimate by under a quarter of its
1-sigma interval (white noise, tests); its interval is computed with the fully
overlapping edf, slightly optimistic for the decimated tau. ``offsets=0`` gives the
fully overlapping estimate at every tau. The accumulator keeps per
level only the last ``4 offsets`` phase points and the ones it gathers for the next
kernel call (``batch_rows``), so a record of any length streams through it in
chunks: the work is about ``(log2(offsets) + 2) N`` and the memory independent of
N. Each sum is continued point by point, so the result does not depend on how the
record is cut into chunks.

Confidence intervals
--------------------
Each deviation comes with the chi-square interval ``s2 edf / chi2_{1-p/2}(edf) <=
sigma^2 <= s2 edf / chi2_{p/2}(edf)`` (SP 1065 eq. 45), the equivalent degrees of
freedom edf from Greenhall & Riley, "Uncertainty of stability variances based on
finite differences", PTTI 2003 (the algorithm of Stable32; their eqs. 7-13 and
Tables 1-3) for the Allan and modified variances, and SP 1065 Table 7 for the total
variance. Those edf assume **one power-law noise** ``S_y(f) ~ f^alpha`` at each tau.
alpha is identified per tau from the lag-1 autocorrelation of the tau-averaged rate
(Riley & Greenhall, "Power law noise identification using the lag 1
autocorrelation", 2004: difference the series d times until
``delta = r1 / (1 + r1) < 0.25`` (at most twice), then
``alpha = -round(2 delta) - 2 d``, clipped to [-4, 2]; needs 30 averages; with fewer
the alpha of the next shorter tau is kept). The edf takes alpha >= -2 (d = 2). For
inertial sensors: alpha = +2 quantization (white angle), 0 angle/velocity random
walk (white rate), -1 bias instability (flicker rate), -2 rate random walk. A curve
that mixes terms at a tau, or carries a periodic part (an RLG's dither), breaks the
single-noise assumption; the interval is then approximate.

Noise terms (IEEE Std 952-1997 Annex C, Table C.1)
--------------------------------------------------
``s2_A(tau) = 3 Q^2 / tau^2 + N^2 / tau + (2 ln 2 / pi) B^2 + K^2 tau / 3 + R^2 tau^2 / 2``

Q quantization (rad or m/s), N angle/velocity random walk (rad/sqrt(s), m/s/sqrt(s)),
B bias instability (rad/s, m/s^2; the flat part of the deviation is
``sqrt(2 ln 2 / pi) B = 0.664 B``), K rate random walk (rad/s/sqrt(s)), R rate ramp
(rad/s^2). :func:`fit_terms` fits the five squared coefficients by non-negative
weighted least squares in the variance, weights ``edf / (2 s2_model^2)`` (the
variance of a chi-square estimate), iterated on the model. Each term is reported
with the tau range where it carries at least half the model variance, and its
interval from the fit covariance widened for the correlation of the overlapping
estimates at neighbouring tau (see :func:`fit_terms`).
"""

import itertools
import math
from dataclasses import dataclass
from statistics import NormalDist

import numpy as np

from inins.core import jit
from inins.core.stats import chi2_ppf

ONE_SIGMA = math.erf(1.0 / math.sqrt(2.0))
"""Confidence of a 1-sigma interval, 0.6827 (Stable32's default)."""
TERMS = ("quantization", "random_walk", "bias_instability", "rate_random_walk", "rate_ramp")
"""Names of the five IEEE terms, in the order of their slope -1, -1/2, 0, +1/2, +1."""
SLOPES = (-1.0, -0.5, 0.0, 0.5, 1.0)
"""Log-log slope of the deviation of each term."""
BIAS_FACTOR = math.sqrt(2.0 * math.log(2.0) / math.pi)
"""0.664: the flat Allan deviation of a bias instability B is 0.664 B."""
ID_MIN_POINTS = 30
"""Fewest tau-averages the lag-1 noise identification works on."""


def basis(tau):
    """Allan variance per unit squared coefficient of each term, shape (j, 5)."""
    tau = np.asarray(tau, dtype=float)
    return np.stack(
        [3.0 / tau**2, 1.0 / tau, np.full_like(tau, BIAS_FACTOR**2), tau / 3.0, tau**2 / 2.0],
        axis=-1,
    )


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


def _level(m, offsets):
    """(level, M) of averaging factor m in the streaming scheme."""
    if not offsets or m < offsets:
        return 0, int(m)
    level = 0
    while m % (2 << level) == 0 and (m >> (level + 1)) >= offsets:
        level += 1
    return level, int(m >> level)


# --------------------------------------------------------------------------- kernels


@jit.njit(cache=True, nogil=True)
def _phase_pass(a, b, ref, phase, block, fill, means, sqs, out):
    """Level 0 of the streaming Allan variance over a chunk of increments.

    ``a`` (p, ka) and ``b`` (p, kb) are the chunk's columns (k = ka + kb channels);
    their running sum less ``ref`` per sample, continued from ``phase`` (updated in
    place), is the phase, written to ``out`` (p, k): one row per point, the channels
    side by side, as the difference kernel reads them. Block sums and sums of squares
    (less ``ref``) of ``fill[1]`` samples go to ``means``/``sqs`` (one row per
    completed block), the open block in ``block`` (2, k) and ``fill[0]``. Returns the
    number of completed blocks and the first row holding a non-finite number (-1 if
    none). One pass over the rows, every channel per row; each channel's sums in the
    same order as channel by channel.
    """
    p, ka = a.shape
    k = ka + b.shape[1]
    bad = p
    block_n = fill[1]
    x = phase.copy()
    s1 = block[0].copy()
    s2 = block[1].copy()
    f = fill[0]
    done = 0
    for i in range(p):
        for c in range(k):
            v = (a[i, c] if c < ka else b[i, c - ka]) - ref[c]
            if not math.isfinite(v) and i < bad:
                bad = i
            x[c] += v
            out[i, c] = x[c]
            s1[c] += v
            s2[c] += v * v
        f += 1
        if f == block_n:
            for c in range(k):
                means[done, c] = s1[c]
                sqs[done, c] = s2[c]
                s1[c] = 0.0
                s2[c] = 0.0
            f = 0
            done += 1
    phase[:] = x
    block[0] = s1
    block[1] = s2
    fill[0] = f
    return done, (bad if bad < p else -1)


DIFFERENCE_ROWS = 256
"""Rows of the difference kernel's inner loop: one stride at a time over them (they
stay in the L1 cache between strides), the channels' sums held in registers."""


@jit.njit(cache=True, nogil=True)
def _difference_sums(buf, first, ms, sums, terms):
    """Add ``(x_j - 2 x_{j-M} + x_{j-2M})^2`` over the points j >= max(first, 2M) of
    buf (n, k) to ``sums`` (q, k), their count to ``terms`` (q,), for each M of ``ms``.

    Each channel's sum is continued in the order of j, one term at a time, as one
    channel alone and the whole record in one call would give it (bit for bit,
    whatever k and however the record is cut into calls). The rows go by in runs of
    :data:`DIFFERENCE_ROWS`, every stride over a run before the next; six channels
    (3 gyros, 3 accelerometers) have their sums in six scalars (the compiler keeps
    them in registers and packs the six differences of a point into vector
    instructions: 2.2x the generic loop).
    """
    n, k = buf.shape
    q = ms.shape[0]
    if q == 0:
        return
    top = 0
    for e in range(q):
        j0 = max(first, 2 * ms[e])
        if j0 < n:
            terms[e] += n - j0
        top = max(top, 2 * ms[e])
    # the points where some stride still lacks a whole window: one stride at a time
    for e in range(q):
        mm = ms[e]
        for j in range(max(first, 2 * mm), min(n, max(first, top))):
            for c in range(k):
                d = buf[j, c] - 2.0 * buf[j - mm, c] + buf[j - 2 * mm, c]
                sums[e, c] += d * d
    # then every stride over each run of rows
    for r0 in range(max(first, top), n, DIFFERENCE_ROWS):
        r1 = min(n, r0 + DIFFERENCE_ROWS)
        for e in range(q):
            mm = ms[e]
            if k == 6:
                t0, t1, t2 = sums[e, 0], sums[e, 1], sums[e, 2]
                t3, t4, t5 = sums[e, 3], sums[e, 4], sums[e, 5]
                for j in range(r0, r1):
                    d0 = buf[j, 0] - 2.0 * buf[j - mm, 0] + buf[j - 2 * mm, 0]
                    d1 = buf[j, 1] - 2.0 * buf[j - mm, 1] + buf[j - 2 * mm, 1]
                    d2 = buf[j, 2] - 2.0 * buf[j - mm, 2] + buf[j - 2 * mm, 2]
                    d3 = buf[j, 3] - 2.0 * buf[j - mm, 3] + buf[j - 2 * mm, 3]
                    d4 = buf[j, 4] - 2.0 * buf[j - mm, 4] + buf[j - 2 * mm, 4]
                    d5 = buf[j, 5] - 2.0 * buf[j - mm, 5] + buf[j - 2 * mm, 5]
                    t0 += d0 * d0
                    t1 += d1 * d1
                    t2 += d2 * d2
                    t3 += d3 * d3
                    t4 += d4 * d4
                    t5 += d5 * d5
                sums[e, 0], sums[e, 1], sums[e, 2] = t0, t1, t2
                sums[e, 3], sums[e, 4], sums[e, 5] = t3, t4, t5
            else:
                for j in range(r0, r1):
                    for c in range(k):
                        d = buf[j, c] - 2.0 * buf[j - mm, c] + buf[j - 2 * mm, c]
                        sums[e, c] += d * d


# --------------------------------------------------------------------------- streaming


class AllanAccumulator:
    """Overlapping Allan variance of a record streamed in chunks of increments.

    Parameters
    ----------
    tau0 : float
        Sample interval (s).
    n_channels : int
        Columns of each chunk (3 gyros and 3 accelerometers: 6).
    ms : array of int
        Averaging factors (:func:`tau_grid` with the same ``offsets``).
    offsets : int
        Starts kept per tau above this many (0: fully overlapping at every tau).
    id_points : int
        Tau-averages kept per tau for the noise identification (the first ones).
    reference : ndarray (k,), optional
        Rate subtracted before summing (a constant rate does not change the second
        differences; it keeps the phase small). Default the first chunk's mean.
    block_n : int
        Samples per block of :meth:`blocks` (block means and spreads, for the motion
        check), accumulated in the same pass.
    batch_rows : int
        Phase points a level gathers before the second differences run over them and
        its next level's points are taken: chunks of any size, kernel calls over runs
        that stay in the cache, and few calls for the short levels. The sums do not
        depend on how the record is cut (each is continued point by point).
    """

    def __init__(
        self,
        tau0,
        n_channels,
        ms,
        offsets=0,
        id_points=1 << 14,
        reference=None,
        block_n=1,
        batch_rows=1 << 16,
    ):
        self.tau0 = float(tau0)
        self.k = int(n_channels)
        self.ms = np.asarray(ms, dtype=np.int64)
        self.offsets = int(offsets)
        self.id_points = int(id_points)
        self.reference = None if reference is None else np.asarray(reference, float)
        plan = [_level(int(m), self.offsets) for m in self.ms]
        self.levels = max((lv for lv, _ in plan), default=0) + 1
        self._by_level = [
            (np.array([i for i, (lv, _) in enumerate(plan) if lv == level], dtype=np.int64))
            for level in range(self.levels)
        ]
        self._big = np.array([big for _, big in plan], dtype=np.int64)
        self._hold = [2 * int(self._big[idx].max()) if idx.size else 0 for idx in self._by_level]
        self._tail = [np.zeros((0, self.k)) for _ in range(self.levels)]
        self._count = [0] * self.levels
        self._sums = np.zeros((self.ms.size, self.k))
        self._terms = np.zeros(self.ms.size, dtype=np.int64)
        self._idx = [[] for _ in self.ms]
        self._id_n = np.zeros(self.ms.size, dtype=np.int64)
        self._phase = np.zeros(self.k)
        self._block = np.zeros((2, self.k))
        self._fill = np.array([0, max(int(block_n), 1)], dtype=np.int64)
        self._blocks, self._squares = [], []
        self.n = 0
        self._buffers = {}
        self.batch_rows = max(int(batch_rows), 1)
        self._pending = [0] * self.levels
        """Phase points of each level written after its tail, not yet differenced."""

    def add(self, increments, more=None):
        """Add a chunk of increments, shape (p, k) (rad or m/s), or its first columns
        ``increments`` (p, ka) and the rest ``more`` (p, k - ka). Returns the first row
        holding a non-finite number, or -1."""
        a = np.ascontiguousarray(increments, dtype=float)
        b = np.zeros((a.shape[0], 0)) if more is None else np.ascontiguousarray(more, float)
        if a.ndim != 2 or a.shape[1] + b.shape[1] != self.k or a.shape[0] == 0:
            return -1
        if self.reference is None:
            self.reference = np.concatenate([a.mean(axis=0), b.mean(axis=0)]) / self.tau0
        p = a.shape[0]
        nb = (self._fill[0] + p) // self._fill[1] + 1
        means, sqs = np.zeros((nb, self.k)), np.zeros((nb, self.k))
        if self.n == 0:
            self._tail[0] = np.zeros((1, self.k))  # x_0 = 0
        start = self._open(0, p)
        done, bad = _phase_pass(
            a,
            b,
            self.reference * self.tau0,
            self._phase,
            self._block,
            self._fill,
            means,
            sqs,
            self._buffers[0][start : start + p],
        )
        if done:
            self._blocks.append(means[:done] / self.tau0)
            self._squares.append(sqs[:done])
        self.n += p
        self._pending[0] += p
        self._flush(0)
        return -1 if bad < 0 else bad

    def _open(self, level, rows):
        """Make room for ``rows`` more points of ``level`` after its tail and pending
        points; returns the row where they go."""
        tail = self._tail[level]
        h, pending = tail.shape[0], self._pending[level]
        start = h + pending
        have = self._buffers.get(level)
        if have is None or have.shape[0] < start + rows:
            size = start + rows if have is None else max(start + rows, 2 * have.shape[0])
            grown = np.empty((size, self.k))
            if pending:
                grown[:start] = have[:start]
            have = self._buffers[level] = grown
        if not pending:
            have[:h] = tail
        return start

    def _flush(self, level, force=False):
        """Second differences over the gathered points of ``level`` (once it has
        ``batch_rows`` of them, or ``force``), and its every other point on to the
        next level, which goes on the same way."""
        while level < self.levels:
            pending = self._pending[level]
            if pending == 0 or (pending < self.batch_rows and not force):
                return
            tail = self._tail[level]
            h = tail.shape[0]
            buf = self._buffers[level][: h + pending]
            self._pending[level] = 0
            idx = self._by_level[level]
            c = self._count[level]
            if idx.size:
                lo, hi = idx[0], idx[-1] + 1
                if hi - lo == idx.size:  # consecutive (ms increasing): the sums in place
                    sums, terms = self._sums[lo:hi], self._terms[lo:hi]
                else:
                    sums, terms = self._sums[idx], self._terms[idx]
                _difference_sums(buf, h, self._big[idx], sums, terms)
                if hi - lo != idx.size:
                    self._sums[idx], self._terms[idx] = sums, terms
                for e in idx:
                    big = self._big[e]
                    if self._id_n[e] <= self.id_points:
                        start = h + (-c) % big
                        take = buf[start::big][: self.id_points + 1 - self._id_n[e]]
                        if take.shape[0]:
                            self._idx[e].append(take.copy())
                            self._id_n[e] += take.shape[0]
            hold = max(self._hold[level], 2)
            self._tail[level] = buf[-hold:].copy()
            self._count[level] = c + pending
            level += 1
            if level >= self.levels:
                return
            up = buf[h + c % 2 :: 2]
            if up.shape[0] == 0:
                return
            start = self._open(level, up.shape[0])
            self._buffers[level][start : start + up.shape[0]] = up
            self._pending[level] += up.shape[0]

    def blocks(self):
        """Block means of the rate (nb, k) and the standard deviation of the increments
        in each block, over the blocks completed so far (``block_n`` samples each)."""
        if not self._blocks:
            return np.zeros((0, self.k)), np.zeros((0, self.k))
        sums = np.vstack(self._blocks) * self.tau0  # of the increments less the reference
        sq = np.vstack(self._squares)
        n = self._fill[1]
        mean = sums / n
        var = np.maximum(sq / n - mean**2, 0.0)
        return mean / self.tau0 + self.reference, np.sqrt(var)

    def finish(self):
        """The deviations: :class:`Deviation` (kind ``"oadev"``)."""
        for level in range(self.levels):
            self._flush(level, force=True)
        keep = self._terms > 0
        tau = self.ms * self.tau0
        with np.errstate(invalid="ignore", divide="ignore"):
            var = self._sums / np.maximum(self._terms, 1)[:, None] / (2.0 * tau[:, None] ** 2)
        alpha = np.zeros((self.ms.size, self.k), dtype=np.int64)
        for a in range(self.ms.size):
            x = np.vstack(self._idx[a]) if self._idx[a] else np.zeros((0, self.k))
            # one contiguous row per channel: np.dot of a strided column is ~20x slower
            y = np.ascontiguousarray(np.diff(x, axis=0).T)
            for c in range(self.k):
                alpha[a, c] = (
                    autocorr_alpha(y[c], "frequency") if y.shape[1] >= ID_MIN_POINTS else _NO_ID
                )
        alpha = _fill_alpha(alpha)
        ms, var, alpha = self.ms[keep], var[keep], alpha[keep]
        edf = np.array(
            [
                [edf_for("oadev", int(al), int(m), self.n + 1) for al in row]
                for m, row in zip(ms, alpha, strict=True)
            ]
        ).reshape(var.shape)
        return Deviation("oadev", ms * self.tau0, ms, np.sqrt(var), edf, alpha, self._terms[keep])


_NO_ID = 99


def _fill_alpha(alpha):
    """Where no alpha was identified (too few averages), keep the last shorter tau's."""
    out = alpha.copy()
    for a in range(out.shape[0]):
        for c in range(out.shape[1]):
            if out[a, c] == _NO_ID:
                out[a, c] = out[a - 1, c] if a else 0
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
    return values - np.polyval(np.polyfit(t, values, degree), t)


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


def edf_greenhall(alpha, m, n, kind="adev", d=2, overlapping=True):
    """Equivalent degrees of freedom (Greenhall & Riley 2003, eqs. 7-13, Tables 1-3).

    alpha: power-law exponent (+2 .. -4, alpha + 2 d > 1); m averaging factor; n number
    of phase points; kind ``adev`` (unmodified, F = m) or ``mdev`` (modified, F = 1);
    d = 2 for the Allan variances; overlapping: stride S = m (else 1).
    """
    modified = kind == "mdev"
    f = 1.0 if modified else float(m)
    s = float(m) if overlapping else 1.0
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


def edf_for(kind, alpha, m, n):
    """edf of deviation ``kind`` (:data:`KINDS`) at alpha, m, n phase points.

    alpha below -2 (rate ramp) is taken as -2 for the Allan variances (d = 2 needs
    alpha > -3)."""
    alpha = max(int(alpha), -2)
    if kind == "totdev":
        return edf_totdev(alpha, m, n)
    return edf_greenhall(
        alpha, m, n, "mdev" if kind == "mdev" else "adev", overlapping=kind != "adev"
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
