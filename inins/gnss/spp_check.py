"""The statistics of a single-point solution over a recording: what import-flight
reports of its SPP check (spec §6a).

:class:`SppCheck` holds a :class:`~inins.gnss.spp.SppSolution` with the recording's
reference position, IMU time base and static window, and gives the figures: epochs
fixed and accepted by the residual test, satellites, PDOP and residuals, the track
(length, speed), the error against a known position (ECEF to NED at it) or a reference
trajectory (horizontal, interpolated in time), the horizontal scatter and range-rate
speed while standing, and per measurement row the elevation and azimuth seen from the
epoch's fix.
"""

import numpy as np

from inins.core import earth
from inins.gnss import spp
from inins.gnss.spp import FixStatus


def _median(values):
    return float(np.median(values)) if len(values) else None


def _max(values):
    values = values[np.isfinite(values)]
    return float(values.max()) if len(values) else None


def _rms(values):
    return float(np.sqrt(np.mean(np.square(values)))) if len(values) else None


def _p95(values):
    return float(np.percentile(values, 95))


class SppCheck:
    """The SPP solution with the figures a report and a summary carry.

    Parameters
    ----------
    solution : inins.gnss.spp.SppSolution
    reference_pos_e : ndarray (3,)
        Known antenna position (ECEF m), NaN if none.
    imu_t0_sow : float
        GPS seconds of week of IMU time 0 (NaN without IMU).
    imu_end : float or None
        Last IMU time (s on the IMU axis); None without IMU.
    window : (float, float) or None
        Standing still, IMU time (s).
    epochs : inins.gnss.measurements.GnssEpochs, optional
        The measurements solved (for the per-row geometry).
    """

    def __init__(self, solution, reference_pos_e, imu_t0_sow, imu_end, window, epochs=None):
        self.epochs = epochs
        self.sol = solution
        self.imu_t0_sow = imu_t0_sow
        self.imu_end = imu_end
        self.window = window
        self.fixed = np.isfinite(solution.pos[:, 0])
        self.track = spp.track(solution)
        ref = np.asarray(reference_pos_e, float)
        self.error_ned = spp.errors_ned(solution, ref) if np.all(np.isfinite(ref)) else None
        self.warnings = ()
        self.single_frequency_dropped = 0
        self.track_error_h = None
        self.track_inside = 0
        self.track_reference = None
        if not self.fixed.any():
            self.warnings = ("no epoch has four satellites above the mask: no fix at all",)

    def score_track(self, time, pos, offset_s):
        """Horizontal errors of the accepted fixes against a reference trajectory whose time
        is GPS seconds of week minus ``offset_s`` (linear interpolation; epochs outside it
        are not scored). Keeps the reference at each epoch (ECEF, m; NaN outside it) in
        ``track_reference``."""
        t = self.sol.time - offset_s
        inside = (t >= time[0]) & (t <= time[-1])
        ref = np.stack([np.interp(t, time, pos[:, i]) for i in range(3)], axis=1)
        lla = earth.llh_from_ecef(pos[0])
        ned = (self.sol.pos - ref) @ earth.mat_en(lla[0], lla[1])
        err = np.hypot(ned[:, 0], ned[:, 1])
        self.track_error_h = np.where(inside & self.accepted, err, np.nan)
        self.track_inside = int(inside.sum())
        self.track_reference = np.where(inside[:, None], ref, np.nan)

    @property
    def accepted(self):
        """Epochs with a fix that passed the residual test (directly or after exclusions)."""
        status = self.sol.status
        return self.fixed & ((status == FixStatus.FIX) | (status == FixStatus.FAULT_EXCLUDED))

    def imu_time(self):
        """Epoch times on the IMU clock (s), NaN without IMU."""
        return self.sol.time - self.imu_t0_sow

    def static_mask(self):
        """Fixed epochs inside the static window, or None without window or IMU."""
        if self.window is None or self.imu_end is None:
            return None
        t = self.imu_time()
        return (t >= self.window[0]) & (t <= self.window[1]) & self.fixed

    def lla(self):
        """Latitude, longitude (rad), height (m) of every fix (m, 3), NaN without one."""
        lla = earth.llh_from_ecef(np.nan_to_num(self.sol.pos))
        lla[~self.fixed] = np.nan
        return lla

    def results(self):
        """The figures by name (SI, the unit a suffix; None where they do not apply)."""
        s, status = self.sol, self.sol.status
        err_h = self.track_error_h
        scored = None if err_h is None else err_h[np.isfinite(err_h)]
        out = {
            "epochs": len(s.time),
            "epochs_accepted": int(np.count_nonzero(self.accepted)),
            "single_frequency_rows_dropped": int(self.single_frequency_dropped),
            "err_h_median_m": None if scored is None or not scored.size else _median(scored),
            "err_h_p95_m": None if scored is None or not scored.size else _p95(scored),
            "epochs_scored": None if scored is None else int(scored.size),
            "epochs_fix": int(np.count_nonzero(self.fixed)),
            "epochs_no_fix": int(np.count_nonzero(status == FixStatus.NO_FIX)),
            "epochs_fault_excluded": int(np.count_nonzero(status == FixStatus.FAULT_EXCLUDED)),
            "epochs_fault_detected": int(np.count_nonzero(status == FixStatus.FAULT_DETECTED)),
            "satellites_used_median": _median(s.n_used[self.fixed]),
            "pdop_median": _median(s.pdop[self.fixed]),
            "residual_rms_median_m": _median(s.residual_rms[self.fixed]),
            "track_length_m": float(self.track.distance[-1]) if len(s.time) else 0.0,
            "speed_max_mps": _max(self.track.speed[self.fixed]),
        }
        err = None if self.error_ned is None else np.linalg.norm(self.error_ned, axis=1)
        err = None if err is None else err[np.isfinite(err)]
        out["err_3d_rms_m"] = None if err is None or not err.size else _rms(err)
        out["err_3d_p95_m"] = None if err is None or not err.size else _p95(err)
        out["err_3d_max_m"] = None if err is None or not err.size else float(err.max())
        during = None
        if self.imu_end is not None:
            t = self.imu_time()
            span = (t >= 0.0) & (t <= self.imu_end)
            if span.any():
                d = self.track.distance[span]
                during = float(d[-1] - d[0])
        out["track_length_imu_m"] = during
        still = self.static_mask()
        if still is not None and still.sum() >= 2:
            centre = self.sol.pos[still].mean(axis=0)
            lla = earth.llh_from_ecef(centre)
            ned = (self.sol.pos[still] - centre) @ earth.mat_en(lla[0], lla[1])
            out["static_horizontal_std_m"] = float(np.hypot(*ned[:, :2].std(axis=0)))
            speed = np.linalg.norm(self.sol.vel[still], axis=1)
            out["static_speed_rms_mps"] = _rms(speed[np.isfinite(speed)])
        else:
            out["static_horizontal_std_m"] = out["static_speed_rms_mps"] = None
        return out

    def row_geometry(self):
        """Per measurement row: elevation and azimuth (rad, from north) seen from the
        epoch's fix (NaN without one) and the row's epoch index; None without the
        measurements."""
        if self.epochs is None:
            return None
        obs = self.epochs.obs
        counts = np.diff(obs.start)
        rx = np.repeat(self.sol.pos, counts, axis=0)
        los = self.epochs.sat_pos - rx
        lla = earth.llh_from_ecef(np.nan_to_num(rx))
        mat = earth.mat_en(lla[:, 0], lla[:, 1])  # (m, 3, 3) ECEF from NED
        ned = np.einsum("mji,mj->mi", mat, los)
        rng = np.linalg.norm(ned, axis=1)
        with np.errstate(invalid="ignore"):
            el = np.arcsin(-ned[:, 2] / rng)
        az = np.mod(np.arctan2(ned[:, 1], ned[:, 0]), 2 * np.pi)
        return el, az, np.repeat(np.arange(len(counts)), counts)
