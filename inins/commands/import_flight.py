"""``inins import-flight``: a GNSS recording into the recorded-flight layout, checked by
single-point positioning (spec §6, §6a).

Reads RINEX observation + navigation files or the PSINS tc file
(:mod:`inins.io.rinex_obs`, :mod:`inins.io.rinex_nav`, :mod:`inins.io.psins_tc`),
writes the recorded-flight layout (:mod:`inins.io.flight_layout`: ``gnss/``,
``imu/`` and the root attributes) into ``import-flight.h5`` so that run-ekf reads it
with :func:`inins.io.flight_layout.read_flight`, and adds the SPP check of every
epoch under ``spp/``: satellites used, PDOP, residual RMS, position, velocity,
track, and the error against a known position when the scenario gives one.
"""

import numpy as np

from inins.commands import figures
from inins.core import earth
from inins.core.units import DEG
from inins.exceptions import InputError
from inins.gnss import ephemeris, measurements, spp
from inins.gnss.measurements import Signal
from inins.gnss.spp import FixStatus
from inins.io import flight_layout
from inins.io.flight_checks import checked_flight
from inins.io.flight_layout import ImuRecord, RecordedFlight
from inins.io.psins_tc import read_psins_tc
from inins.io.rinex_nav import read_nav
from inins.io.rinex_obs import observable, read_obs
from inins.results import CommandResult, Series, format_table
from inins.scenario.import_flight import ImportFlightScenario

SCENARIO_MODEL = ImportFlightScenario
FIGURES = {
    "import-flight-track.png": figures.import_flight_track,
    "import-flight-residuals.png": figures.import_flight_residuals,
    "import-flight-sky.png": figures.import_flight_sky,
}


def run(scenario, seed, *, sink=None, progress=None):
    """Read the recording, solve every epoch, and describe both; ``seed`` is unused."""
    flight, approx_pos_e = read_recording(scenario)
    reference = _reference(scenario, approx_pos_e)
    changes = {"reference_pos_e": reference}
    if scenario.imu_log is not None:
        changes |= {
            "imu": imu_from_log(scenario.imu_log, progress),
            "imu_t0_week": int(flight.gnss.week[0]),
            "imu_t0_sow": float(scenario.imu_t0_sow),
        }
    flight = RecordedFlight(**{**vars(flight), **changes})
    source = str(scenario.nav_file or scenario.file)
    if scenario.format == "rinex":  # the PSINS reader checks its own flight
        flight = checked_flight(flight, scenario.obs_file)
    obs = measurements.from_record(flight.gnss)
    epochs = measurements.attach_satellites(
        obs, ephemeris.from_columns(flight.ephemeris), source=source
    )
    klobuchar, iono = _ionosphere(scenario.spp.ionosphere, flight, epochs)
    options = spp.SppOptions(
        mask_rad=scenario.spp.mask_deg * DEG,
        sigma_zenith_m=scenario.spp.sigma_zenith_m,
        false_alarm=scenario.spp.false_alarm,
        klobuchar=klobuchar,
    )
    solution = spp.solve(epochs, options)
    check = SppCheck(solution, flight, scenario.static_window_imu_s, epochs)
    datasets = {
        path: Series(value, unit, "", description)
        for path, (value, unit, description) in flight_layout.flight_arrays(flight).items()
    }
    datasets.update(check.datasets())
    return CommandResult(
        command="import-flight",
        results=check.results(),
        datasets=datasets,
        attrs={"": flight_layout.flight_attrs(flight), "spp": {"ionosphere": iono}},
        report=report(scenario, flight, epochs, check, iono),
        warnings=(*flight.dropped, *check.warnings),
    )


RESULT_NAMES = (
    "epochs",
    "epochs_fix",
    "epochs_no_fix",
    "epochs_fault_excluded",
    "epochs_fault_detected",
    "satellites_used_median",
    "pdop_median",
    "residual_rms_median_m",
    "track_length_m",
    "speed_max_mps",
    "err_3d_rms_m",
    "err_3d_p95_m",
    "err_3d_max_m",
    "imu_samples",
    "track_length_imu_m",
    "static_horizontal_std_m",
    "static_speed_rms_mps",
)
"""Every result a run gives (null where not applicable)."""


def declared_results(scenario):
    """``(results, truth)`` names of every run, for validating checks before it."""
    return RESULT_NAMES, ()


def estimate(scenario):
    """None: a recording is a few MB (the whole ABPO day is 3 MB of text)."""
    return None


def read_recording(scenario):
    """The :class:`RecordedFlight` of the scenario's files, and the RINEX header position
    (NaN for the PSINS file)."""
    if scenario.format == "psins-tc":
        return read_psins_tc(scenario.file), np.full(3, np.nan)
    obs_file, nav = read_obs(scenario.obs_file), read_nav(scenario.nav_file)
    obs = measurements.from_code(
        obs_file.week,
        obs_file.time,
        obs_file.start,
        obs_file.prn,
        observable(obs_file, "P1"),
        observable(obs_file, "P2"),
        observable(obs_file, "C1"),
        doppler_l1=observable(obs_file, "D1"),
        snr=observable(obs_file, "S1"),
    )
    carrier = observable(obs_file, "L1") * measurements.LAMBDA_L1
    gnss = flight_layout.GnssRecord(
        week=obs.week,
        time=obs.time,
        start=obs.start,
        prn=obs.prn,
        pseudorange=obs.pseudorange,
        signal=obs.signal,
        range_rate=obs.range_rate,
        sigma=obs.sigma,
        snr=obs.snr,
        carrier=carrier,
    )
    flight = RecordedFlight(
        gnss=gnss,
        ephemeris=nav.records,
        imu=None,
        source=f"RINEX {obs_file.version:g} {scenario.obs_file.name}, {scenario.nav_file.name}",
        imu_t0_week=-1,
        imu_t0_sow=float("nan"),
        reference_pos_e=np.full(3, np.nan),
        iono_alpha=nav.iono_alpha,
        iono_beta=nav.iono_beta,
    )
    return flight, obs_file.approx_pos_e


def imu_from_log(path, progress=None):
    """The IMU increments of an import-log scenario's log (body axes, SI) as an
    :class:`inins.io.flight_layout.ImuRecord`; time is the end of each sample interval
    on the log's uniform grid ``t0 + (k + 1) dt``."""
    from inins.io.logimport import LogReader
    from inins.scenario.base import load_scenario
    from inins.scenario.import_log import ImportLogScenario, import_settings

    log_scenario = load_scenario(ImportLogScenario, path, [], None)[0]
    reader = LogReader(import_settings(log_scenario))
    parts = [(c.table.dtheta, c.table.dv) for c in reader.chunks(progress)]
    extent = reader.extent
    time = extent.t0 + (np.arange(extent.n) + 1.0) * extent.dt
    return ImuRecord(
        time=time,
        dtheta=np.concatenate([p[0] for p in parts]),
        dv=np.concatenate([p[1] for p in parts]),
    )


def _reference(scenario, approx_pos_e):
    if scenario.reference_pos_e_m is not None:
        return np.array(scenario.reference_pos_e_m, dtype=float)
    if scenario.reference == "header":
        if not np.all(np.isfinite(approx_pos_e)):
            raise InputError(
                "the RINEX header has no APPROX POSITION XYZ",
                source=str(scenario.obs_file),
                key="reference",
            )
        return np.asarray(approx_pos_e, dtype=float)
    return np.full(3, np.nan)


def _ionosphere(choice, flight, epochs):
    """Klobuchar coefficients for SPP (or None) and the text naming the model used."""
    has_klobuchar = flight.iono_alpha is not None and flight.iono_beta is not None
    free = int(np.count_nonzero(epochs.obs.signal == Signal.IONO_FREE))
    rows = len(epochs.obs.signal)
    if choice == "iono-free" and free < rows:
        raise InputError(
            f"ionosphere-free needs P1 and P2 on every row; {rows - free} of {rows} rows "
            "have single-frequency code only",
            key="spp.ionosphere",
        )
    if choice == "klobuchar" and not has_klobuchar:
        raise InputError(
            "the navigation data carry no Klobuchar coefficients", key="spp.ionosphere"
        )
    use = has_klobuchar and choice in ("auto", "klobuchar")
    klobuchar = (flight.iono_alpha, flight.iono_beta) if use else None
    single = "Klobuchar" if use else "none (single frequency, several metres of error)"
    if free == rows:
        return None, "ionosphere-free P1/P2 combination"
    if free == 0:
        return klobuchar, f"single-frequency L1; ionosphere model: {single}"
    return klobuchar, (
        f"ionosphere-free P1/P2 on {free} of {rows} rows; the others L1 "
        f"with ionosphere model: {single}"
    )


class SppCheck:
    """The SPP solution with the figures the report and summary carry."""

    def __init__(self, solution, flight, window, epochs=None):
        self.epochs = epochs
        self.sol = solution
        self.flight = flight
        self.window = window
        self.fixed = np.isfinite(solution.pos[:, 0])
        self.track = spp.track(solution)
        ref = flight.reference_pos_e
        self.error_ned = spp.errors_ned(solution, ref) if np.all(np.isfinite(ref)) else None
        self.warnings = ()
        if not self.fixed.any():
            self.warnings = ("no epoch has four satellites above the mask: no fix at all",)

    def imu_time(self):
        """Epoch times on the IMU clock (s), NaN without IMU."""
        return self.sol.time - self.flight.imu_t0_sow

    def static_mask(self):
        if self.window is None or self.flight.imu is None:
            return None
        t = self.imu_time()
        return (t >= self.window[0]) & (t <= self.window[1]) & self.fixed

    def results(self):
        s, status = self.sol, self.sol.status
        out = {
            "epochs": len(s.time),
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
        imu = self.flight.imu
        out["imu_samples"] = 0 if imu is None else len(imu.time)
        during = None
        if imu is not None:
            t = self.imu_time()
            span = (t >= 0.0) & (t <= imu.time[-1])
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

    def datasets(self):
        s = self.sol
        lla = earth.llh_from_ecef(np.nan_to_num(s.pos))
        lla[~self.fixed] = np.nan
        out = {
            "spp/time": Series(s.time, "s", "", "receive time tag, GPS seconds of week"),
            "spp/pos_e": Series(s.pos, "m", "e", "antenna position, ECEF (NaN: no fix)"),
            "spp/lla": Series(lla, "rad, rad, m", "", "latitude, longitude, height"),
            "spp/vel_n": Series(self.track.vel_n, "m/s", "n", "range-rate velocity, NED"),
            "spp/clock_m": Series(s.clock, "m", "", "receiver clock bias c dt_rx"),
            "spp/drift_mps": Series(s.drift, "m/s", "", "receiver clock drift c dt_rx_dot"),
            "spp/status": Series(
                s.status.astype(np.int8),
                "1",
                "",
                "0 fix, 1 no fix, 2 fault excluded, 3 fault detected, 4 not converged",
            ),
            "spp/satellites_used": Series(s.n_used, "1", "", "satellites in the fix"),
            "spp/pdop": Series(s.pdop, "1", "", "position dilution of precision"),
            "spp/residual_rms": Series(s.residual_rms, "m", "", "RMS of the used residuals"),
            "spp/excluded_prn": Series(s.excluded_prn, "1", "", "satellite excluded, 0 none"),
            "spp/distance": Series(self.track.distance, "m", "", "path length so far"),
        }
        out.update(self.row_datasets())
        if self.error_ned is not None:
            out["spp/error_ned"] = Series(
                self.error_ned, "m", "n", "position error against the reference, NED"
            )
        return out

    def row_datasets(self):
        """Per measurement row: elevation and azimuth seen from the epoch's fix (NaN
        without one), the residual and whether the fix used it (the sky plot, the
        residual figure)."""
        if self.epochs is None:
            return {}
        s, obs = self.sol, self.epochs.obs
        counts = np.diff(obs.start)
        rx = np.repeat(s.pos, counts, axis=0)
        los = self.epochs.sat_pos - rx
        lla = earth.llh_from_ecef(np.nan_to_num(rx))
        mat = earth.mat_en(lla[:, 0], lla[:, 1])  # (m, 3, 3) ECEF from NED
        ned = np.einsum("mji,mj->mi", mat, los)
        rng = np.linalg.norm(ned, axis=1)
        with np.errstate(invalid="ignore"):
            el = np.arcsin(-ned[:, 2] / rng)
        az = np.mod(np.arctan2(ned[:, 1], ned[:, 0]), 2 * np.pi)
        return {
            "spp/row_elevation": Series(el, "rad", "", "elevation from the fix (NaN: no fix)"),
            "spp/row_azimuth": Series(az, "rad", "", "azimuth from the fix, from north"),
            "spp/row_prn": Series(obs.prn, "1", "", "satellite of each row"),
            "spp/row_epoch": Series(np.repeat(np.arange(len(counts)), counts), "1", "", "epoch"),
            "spp/residual": Series(s.residual, "m", "", "pseudorange residual (measured - model)"),
            "spp/row_used": Series(s.used.astype(np.int8), "1", "", "row used in the fix"),
        }


def _median(values):
    return float(np.median(values)) if len(values) else None


def _max(values):
    values = values[np.isfinite(values)]
    return float(values.max()) if len(values) else None


def _rms(values):
    return float(np.sqrt(np.mean(np.square(values)))) if len(values) else None


def _p95(values):
    return float(np.percentile(values, 95))


def report(scenario, flight, epochs, check, iono):
    """Report body: the recording as read, the SPP check, errors and track."""
    r = check.results()
    s = check.sol
    g = flight.gnss
    span = (s.time[-1] - s.time[0]) if len(s.time) else 0.0
    lines = [
        f"source: {flight.source}",
        f"{r['epochs']} epochs over {span:g} s, {len(g.prn)} satellite measurements, "
        f"{len(flight.ephemeris)} broadcast ephemeris sets",
        f"ionosphere: {iono}",
        f"SPP: mask {scenario.spp.mask_deg:g} deg, weights sigma/sin(el) with "
        f"{scenario.spp.sigma_zenith_m:g} m at zenith, Saastamoinen troposphere, residual "
        f"test at false-alarm {scenario.spp.false_alarm:g}",
    ]
    if flight.dropped:
        lines.append("dropped at the edge checks (counted, not used):")
        lines += [f"  {note}" for note in flight.dropped]
    dropped = dict(zip(epochs.dropped_prn.tolist(), epochs.dropped_count.tolist(), strict=True))
    if dropped:
        lines.append(
            "measurements without a healthy ephemeris (dropped): "
            + ", ".join(f"G{p:02d} x{c}" for p, c in sorted(dropped.items()))
        )
    if flight.imu is not None:
        imu = flight.imu
        lines.append(
            f"IMU: {len(imu.time)} samples, t {imu.time[0]:g}-{imu.time[-1]:g} s; "
            f"IMU t = 0 at GPS week {flight.imu_t0_week}, "
            f"{flight.imu_t0_sow:.3f} s of week"
        )
    rows = [
        [name, value]
        for name, value in (
            ("epochs with a fix", r["epochs_fix"]),
            ("no fix (< 4 satellites)", r["epochs_no_fix"]),
            ("a fault excluded", r["epochs_fault_excluded"]),
            ("a fault detected, not isolated", r["epochs_fault_detected"]),
            ("satellites used (median)", r["satellites_used_median"]),
            ("PDOP (median)", r["pdop_median"]),
            ("residual RMS (median)", r["residual_rms_median_m"]),
            ("track length", r["track_length_m"]),
            ("track during the IMU", r["track_length_imu_m"]),
            ("highest speed", r["speed_max_mps"]),
        )
    ]
    lines += [
        "",
        "single-point positioning of every epoch",
        format_table(rows, ["", "value"], fmt=".5g"),
    ]
    excluded = sorted(set(s.excluded_prn[s.excluded_prn > 0].tolist()))
    if excluded:
        lines.append(
            "satellites excluded by the residual test: " + ", ".join(f"G{p:02d}" for p in excluded)
        )
    if check.error_ned is not None:
        ned = check.error_ned[np.isfinite(check.error_ned[:, 0])]
        rms = np.sqrt(np.mean(ned**2, axis=0))
        lines += [
            "",
            f"against the reference position {np.round(flight.reference_pos_e, 3)} m "
            f"(ECEF): 3D RMS {r['err_3d_rms_m']:.3f} m, 95th percentile "
            f"{r['err_3d_p95_m']:.3f} m, max {r['err_3d_max_m']:.3f} m; RMS north "
            f"{rms[0]:.3f}, east {rms[1]:.3f}, down {rms[2]:.3f} m",
        ]
    if r["static_horizontal_std_m"] is not None:
        w = scenario.static_window_imu_s
        lines += [
            "",
            f"standing (IMU t {w[0]:g}-{w[1]:g} s): horizontal scatter "
            f"{r['static_horizontal_std_m']:.3f} m (std), range-rate speed "
            f"{r['static_speed_rms_mps']:.3f} m/s RMS",
        ]
    return "\n".join(lines)
