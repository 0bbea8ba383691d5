"""Typed outcome of a filter run: epoch-rate series and the scalar summary (003 §2.3, §3.3)."""

from dataclasses import dataclass, replace

import numpy as np

from inins.core import rotation
from inins.core.error_model import StateLayout
from inins.core.units import DEG, DPH


@dataclass(frozen=True, eq=False)
class Innovations:
    """Every scalar measurement processed, in order (``j`` rows).

    Attributes
    ----------
    epoch : ndarray, shape (j,)
        Epoch index (int).
    prn : ndarray, shape (j,)
        Satellite (int).
    kind : ndarray, shape (j,)
        0 pseudorange (m), 1 range rate (m/s).
    value, variance : ndarray, shape (j,)
        Innovation and its predicted variance ``H P H^T + R``.
    accepted : ndarray, shape (j,)
        False where the chi-square gate rejected it.
    """

    epoch: np.ndarray
    prn: np.ndarray
    kind: np.ndarray
    value: np.ndarray
    variance: np.ndarray
    accepted: np.ndarray

    @property
    def nis(self):
        """Normalised innovation squared per row, chi-square(1) if consistent."""
        return self.value**2 / self.variance


@dataclass(frozen=True)
class EkfSummary:
    """Scalar results (names carry their unit, spec §1); NaN where not known (no truth)."""

    heading_err_rms_deg: float
    heading_err_final_deg: float
    pos_err_rms_m: float
    vel_err_rms_mps: float
    gyro_bias_z_est_dph: float
    gyro_bias_z_sigma_dph: float
    nees_mean: float
    nis_mean: float
    rejected_measurements: int
    coasted_epochs: int
    realtime_factor: float
    update_time_mean_s: float
    update_time_max_s: float


@dataclass(frozen=True, eq=False)
class EkfResult:
    """Epoch-rate series of one run (``m`` epochs; ``n`` states of ``layout``).

    Attributes
    ----------
    model, coupling : str
        ``"ekf1"``/``"ekf2"``, ``"ff"``/``"fb"``.
    layout : StateLayout
    time : ndarray, shape (m,)
        Time the logged state refers to (s): the 1PPS epoch, or with the naive
        pairing (``pps_storage`` false) the data arrival.
    quat_nb, vel_n, lla : ndarray, shapes (m, 4), (m, 3), (m, 3)
        Corrected navigation solution at the epoch (after its update).
    state, sigma : ndarray, shape (m, n)
        Estimated errors (SI units of ``layout``; sensor states total, i.e. with
        the FB compensation added) and their 1-sigma.
    cumulative : ndarray, shape (m, n)
        FB: cumulative corrections fed back (navigation and sensor); zero in FF.
    nav_error : ndarray, shape (m, 9) or (0, 9)
        Output error against truth: position (NED m), velocity (m/s), phi (rad).
    heading_error : ndarray, shape (m,) or (0,)
        Heading minus true heading (rad).
    nees : ndarray, shape (m,) or (0,)
        ``e^T P^-1 e`` with ``e`` the error of all ``n`` states.
    n_sats, n_used, n_rejected : ndarray, shape (m,)
        Satellites given, scalar measurements used and rejected by the gate.
    coasted : ndarray, shape (m,)
        True where the epoch had no satellites or fell in an outage window.
    nis : ndarray, shape (m,)
        Sum of the accepted measurements' NIS per epoch.
    update_time : ndarray, shape (m,)
        Wall time of the epoch's compiled step (s): strapdown, propagation, update and
        feedback (:func:`inins.ekf.fused.epoch`). The epochs run in batches of
        :data:`inins.ekf.filter.BATCH` per call, so this is the mean over the epoch's
        batch (every epoch's own time with a smoother's store: one epoch per call).
    innovations : Innovations
    flight_time, wall_time : float
        Data span and the filter's own wall time (s): producing the epochs (a
        simulation generator, a file reader) is not counted, nor is the scoring
        against truth (after the run).
    gnss_time : ndarray, shape (m,)
        The measurement epoch (1PPS) of each entry (s); equals ``time`` with 1PPS
        storage.
    """

    model: str
    coupling: str
    layout: StateLayout
    time: np.ndarray
    quat_nb: np.ndarray
    vel_n: np.ndarray
    lla: np.ndarray
    state: np.ndarray
    sigma: np.ndarray
    cumulative: np.ndarray
    nav_error: np.ndarray
    heading_error: np.ndarray
    nees: np.ndarray
    n_sats: np.ndarray
    n_used: np.ndarray
    n_rejected: np.ndarray
    coasted: np.ndarray
    nis: np.ndarray
    update_time: np.ndarray
    innovations: Innovations
    flight_time: float
    wall_time: float
    gnss_time: np.ndarray | None = None

    @classmethod
    def from_log(cls, config, log, flight_time, wall_time):
        """Stack what the run recorded (an :class:`inins.ekf.epoch_log.EpochLog`); no truth
        errors yet (:meth:`with_truth`)."""
        n = len(config.layout)

        def stack(values, shape, dtype=float):  # the log's arrays as they are (no copy)
            return np.asarray(values, dtype=dtype).reshape((len(values), *shape))

        return cls(
            config.model.value,
            config.coupling.value,
            config.layout,
            stack(log.time, ()),
            stack(log.quat, (4,)),
            stack(log.vel, (3,)),
            stack(log.lla, (3,)),
            stack(log.state, (n,)),
            stack(log.sigma, (n,)),
            stack(log.cumulative, (n,)),
            np.zeros((0, 9)),
            np.zeros(0),
            np.zeros(0),
            stack(log.n_sats, (), np.int64),
            stack(log.n_used, (), np.int64),
            stack(log.n_rejected, (), np.int64),
            stack(log.coasted, (), bool),
            stack(log.nis, ()),
            stack(log.update_s, ()),
            log.innovations(),
            float(flight_time),
            float(wall_time),
            stack(log.gnss_time, ()),
        )

    def with_truth(self, nav_error, heading_error, nees):
        """A copy with the errors against truth: ``nav_error`` (m, 9), ``heading_error``
        (m,), ``nees`` (m,) or (0,)."""
        return replace(self, nav_error=nav_error, heading_error=heading_error, nees=nees)

    def euler(self):
        """Roll, pitch, heading (rad), shape (m, 3)."""
        return rotation.euler_from_mat(rotation.mat_from_quat(self.quat_nb))

    def series(self, name):
        """``(estimate, sigma)`` of state ``name`` (e.g. ``"bg_z"``), each (m,)."""
        i = self.layout.index(name)
        return self.state[:, i], self.sigma[:, i]

    def coasted_windows(self):
        """Consecutive coasted epochs as ``(first, last)`` times (s)."""
        flags = np.concatenate([[False], self.coasted, [False]]).astype(np.int8)
        starts = np.flatnonzero(np.diff(flags) == 1)
        stops = np.flatnonzero(np.diff(flags) == -1) - 1
        return tuple(
            (float(self.time[a]), float(self.time[b])) for a, b in zip(starts, stops, strict=True)
        )

    def summary(self, window=None):
        """:class:`EkfSummary`; RMS errors over epochs with ``window[0] <= t <= window[1]``."""
        sel = (
            np.ones(self.time.size, bool)
            if window is None
            else (self.time >= window[0]) & (self.time <= window[1])
        )
        has_truth = self.nav_error.shape[0] == self.time.size and self.time.size > 0

        def rms(values):
            return float(np.sqrt(np.mean(values**2))) if has_truth and values.size else np.nan

        bz, sz = self.series("bg_z")
        used = self.innovations.accepted
        return EkfSummary(
            heading_err_rms_deg=rms(self.heading_error[sel] if has_truth else None) / DEG,
            heading_err_final_deg=float(self.heading_error[-1] / DEG) if has_truth else np.nan,
            pos_err_rms_m=rms(
                np.linalg.norm(self.nav_error[sel, 0:3], axis=1) if has_truth else None
            ),
            vel_err_rms_mps=rms(
                np.linalg.norm(self.nav_error[sel, 3:6], axis=1) if has_truth else None
            ),
            gyro_bias_z_est_dph=float(bz[-1] / DPH),
            gyro_bias_z_sigma_dph=float(sz[-1] / DPH),
            nees_mean=float(np.mean(self.nees[sel])) if self.nees.size == sel.size else np.nan,
            nis_mean=float(np.mean(self.innovations.nis[used])) if used.any() else np.nan,
            rejected_measurements=int(np.sum(self.n_rejected)),
            coasted_epochs=int(np.sum(self.coasted)),
            realtime_factor=self.flight_time / self.wall_time if self.wall_time > 0 else np.inf,
            update_time_mean_s=float(np.mean(self.update_time)) if self.time.size else np.nan,
            update_time_max_s=float(np.max(self.update_time)) if self.time.size else np.nan,
        )
