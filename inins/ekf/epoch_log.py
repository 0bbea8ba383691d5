"""The log of a tight filter run (:func:`inins.ekf.filter.run_filter`): the batch buffers
the compiled :func:`inins.ekf.fused.epochs` writes into, and the run's output arrays.

Memory: a batch's ``P`` (:data:`inins.ekf.filter.BATCH` epochs) lives in the reused
:class:`Buffers` only; each batch is scored against its truth from it
(:meth:`Log.score`, :func:`inins.ekf.scoring.epoch_errors`) before the next overwrites
it. The output arrays grow by the epoch's rows alone (about 1.5 kB an epoch of EKF2 with
ten satellites), allocated at once for the epochs expected.
"""

from dataclasses import dataclass

import numpy as np

from inins.ekf import fused
from inins.ekf.result import Innovations

LOG_CAPACITY = 256
"""Epochs the log holds before it first doubles, when the run gives no capacity."""


@dataclass
class EpochLog:
    """What a run records, ``m`` epochs (:func:`inins.ekf.filter.run_filter` fills it as
    the run goes; the errors against truth are scored batch by batch and go into the
    result).

    Attributes
    ----------
    time : ndarray, shape (m,)
        The time the logged state refers to (s): the PPS, or the arrival (naive pairing).
    gnss_time : ndarray, shape (m,)
        The measurement epoch (PPS) (s).
    quat, vel, lla : ndarray, shapes (m, 4), (m, 3), (m, 3)
        Output solution after the update.
    state, sigma, cumulative : ndarray, shape (m, n)
        Error-state estimate (sensor totals), its 1-sigma, FB cumulative corrections.
    n_sats, n_used, n_rejected : ndarray, shape (m,), int
    coasted : ndarray, shape (m,), bool
    nis, update_s : ndarray, shape (m,)
    measurements : Innovations
        Every scalar measurement processed.
    """

    time: np.ndarray
    gnss_time: np.ndarray
    quat: np.ndarray
    vel: np.ndarray
    lla: np.ndarray
    state: np.ndarray
    sigma: np.ndarray
    cumulative: np.ndarray
    n_sats: np.ndarray
    n_used: np.ndarray
    n_rejected: np.ndarray
    coasted: np.ndarray
    nis: np.ndarray
    update_s: np.ndarray
    measurements: Innovations

    def innovations(self):
        """:class:`~inins.ekf.result.Innovations` of every scalar measurement processed."""
        return self.measurements


class Buffers:
    """The arrays one call of :func:`inins.ekf.fused.epochs` writes its batch into (its
    epochs in rows ``0..b-1``, ``P`` of epoch ``j`` in ``cov[j]``), reused batch after
    batch: the run's memory does not grow with ``P`` (NEES is scored per batch)."""

    def __init__(self, n, size):
        self.flog = np.zeros((size, fused.LOG_STATE + 3 * n))
        self.ilog = np.zeros((size, 4), np.int64)
        self.cov = np.zeros((size, n, n))
        self.inn_f = np.zeros((8 * size, 2))
        self.inn_i = np.zeros((8 * size, 4), np.int64)
        self._record = None

    def record(self, rows):
        """The arrays of :data:`inins.ekf.fused.Log` (a plain tuple) with room for ``rows``
        innovation rows."""
        if rows > self.inn_f.shape[0]:
            self.inn_f, self.inn_i = _grown(self.inn_f, rows), _grown(self.inn_i, rows)
            self._record = None
        if self._record is None:
            self._record = (self.flog, self.ilog, self.cov, self.inn_f, self.inn_i)
        return self._record


_COLUMNS = (  # EpochLog field, first flog column (None: ilog), width (0: (m,), n: the states)
    ("time", fused.LOG_TIME, 0),
    ("gnss_time", fused.LOG_GNSS_TIME, 0),
    ("nis", fused.LOG_NIS, 0),
    ("quat", fused.LOG_QUAT, 4),
    ("vel", fused.LOG_VEL, 3),
    ("lla", fused.LOG_LLA, 3),
    ("state", fused.LOG_STATE, "n"),
    ("sigma", fused.LOG_STATE, "n"),
    ("cumulative", fused.LOG_STATE, "n"),
    ("n_sats", None, fused.N_SATS),
    ("n_used", None, fused.N_USED),
    ("n_rejected", None, fused.N_REJECTED),
    ("coasted", None, fused.COASTED),
)
"""Where each per-epoch array of :class:`EpochLog` is in a batch's ``flog`` / ``ilog`` rows
(the state, its sigma and the cumulative corrections ``n`` columns each, one after the
other)."""


class Log:
    """The run's output arrays (:class:`EpochLog`), one contiguous array per field, each
    batch's rows copied in from the :class:`Buffers`; sized for ``capacity`` epochs
    (and rows of innovations a generous 64 an epoch: pages never written cost no
    memory), grown by doubling beyond; the errors against truth scored per batch."""

    def __init__(self, n, covariance=None, capacity=None):
        self.n, self.m, self.rows = n, 0, 0  # state size, epochs and innovation rows logged
        size = max(int(capacity or LOG_CAPACITY), 1)
        self.arrays = {}
        for name, first, width in _COLUMNS:
            shape = () if width == 0 or first is None else ((n,) if width == "n" else (width,))
            kind = bool if name == "coasted" else (np.int64 if first is None else float)
            self.arrays[name] = np.zeros((size, *shape), kind)
        self.arrays["update_s"] = np.zeros(size)
        self.inn = _innovation_arrays(64 * size if capacity else 8 * size)
        self.errors = None  # (nav_error, heading_error, nees) of the epochs scored
        self.scored, self.has_nees = 0, False
        self.covariance = covariance  # the caller's (k, n, n), or None

    def take(self, buffers, size, written, seconds):
        """Copy a batch of ``size`` epochs and ``written`` innovation rows from
        ``buffers`` (epoch ``m + j`` is the batch's ``j``), each epoch ``seconds`` of
        the kernel's time."""
        first, rows, n, a = self.m, self.rows, self.n, self.arrays
        end = first + size
        if end > a["time"].shape[0]:
            self.arrays = a = {name: _grown(v, end) for name, v in a.items()}
        if rows + written > self.inn[0].size:
            self.inn = tuple(_grown(v, rows + written) for v in self.inn)
        f, i = buffers.flog[:size], buffers.ilog[:size]
        for name, column, width in _COLUMNS:
            if column is None:
                a[name][first:end] = i[:, width]
            elif width == 0:
                a[name][first:end] = f[:, column]
            else:
                if width == "n":
                    column += n * ("state", "sigma", "cumulative").index(name)
                    width = n
                a[name][first:end] = f[:, column : column + width]
        a["update_s"][first:end] = seconds
        inn_f, inn_i, out = buffers.inn_f[:written], buffers.inn_i[:written], self.inn
        out[0][rows : rows + written] = inn_i[:, 0] + first
        for k, column in enumerate((inn_i[:, 1], inn_i[:, 2], inn_f[:, 0], inn_f[:, 1])):
            out[k + 1][rows : rows + written] = column
        out[5][rows : rows + written] = inn_i[:, 3] != 0
        if self.covariance is not None:
            if end > self.covariance.shape[0]:
                raise ValueError(f"covariance holds {self.covariance.shape[0]} epochs, not more")
            self.covariance[first:end] = buffers.cov[:size]
        self.m, self.rows = end, rows + written

    def score(self, buffers, first, truths, scorer):
        """The errors against truth of the batch taken at epoch ``first``, for its epochs
        ``(j, truth)`` that carry truth, from their rows and ``P`` in ``buffers``
        (``scorer``: :func:`inins.ekf.scoring.epoch_errors` with the run's settings)."""
        if not truths:
            return
        j = np.array([j for j, _ in truths])
        rows = buffers.flog[j]
        solution = (
            rows[:, fused.LOG_QUAT : fused.LOG_QUAT + 4],
            rows[:, fused.LOG_VEL : fused.LOG_VEL + 3],
            rows[:, fused.LOG_LLA : fused.LOG_LLA + 3],
            rows[:, fused.LOG_STATE : fused.LOG_STATE + self.n],
        )
        got = scorer(solution, [truth for _, truth in truths], buffers.cov[j])
        if self.errors is None:
            size = self.arrays["time"].shape[0]
            self.errors = tuple(np.zeros((size, *a.shape[1:])) for a in got)
            self.has_nees = got[2].size > 0
        if self.m > self.errors[0].shape[0]:
            self.errors = tuple(_grown(a, self.m) for a in self.errors)
        for out, value in zip(self.errors, got, strict=True):
            if value.size:
                out[first + j] = value
        self.scored += j.size

    def truth(self):
        """``(nav_error, heading_error, nees)`` of every epoch, or None unless every epoch
        was scored (``nees`` (0,) without the true sensor errors)."""
        if self.errors is None or self.scored != self.m or self.m == 0:
            return None
        nav, heading, nees = self.errors
        nees = nees[: self.m] if self.has_nees else np.zeros(0)
        return nav[: self.m], heading[: self.m], nees

    def epochs(self):
        """The :class:`EpochLog` of the epochs written (views of the filled rows)."""
        m = self.m
        return EpochLog(
            **{name: value[:m] for name, value in self.arrays.items()},
            measurements=Innovations(*(v[: self.rows] for v in self.inn)),
        )


def _innovation_arrays(size):
    """Empty columns of :class:`~inins.ekf.result.Innovations` for ``size`` rows."""
    kinds = (np.int64, np.int64, np.int8, float, float, bool)
    return tuple(np.zeros(size, kind) for kind in kinds)


def _grown(array, index):
    """``array`` with its first axis doubled until it holds ``index`` (zeros appended)."""
    size = max(array.shape[0], 1)
    while size <= index:
        size *= 2
    out = np.zeros((size, *array.shape[1:]), array.dtype)
    out[: array.shape[0]] = array
    return out
