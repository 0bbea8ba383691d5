"""The overlapping Allan variance of a record streamed in chunks (the scheme: the
"Streaming" part of :mod:`inins.calibration.allan`): two kernels, one pass over the
rows for the phase and block statistics, one for the second differences of every
stride at a level, and the accumulator that feeds them level by level.
"""

import math

import numpy as np

from inins.calibration.allan.deviation import (
    _NO_ID,
    ID_MIN_POINTS,
    Deviation,
    _fill_alpha,
    frequency_alphas,
)
from inins.calibration.allan.edf import edf_for
from inins.core import jit


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
    :data:`DIFFERENCE_ROWS`, every stride over a run (from its first whole window on)
    before the next; six channels (3 gyros, 3 accelerometers) have their sums in six
    scalars (the compiler keeps them in registers and packs the six differences of a
    point into vector instructions: 2.2x the generic loop).
    """
    n, k = buf.shape
    q = ms.shape[0]
    for e in range(q):
        j0 = max(first, 2 * ms[e])
        if j0 < n:
            terms[e] += n - j0
    for r0 in range(first, n, DIFFERENCE_ROWS):
        r1 = min(n, r0 + DIFFERENCE_ROWS)
        for e in range(q):
            mm = ms[e]
            j0 = max(r0, 2 * mm)
            if j0 >= r1:
                continue
            if k == 6:
                t0, t1, t2 = sums[e, 0], sums[e, 1], sums[e, 2]
                t3, t4, t5 = sums[e, 3], sums[e, 4], sums[e, 5]
                for j in range(j0, r1):
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
                for j in range(j0, r1):
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
        Tau-averages kept per tau for the noise identification (the first ones; 4096
        give the lag-1 autocorrelation to 0.016, against the 0.25 steps of its rule).
    reference : ndarray (k,), optional
        Rate subtracted before summing (a constant rate does not change the second
        differences; it keeps the phase small). Default the first chunk's mean.
    block_n : int
        Samples per block of :meth:`blocks` (block means and spreads, for the motion
        check), accumulated in the same pass.
    monotone_alpha : bool
        The noise identified at a tau never above the shorter tau's (sensor noise:
        :func:`inins.calibration.allan.deviation._fill_alpha`).
    expected_rows : int
        The record's length when known: with ``offsets=0`` (the whole phase kept) its
        buffer is taken at once instead of grown by doubling (copies and first touches
        of up to twice the record).
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
        id_points=1 << 12,
        reference=None,
        block_n=1,
        batch_rows=1 << 16,
        monotone_alpha=False,
        expected_rows=0,
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
        self.monotone_alpha = bool(monotone_alpha)
        self.expected_rows = int(expected_rows)
        self._pending = [0] * self.levels
        """Phase points of each level written after its tail, not yet differenced."""
        self._whole = [False] * self.levels
        """The tail is the level's whole history, kept in place in its buffer (the fully
        overlapping estimator, offsets=0: every point stays needed; copying it on every
        batch made the pass quadratic in the record length)."""

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
        h, pending, whole = tail.shape[0], self._pending[level], self._whole[level]
        start = h + pending
        have = self._buffers.get(level)
        if have is None or have.shape[0] < start + rows:
            # while points gather (small chunks): room for a whole batch at once; a whole
            # history grows by doubling (its copies sum to O(N))
            size = start + rows if not pending else max(start + rows, h + self.batch_rows + rows)
            if whole and have is not None:
                size = max(size, 2 * have.shape[0], h + self.batch_rows + rows)
            if self.offsets == 0 and level == 0:
                size = max(size, self.expected_rows + 2)
            grown = np.empty((size, self.k))
            if pending or (whole and have is not None):
                grown[:start] = have[:start]
            have = self._buffers[level] = grown
            if whole:
                self._tail[level] = have[:h]
        if not pending and not whole:
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
            self._whole[level] = hold >= buf.shape[0] or self.offsets == 0
            self._tail[level] = buf if self._whole[level] else buf[-hold:].copy()
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
        alpha = np.full((self.ms.size, self.k), _NO_ID, dtype=np.int64)
        for a in range(self.ms.size):
            x = np.vstack(self._idx[a]) if self._idx[a] else np.zeros((0, self.k))
            y = np.diff(x, axis=0)
            if y.shape[0] >= ID_MIN_POINTS:
                alpha[a] = frequency_alphas(y)
        alpha = _fill_alpha(alpha, self.monotone_alpha)
        ms, var, alpha, big = self.ms[keep], var[keep], alpha[keep], self._big[keep]
        # a decimated tau has M starts per m, not m (Greenhall & Riley's S)
        edf = np.array(
            [
                [edf_for("oadev", int(al), int(m), self.n + 1, int(s)) for al in row]
                for m, s, row in zip(ms, big, alpha, strict=True)
            ]
        ).reshape(var.shape)
        return Deviation("oadev", ms * self.tau0, ms, np.sqrt(var), edf, alpha, self._terms[keep])
