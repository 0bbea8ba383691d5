"""``inins run-ekf``: tightly coupled INS/GPS EKF (EKF1 17 / EKF2 26 states, FF / FB) on
a simulated flight or a recording (spec §6, §6a, paper 003).

Simulated: the flight plan (:mod:`inins.ekf.flight`) gives the truth; the IMU stream
and the receiver simulation (:func:`inins.ekf.sources.simulated_epochs`, GNSS layer)
are generated epoch block by epoch block, so memory is flat in flight length. The
initial attitude is the gyrocompass result of the sensor errors on the ground.
Recorded: :func:`inins.io.flight_layout.read_flight` (import-flight output) or
:func:`inins.io.psins_tc.read_psins_tc` (the .mat directly); levelling on the static
window and the velocity-heading initialisation (:func:`inins.ekf.sources.velocity_heading`).
With ``compensation: FILE`` the recorded increments (and post's uniform-grid ones) are
compensated by :func:`inins.calibration.imu_model.compensate` before the filter.

Memory: the filter keeps no covariance per epoch (NEES scored batch by batch as it
runs, :mod:`inins.ekf.filter`); with ``filter.smoother: rts`` the forward store and the
smoothed covariances are temporary memory maps (:func:`inins.io.scratch.memmap_store`).
"""

import math
from dataclasses import replace

import numpy as np

from inins.calibration.imu_model import compensate
from inins.commands import run_ekf_figures, run_ekf_post, run_ekf_post_export, run_ekf_report
from inins.commands._compensation import scenario_terms
from inins.core import strapdown
from inins.core.units import ARCSEC, DEG, DPH
from inins.ekf import flight as fl
from inins.ekf import recorded, scoring, smoother, sources
from inins.ekf.config import Coupling, FilterConfig, InitialSigma, Model, clock_psd
from inins.ekf.filter import run_filter
from inins.ekf.tight_store import TightStore
from inins.exceptions import InputError
from inins.gnss import broadcast, constellation, ephemeris, glonass, gpstime, measurements
from inins.io import scratch
from inins.io.flight_layout import read_flight
from inins.io.resources import configs_root
from inins.io.rinex_nav import read_nav, read_navigation
from inins.results import CommandResult, Series
from inins.scenario.run_ekf import RunEkfScenario

SCENARIO_MODEL = RunEkfScenario
FIGURES = run_ekf_figures.FIGURES
FILES = run_ekf_post_export.files
"""The exports a ``post:`` section asks for (``post.export``)."""
OPTIONAL_FILES = run_ekf_post_export.OPTIONAL_FILES
built_in_checks = run_ekf_post.built_in_checks


def run(scenario, seed, *, sink=None, progress=None):
    """Run the filter on the scenario's flight or recording."""
    if scenario.post is not None:  # loosely coupled post-processing of a drive
        return run_ekf_post.run(scenario, seed, sink=sink, progress=progress)
    with scratch.memmap_store() as maps:  # a smoother's store and its output: on disk
        store = TightStore(maps) if scenario.filter.smoother == "rts" else None
        if scenario.data is not None:
            result, info = _recorded(scenario, store)
        else:
            result, info = _simulated(scenario, seed, progress, store)
        sm = None if store is None else smoother.smooth(store.run(), maps)
    smoothed = run_ekf_report.tight_smoothed(result, sm, scenario.filter.outages_s)
    summary = result.summary()
    if result.heading_error.size and np.any(result.time >= scenario.filter.turning_from_s):
        window = result.summary(window=(scenario.filter.turning_from_s, math.inf))
        summary = replace(summary, heading_err_rms_deg=window.heading_err_rms_deg)
    return CommandResult(
        command="run-ekf",
        results=_results(result, summary, info) | smoothed.results,
        truth=_truth(info),
        datasets=_datasets(result, info) | smoothed.datasets,
        attrs={
            "ekf": {
                "model": result.model,
                "coupling": result.coupling,
                "states": list(result.layout.names),
            }
        },
        report=_report(scenario, result, summary, info) + smoothed.report,
        warnings=info.get("dropped", ()),
    )


def filter_config(f, dt, lever, dither_window, systems="G"):
    """:class:`FilterConfig` from the scenario's filter section (its SI keywords,
    :meth:`inins.scenario.run_ekf.FilterSettings.to_si`) and the systems it takes
    (:func:`filter_systems`)."""
    si = f.to_si()
    si["systems"] = systems
    bias_psd, drift_psd = clock_psd(si.pop("clock_h0"), si.pop("clock_h_2"))
    return FilterConfig(
        Model(si.pop("model")),
        Coupling(si.pop("coupling")),
        dt,
        lever_arm=np.asarray(lever, float),
        initial_sigma=InitialSigma(**si.pop("initial_sigma")),
        clock_bias_psd=bias_psd,
        clock_drift_psd=drift_psd,
        dither_window=dither_window,
        **si,
    )


def filter_systems(f, available, key):
    """The systems the filter takes: ``filter.systems``, or every one ``available``
    (letters, GPS first); a system given that the data do not have is bad input."""
    have = "".join(x for x in "GREC" if x in available)
    if f.systems is None:
        return have or "G"
    missing = [x for x in f.systems if x not in have]
    if missing:
        raise InputError(
            f"system {''.join(missing)} is not in the {key} (it has {have or 'none'})",
            key="filter.systems",
        )
    return "".join(x for x in "GREC" if x in f.systems)


def _take_systems(nav, systems):
    """A mixed Navigation restricted to ``systems`` (letters)."""
    keep = np.isin(nav.kepler.prn // 100, ["GREC".index(x) for x in systems])
    glo = nav.glonass if "R" in systems else glonass.empty()
    return broadcast.Navigation(kepler=nav.kepler.take(keep), glonass=glo)


def _ephemeris(c, duration):
    if c.source == "mixed":  # four systems from one RINEX 3 file (no LEAP SECONDS: 17 s)
        week, sow0 = gpstime.from_calendar(2016, 6, 6, 0, 0, 0.0)
        path = configs_root().parent / "data" / "smartloc" / "BRDC00WRD_U_20161580000_01D_MN.rnx.gz"
        mixed = read_navigation(path, leap_seconds=17)
        return broadcast.from_records(mixed.records, mixed.glonass), week, sow0 + c.start_hour_s
    week, sow0 = gpstime.from_calendar(2015, 1, 8, 0, 0, 0.0)
    sow0 += c.start_hour_s
    if c.source == "walker":
        return constellation.walker(week, sow0, duration + 60.0, per_plane=c.per_plane), week, sow0
    nav = read_nav(configs_root().parent / "data" / "abpo0080.15n.gz")
    return ephemeris.from_columns(nav.records), week, sow0


def _reporting(stream, total, progress):
    """Pass the epochs on, calling ``progress(done, total)`` once a simulated minute."""
    for i, epoch in enumerate(stream):
        if progress is not None and i % 60 == 0:
            progress(i, total)
        yield epoch
    if progress is not None:
        progress(total, total)


def _simulated(scenario, seed, progress=None, store=None):
    fs, gs = scenario.flight, scenario.gnss
    plan = fs.plan()
    _check_imu(fs.imu)
    dt = 1.0 / fs.imu.sample_rate_hz
    errors = fs.imu.to_si()
    dither = fl.Dither(fs.dither.amplitude_arcsec * ARCSEC, fs.dither.frequency_hz)
    base = fl.flight_trajectory(plan)
    truth = fl.Dithered(base, dither)
    window = scenario.filter.dither_window
    window = fl.dither_window(dither, dt) if window == "auto" else window
    eph, week, sow0 = _ephemeris(gs.constellation, plan.duration)
    mixed = isinstance(eph, broadcast.Navigation)
    available = "".join("GRECJS"[k] for k in eph.systems) if mixed else "G"
    systems = filter_systems(scenario.filter, available, "constellation")
    unused = sorted(set(gs.system_bias_m) - set(systems))
    if unused:
        raise InputError(
            f"a bias for system {''.join(unused)}, which the simulation does not use "
            f"(systems {systems})",
            key="gnss.system_bias_m",
        )
    if mixed:
        eph = _take_systems(eph, systems)
    config = _checked(
        lambda: filter_config(scenario.filter, dt, gs.lever_arm_m, window, systems), "gnss"
    )
    rx = sources.Receiver(
        **gs.receiver_si(),
        filter_sigma_pr=scenario.filter.pseudorange_sigma_m,
        filter_sigma_rr=scenario.filter.range_rate_sigma_mps,
        filter_sigma_scale=scenario.filter.sigma_scale(),
    )
    mat0, vel0, lla0 = truth.state([0.0])
    mat_base, _, _ = base.state([0.0])
    aligned = fl.gyrocompass_attitude(mat_base[0], lla0[0, 0], lla0[0, 2], errors)
    initial = strapdown.NavState.from_attitude(aligned @ mat_base[0].T @ mat0[0], vel0[0], lla0[0])
    stream = _reporting(
        sources.simulated_epochs(truth, base, errors, dt, plan.duration, eph, week, sow0, rx, seed),
        math.floor(plan.duration),
        progress,
    )
    result = _checked(
        lambda: run_filter(
            config, initial, 0.0, stream, errors, store=store, capacity=math.floor(plan.duration)
        ),
        "gnss.mask_deg",
    )
    bias = dict(zip("GREC", np.zeros(4), strict=True)) | dict(gs.system_bias_m)
    info = {
        "errors": errors,
        "forward": np.array([1.0, 0.0, 0.0]),
        "track": None,
        # each bias state estimates its system's bias minus the reference system's
        "system_bias": {n: bias[n[-1]] - bias[systems[0]] for n in config.bias_names},
        "systems": systems,
    }
    return result, info


_CONFIG_KEYS = {  # FilterConfig key -> scenario key below the source ("gnss" / "data")
    "lever_arm": "lever_arm_m",
}


def _checked(func, key):
    """Run ``func``; an InputError without a scenario key path gets one (``key``, or the
    scenario key of a :class:`FilterConfig` field under ``key``)."""
    try:
        return func()
    except InputError as exc:
        if exc.key in _CONFIG_KEYS:
            raise InputError(str(exc.args[0]), key=f"{key}.{_CONFIG_KEYS[exc.key]}") from None
        if exc.key in (None, "gnss"):
            raise InputError(str(exc.args[0]), key=key) from None
        raise


_IMU_LIMITS = (  # scenario key, value getter, upper bound (lab units): beyond any real IMU
    ("gyro.arw_deg_rth", lambda i: max(i.gyro.arw_deg_rth), 100.0),
    ("accel.vrw_ug_rthz", lambda i: max(i.accel.vrw_ug_rthz), 1e5),
    ("gyro.bias_dph", lambda i: max(map(abs, i.gyro.bias_dph)), 3.6e5),
    ("accel.bias_ug", lambda i: max(map(abs, i.accel.bias_ug)), 1e6),
)


def _check_imu(imu):
    """Noise densities and biases out of any physical range (wrong units) are bad input."""
    for key, get, high in _IMU_LIMITS:
        if not get(imu) <= high:
            raise InputError(
                f"{get(imu):.6g} is beyond any real IMU (at most {high:g}): wrong unit?",
                key=f"flight.imu.{key}",
            )


def _read(data):
    if data.file.suffix.lower() == ".mat":
        from inins.io.psins_tc import read_psins_tc  # scipy.io: 0.3 s, only for a .mat

        return read_psins_tc(data.file)
    return read_flight(data.file)


def _recorded(scenario, store=None):
    d, f = scenario.data, scenario.filter
    rec = _read(d)
    if rec.imu is None or len(rec.imu.time) < 2:
        raise InputError("the recording has no IMU data", source=str(d.file), key="imu/time")
    imu = rec.imu
    dt = float(np.median(np.diff(imu.time)))
    sources.check_imu_time(imu.time, dt, str(d.file))
    terms = scenario_terms(scenario)
    if terms is not None:
        dth_c, dv_c = compensate(imu.dtheta, imu.dv, dt, terms)
        imu = replace(imu, dtheta=dth_c, dv=dv_c)
    obs = measurements.from_record(rec.gnss)
    present = {"GRECJS"[k] for k in np.unique(obs.prn // 100)}
    notes = ()
    if f.systems is None and "R" in present and rec.glonass is None:
        present.discard("R")  # a file imported before the layout carried GLONASS sets
        notes = ("GLONASS rows left out: the recording has no GLONASS navigation sets",)
    systems = filter_systems(f, present, "recording")
    obs = measurements.system_rows(obs, ["GREC".index(x) for x in systems])
    glo = None
    if "R" in systems:
        if rec.glonass is None:
            raise InputError(
                "GLONASS observations but no GLONASS navigation sets (gnss/glonass) in the "
                "recording: import it again, or leave R out of filter.systems",
                source=str(d.file),
                key="filter.systems",
            )
        glo = glonass.from_columns(**rec.glonass)
    start = recorded.prepare(
        imu.time,
        imu.dtheta,
        imu.dv,
        dt,
        obs,
        rec.ephemeris,
        rec.imu_t0_sow,
        glonass=glo,
        mask=d.mask_deg * DEG,
        klobuchar=None if rec.iono_alpha is None else (rec.iono_alpha, rec.iono_beta),
        static_window=d.static_window_s,
        motion_speed=d.motion_speed_mps,
        lever_arm=np.asarray(d.lever_arm_m, float),
        source=str(d.file),
    )
    window = 1 if f.dither_window == "auto" else f.dither_window
    config = _checked(lambda: filter_config(f, dt, d.lever_arm_m, window, systems), "data")
    stream = recorded.epoch_stream(
        start,
        imu.time,
        imu.dtheta,
        imu.dv,
        d.latency_s,
        f.pseudorange_sigma_m,
        f.range_rate_sigma_mps,
        sigma_scale=f.sigma_scale(),
    )
    result = _checked(
        lambda: run_filter(config, start.initial, start.t_start, stream, store=store),
        "data.mask_deg",
    )
    t = start.time
    idx = np.clip(np.searchsorted(t, result.gnss_time), 0, len(t) - 1)
    info = {
        "errors": None,
        "forward": np.asarray(d.forward_axis_b, float) / np.linalg.norm(d.forward_axis_b),
        "spp_pos": start.fix_pos[idx],
        "spp_vel_n": start.fix_vel_n[idx],
        "heading_init": start.heading,
        "lever": np.asarray(d.lever_arm_m, float),
        "dropped": (*rec.dropped, *notes),
        "systems": systems,
    }
    return result, info


def _null(value):
    return None if value is None or not np.isfinite(value) else float(value)


RESULT_NAMES = (
    "heading_err_rms_deg",
    "heading_err_final_deg",
    "pos_err_rms_m",
    "vel_err_rms_mps",
    "gyro_bias_z_est_dph",
    "gyro_bias_z_sigma_dph",
    "nees_mean",
    "nis_mean",
    "rejected_measurements",
    "coasted_epochs",
    "realtime_factor",
    "update_time_mean_s",
    "epochs",
    "fb_heading_correction_deg",
    "phi_d_est_final_deg",
    "spp_pos_diff_max_m",
    "spp_pos_diff_rms_m",
    "spp_vel_diff_max_mps",
    "spp_vel_diff_rms_mps",
    "initial_heading_deg",
    "mg_yz_est_arcsec",
    "mg_yz_sigma_arcsec",
    "mg_zy_est_arcsec",
    "mg_zy_sigma_arcsec",
)
"""Every result a run gives (null where not applicable: no truth, no recording, EKF1)."""
RESULT_NAMES += run_ekf_report.TIGHT_SMOOTH_NAMES  # null unless filter.smoother: rts
RESULT_NAMES += run_ekf_report.TIGHT_OUTAGE_NAMES  # null without truth and outages_s
TRUTH_NAMES = ("gyro_bias_z_est_dph", "mg_yz_est_arcsec", "mg_zy_est_arcsec")


def declared_results(scenario):
    """``(results, truth)`` names of every run, for validating checks before it."""
    if scenario.post is not None:
        return run_ekf_post.RESULT_NAMES, ()
    return RESULT_NAMES, TRUTH_NAMES


def estimate(scenario):
    """Size of the run and its numerical edges (:mod:`inins.commands.preflight`)."""
    from inins.commands.preflight import run_ekf_estimate

    return run_ekf_estimate(scenario)


def _results(result, s, info):
    out = dict.fromkeys(RESULT_NAMES)
    out |= {
        "heading_err_rms_deg": _null(s.heading_err_rms_deg),
        "heading_err_final_deg": _null(s.heading_err_final_deg),
        "pos_err_rms_m": _null(s.pos_err_rms_m),
        "vel_err_rms_mps": _null(s.vel_err_rms_mps),
        "gyro_bias_z_est_dph": _null(s.gyro_bias_z_est_dph),
        "gyro_bias_z_sigma_dph": _null(s.gyro_bias_z_sigma_dph),
        "nees_mean": _null(s.nees_mean),
        "nis_mean": _null(s.nis_mean),
        "rejected_measurements": int(s.rejected_measurements),
        "coasted_epochs": int(s.coasted_epochs),
        "realtime_factor": _null(s.realtime_factor),
        "update_time_mean_s": _null(s.update_time_mean_s),
        "epochs": int(result.time.size),
    }
    i = result.layout.index("phi_D")
    out["fb_heading_correction_deg"] = float(result.cumulative[-1, i] / DEG)
    out["phi_d_est_final_deg"] = float(result.state[-1, i] / DEG)
    if info.get("spp_pos") is not None:  # the antenna, compared with the SPP fix
        f = scoring.fix_differences(
            result.lla,
            result.quat_nb,
            result.vel_n,
            info["lever"],
            info["spp_pos"],
            info["spp_vel_n"],
        )
        out.update(
            spp_pos_diff_max_m=f.pos_max,
            spp_pos_diff_rms_m=f.pos_rms,
            spp_vel_diff_max_mps=f.vel_max,
            spp_vel_diff_rms_mps=f.vel_rms,
            initial_heading_deg=float(info["heading_init"].heading / DEG),
        )
    for name in ("mg_yz", "mg_zy"):
        if name in result.layout.names:
            out[f"{name}_est_arcsec"] = float(result.series(name)[0][-1] / ARCSEC)
            out[f"{name}_sigma_arcsec"] = float(result.series(name)[1][-1] / ARCSEC)
    return out


def _truth(info):
    e = info.get("errors")
    if e is None:
        return {}
    m = e.gyro_misalignment
    return {
        "gyro_bias_z_est_dph": float(e.gyro_bias[2] / DPH),
        "mg_yz_est_arcsec": float(m[3] / ARCSEC),
        "mg_zy_est_arcsec": float(m[5] / ARCSEC),
    }


def _datasets(r, info):
    d = {
        "nav/time": Series(r.time, "s", "", "1PPS epoch (naive pairing: data arrival)"),
        "nav/lla": Series(r.lla, "rad, rad, m", "", "corrected position (IMU)"),
        "nav/vel_n": Series(r.vel_n, "m/s", "n", "corrected velocity"),
        "nav/quat_nb": Series(r.quat_nb, "1", "nb", "corrected attitude"),
        "states/estimate": Series(r.state, "SI", "", "error-state estimate (sensor totals)"),
        "states/sigma": Series(r.sigma, "SI", "", "1-sigma of each state"),
        "states/cumulative": Series(r.cumulative, "SI", "", "FB cumulative corrections"),
        "epochs/n_sats": Series(r.n_sats, "1", "", "satellites given"),
        "epochs/n_rejected": Series(r.n_rejected, "1", "", "measurements rejected by the gate"),
        "epochs/coasted": Series(r.coasted.astype(np.int8), "1", "", "no update this epoch"),
        "epochs/nis": Series(r.nis, "1", "", "sum of accepted NIS per epoch"),
        "epochs/update_time": Series(
            r.update_time, "s", "", "epoch step wall time, mean over its batch of epochs"
        ),
        "innovations/epoch": Series(r.innovations.epoch, "1", "", "epoch index"),
        "innovations/prn": Series(r.innovations.prn, "1", "", "satellite"),
        "innovations/kind": Series(r.innovations.kind, "1", "", "0 pseudorange, 1 range rate"),
        "innovations/value": Series(r.innovations.value, "m or m/s", "", "innovation"),
        "innovations/variance": Series(r.innovations.variance, "m^2 or m^2/s^2", "", "HPH'+R"),
        "innovations/accepted": Series(r.innovations.accepted.astype(np.int8), "1", "", "gate"),
    }
    if r.nav_error.shape[0]:
        d["truth/nav_error"] = Series(r.nav_error, "m, m/s, rad", "n", "output minus truth")
        d["truth/heading_error"] = Series(r.heading_error, "rad", "", "heading minus truth")
    if r.nees.size:
        d["truth/nees"] = Series(r.nees, "1", "", "NEES of all states")
    truth = run_ekf_report.state_truth(info.get("errors"), r.layout.names, info.get("system_bias"))
    if truth:
        vector = np.array([truth.get(n, np.nan) for n in r.layout.names])
        d["truth/states"] = Series(vector, "SI", "", "true sensor states (NaN: none single)")
    if info.get("spp_pos") is not None:
        d["spp/pos_e"] = Series(info["spp_pos"], "m", "e", "SPP antenna position at each epoch")
        d["spp/vel_n"] = Series(info["spp_vel_n"], "m/s", "n", "SPP range-rate velocity")
    d["nav/forward_heading"] = Series(
        scoring.forward_heading(r.quat_nb, info["forward"]),
        "rad",
        "",
        "heading of the body forward axis",
    )
    return d


def _report(scenario, r, s, info):
    source = "recording " + scenario.data.file.name if scenario.data else "simulated flight"
    lines = [
        f"{r.model.upper()}-{r.coupling.upper()} ({len(r.layout.names)} states) on the "
        f"{source}: {r.time.size} epochs, {r.flight_time:.1f} s",
        f"realtime factor {s.realtime_factor:.4g} (wall {r.wall_time:.3g} s, first epoch "
        f"includes JIT compilation), epoch step {1e3 * s.update_time_mean_s:.3g} ms mean",
        run_ekf_report.summary_line(s, info.get("errors") is not None),
        run_ekf_report.heading_line(
            s, scenario.filter.turning_from_s, info.get("errors") is not None
        ),
    ]
    biases = [n for n in r.layout.names if n.startswith("isb_")]
    if biases:
        lines.append(
            f"GNSS systems {info['systems']}: the receiver clock on {info['systems'][0]}, "
            f"inter-system bias states {', '.join(biases)}"
        )
    if info.get("heading_init") is not None:
        h = info["heading_init"]
        axis = h.mat_nb @ info["forward"]
        used = ", ".join(f"{t:g}" for t in h.epochs)
        lines.append(
            f"initial attitude: levelled on {list(scenario.data.static_window_s)} s; heading "
            f"of the forward axis {math.degrees(math.atan2(axis[1], axis[0])):.2f} deg "
            f"(body x {h.heading / DEG:.2f} deg) from the velocity at {used} s"
        )
    truth = run_ekf_report.state_truth(info.get("errors"), r.layout.names, info.get("system_bias"))
    lines += run_ekf_report.final_states(r.layout.names, r.state[-1], r.sigma[-1], truth)
    lines += run_ekf_report.truth_table(_results(r, s, info), _truth(info))
    return "\n".join(lines)
