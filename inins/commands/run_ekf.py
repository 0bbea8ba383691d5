"""``inins run-ekf``: tightly coupled INS/GPS EKF (EKF1 17 / EKF2 26 states, FF / FB) on
a simulated flight or a recording (spec §6, §6a, paper 003).

Simulated: the flight plan (:mod:`inins.ekf.flight`) gives the truth; the IMU stream
and the receiver simulation (:func:`inins.ekf.sources.simulated_epochs`, GNSS layer)
are generated epoch block by epoch block, so memory is flat in flight length. The
initial attitude is the gyrocompass result of the sensor errors on the ground.
Recorded: :func:`inins.io.flight_layout.read_flight` (import-flight output) or
:func:`inins.io.psins_tc.read_psins_tc` (the .mat directly); levelling on the static
window and the velocity-heading initialisation (:func:`inins.ekf.sources.velocity_heading`).
"""

import math
from dataclasses import replace

import numpy as np

from inins.commands import figures, run_ekf_post
from inins.core import earth, rotation, strapdown
from inins.core.units import ARCSEC, DEG, DEG_RTH, DPH, UG, UG_RTHZ
from inins.ekf import flight as fl
from inins.ekf import sources
from inins.ekf.config import Coupling, FilterConfig, InitialSigma, Model
from inins.ekf.filter import run_filter
from inins.exceptions import InputError
from inins.gnss import constellation, ephemeris, gpstime, measurements, spp
from inins.gnss.orbit import C
from inins.io.flight_layout import read_flight
from inins.io.psins_tc import read_psins_tc
from inins.io.resources import configs_root
from inins.io.rinex_nav import read_nav
from inins.results import CommandResult, Series, format_table
from inins.scenario.run_ekf import RunEkfScenario

SCENARIO_MODEL = RunEkfScenario
FIGURES = run_ekf_post.with_post_figures(
    {
        "run-ekf-heading-error.png": figures.run_ekf_heading,
        "run-ekf-gyro-bias.png": figures.run_ekf_gyro_bias,
        "run-ekf-misalignment.png": figures.run_ekf_misalignment,
        "run-ekf-fb-corrections.png": figures.run_ekf_corrections,
    }
)
_KIND = {"wait": fl.LegKind.WAIT, "takeoff": fl.LegKind.TAKEOFF, "straight": fl.LegKind.STRAIGHT}


def run(scenario, seed, *, sink=None, progress=None):
    """Run the filter on the scenario's flight or recording."""
    if scenario.post is not None:  # loosely coupled post-processing of a drive
        return run_ekf_post.run(scenario, seed, sink=sink, progress=progress)
    if scenario.data is not None:
        result, info = _recorded(scenario)
    else:
        result, info = _simulated(scenario, seed, progress)
    summary = result.summary()
    if result.heading_error.size and np.any(result.time >= scenario.filter.turning_from_s):
        window = result.summary(window=(scenario.filter.turning_from_s, math.inf))
        summary = replace(summary, heading_err_rms_deg=window.heading_err_rms_deg)
    return CommandResult(
        command="run-ekf",
        results=_results(result, summary, info),
        truth=_truth(info),
        datasets=_datasets(result, info),
        attrs={
            "ekf": {
                "model": result.model,
                "coupling": result.coupling,
                "states": list(result.layout.names),
            }
        },
        report=_report(scenario, result, summary, info),
    )


def filter_config(f, dt, lever, dither_window):
    """:class:`FilterConfig` in SI from the scenario's filter section."""
    n, s = f.noise, f.initial_sigma
    h0, hm2 = n.clock_h0_s, n.clock_hm2_per_s
    return FilterConfig(
        Model(f.model),
        Coupling(f.coupling),
        dt,
        lever_arm=np.asarray(lever, float),
        arw=np.full(3, n.arw_deg_rth * DEG_RTH),
        vrw=np.full(3, n.vrw_ug_rthz * UG_RTHZ),
        gyro_bias_rw=np.full(3, n.gyro_bias_walk_dph * DPH / 60.0),  # per sqrt(3600 s)
        accel_bias_rw=np.full(3, n.accel_bias_walk_ug * UG / 60.0),
        clock_bias_psd=C**2 * h0 / 2.0,
        clock_drift_psd=C**2 * 2.0 * math.pi**2 * hm2,
        initial_sigma=InitialSigma(
            position=s.position_m,
            velocity=s.velocity_mps,
            tilt=s.tilt_deg * DEG,
            heading=s.heading_deg * DEG,
            accel_bias=s.accel_bias_ug * UG,
            gyro_bias=s.gyro_bias_dph * DPH,
            accel_misalignment=s.accel_misalignment_arcsec * ARCSEC,
            gyro_misalignment=s.gyro_misalignment_arcsec * ARCSEC,
            clock_bias=s.clock_bias_m,
            clock_drift=s.clock_drift_mps,
        ),
        gate_probability=f.gate_probability,
        dither_window=dither_window,
        outages=tuple(f.outages_s),
        use_range_rate=f.use_range_rate,
        pps_storage=f.pps_storage,
    )


def flight_plan(flight):
    """:class:`inins.ekf.flight.FlightPlan` of the scenario (validated there, keys named)."""
    legs = []
    for leg in flight.legs:
        speed = math.nan if leg.speed_mps is None else leg.speed_mps
        if leg.kind in ("climb", "descend"):
            rate = leg.climb_rate_mps if leg.kind == "climb" else -leg.climb_rate_mps
            legs.append(fl.Leg(fl.LegKind.CLIMB, leg.duration_s, speed, climb_rate=rate))
        elif leg.kind == "turn":
            sign = 1.0 if leg.direction == "right" else -1.0
            legs.append(
                fl.Leg(
                    fl.LegKind.TURN,
                    leg.duration_s,
                    speed,
                    bank=leg.bank_deg * DEG,
                    angle=sign * leg.angle_deg * DEG,
                    turn_rate=math.nan if leg.turn_rate_dps is None else leg.turn_rate_dps * DEG,
                )
            )
        else:
            legs.append(fl.Leg(_KIND[leg.kind], leg.duration_s, speed))
    lla = flight.site.lla()
    plan = fl.FlightPlan(
        lla[0], lla[1], lla[2], flight.heading_deg * DEG, tuple(legs), aoa=flight.aoa_deg * DEG
    )
    try:
        _ = plan.duration
    except InputError as exc:
        raise InputError(str(exc.args[0]), key=_leg_key(exc.key)) from None
    return plan


_LEG_FIELDS = {
    "duration": "duration_s",
    "speed": "speed_mps",
    "climb_rate": "climb_rate_mps",
    "bank": "bank_deg",
    "angle": "angle_deg",
    "turn_rate": "turn_rate_dps",
}


def _leg_key(key):
    """``legs.2.bank`` (flight-plan key) -> ``flight.legs[2].bank_deg`` (scenario key)."""
    parts = (key or "").split(".")
    if len(parts) == 3 and parts[0] == "legs":
        return f"flight.legs[{parts[1]}].{_LEG_FIELDS.get(parts[2], parts[2])}"
    return f"flight.{key}"


def _ephemeris(c, duration):
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


def _simulated(scenario, seed, progress=None):
    fs, gs = scenario.flight, scenario.gnss
    plan = flight_plan(fs)
    _check_imu(fs.imu)
    dt = 1.0 / fs.imu.sample_rate_hz
    errors = fs.imu.to_si()
    dither = fl.Dither(fs.dither.amplitude_arcsec * ARCSEC, fs.dither.frequency_hz)
    base = fl.flight_trajectory(plan)
    truth = fl.Dithered(base, dither)
    window = scenario.filter.dither_window
    window = fl.dither_window(dither, dt) if window == "auto" else window
    config = _checked(lambda: filter_config(scenario.filter, dt, gs.lever_arm_m, window), "gnss")
    eph, week, sow0 = _ephemeris(gs.constellation, plan.duration)
    rx = sources.Receiver(
        gs.lever_arm_m,
        gs.mask_deg * DEG,
        gs.pseudorange_sigma_m,
        gs.range_rate_sigma_mps,
        gs.clock_h0_s,
        gs.clock_hm2_per_s,
        gs.clock_bias_m,
        gs.clock_drift_mps,
        gs.latency_s,
        scenario.filter.pseudorange_sigma_m,
        scenario.filter.range_rate_sigma_mps,
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
    result = _checked(lambda: run_filter(config, initial, 0.0, stream, errors), "gnss.mask_deg")
    info = {"errors": errors, "forward": np.array([1.0, 0.0, 0.0]), "track": None}
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
        return read_psins_tc(data.file)
    return read_flight(data.file)


def _recorded(scenario):
    d = scenario.data
    rec = _read(d)
    if rec.imu is None or len(rec.imu.time) < 2:
        raise InputError("the recording has no IMU data", source=str(d.file), key="imu/time")
    imu = rec.imu
    dt = float(np.median(np.diff(imu.time)))
    sources.check_imu_time(imu.time, dt, str(d.file))
    obs = measurements.from_record(rec.gnss)
    t = obs.time - rec.imu_t0_sow
    inside = np.flatnonzero((t > imu.time[0] - 1.0) & (t < imu.time[-1] + 1.0))
    if inside.size == 0:
        raise InputError("no GNSS epoch during the IMU record", source=str(d.file), key="gnss")
    epochs = measurements.attach_satellites(
        obs.take_epochs(inside), ephemeris.from_columns(rec.ephemeris), source=str(d.file)
    )
    t = epochs.obs.time - rec.imu_t0_sow
    mask = d.mask_deg * DEG
    klob = None if rec.iono_alpha is None else (rec.iono_alpha, rec.iono_beta)
    fix = spp.solve(epochs, spp.SppOptions(mask_rad=mask, klobuchar=klob))
    fixed = np.flatnonzero(np.isfinite(fix.pos[:, 0]))
    if fixed.size == 0:
        raise InputError("no SPP fix in the record", source=str(d.file), key="data.mask_deg")
    lla0 = earth.llh_from_ecef(fix.pos[fixed[0]])
    vel_n = np.einsum("ji,nj->ni", earth.mat_en(lla0[0], lla0[1]), fix.vel)
    init = sources.velocity_heading(
        imu.time, imu.dtheta, imu.dv, dt, lla0, d.static_window_s, t, vel_n, d.motion_speed_mps
    )
    window = 1 if scenario.filter.dither_window == "auto" else scenario.filter.dither_window
    config = _checked(lambda: filter_config(scenario.filter, dt, d.lever_arm_m, window), "data")
    f = scenario.filter
    gnss_list, _ = sources.filter_epochs(
        epochs,
        t,
        t + d.latency_s,
        f.pseudorange_sigma_m,
        f.range_rate_sigma_mps,
        mask,
        fix.pos[fixed[0]],
        klob,
    )
    t_start = float(imu.time[0] - dt)
    # the IMU sits the lever arm behind the antenna's first fix
    lever_e = earth.mat_en(lla0[0], lla0[1]) @ init.mat_nb @ np.asarray(d.lever_arm_m, float)
    lla_imu = earth.llh_from_ecef(fix.pos[fixed[0]] - lever_e)
    initial = strapdown.NavState.from_attitude(init.mat_nb, np.zeros(3), lla_imu)
    stream = sources.recorded_epochs(imu.time, imu.dtheta, imu.dv, t_start, gnss_list)
    result = _checked(lambda: run_filter(config, initial, t_start, stream), "data.mask_deg")
    idx = np.clip(np.searchsorted(t, result.time), 0, len(t) - 1)
    info = {
        "errors": None,
        "forward": np.asarray(d.forward_axis_b, float) / np.linalg.norm(d.forward_axis_b),
        "spp_pos": fix.pos[idx],
        "spp_vel_n": vel_n[idx],
        "heading_init": init,
        "lever": np.asarray(d.lever_arm_m, float),
    }
    return result, info


def forward_heading(result, forward):
    """Heading (rad) of the body ``forward`` axis at each epoch, shape (m,)."""
    axis = rotation.mat_from_quat(result.quat_nb) @ forward
    return np.arctan2(axis[:, 1], axis[:, 0])


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
TRUTH_NAMES = ("gyro_bias_z_est_dph", "mg_yz_est_arcsec", "mg_zy_est_arcsec")


def declared_results(scenario):
    """``(results, truth)`` names of every run, for validating checks before it."""
    if scenario.post is not None:
        return run_ekf_post.RESULT_NAMES, ()
    return RESULT_NAMES, TRUTH_NAMES


def estimate(scenario):
    """None: a run streams epoch by epoch (memory flat in flight length) and writes
    epoch-rate series only."""
    return None


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
    if info.get("spp_pos") is not None:
        lla = result.lla
        mat_nb = rotation.mat_from_quat(result.quat_nb)
        lever_n = mat_nb @ info["lever"]  # the antenna, compared with the SPP fix
        r = earth.ecef_from_llh(lla[:, 0], lla[:, 1], lla[:, 2])
        r = r + np.einsum("nij,nj->ni", earth.mat_en(lla[:, 0], lla[:, 1]), lever_n)
        ok = np.isfinite(info["spp_pos"][:, 0])
        dp = np.linalg.norm(r[ok] - info["spp_pos"][ok], axis=1)
        dv = np.linalg.norm(result.vel_n[ok] - info["spp_vel_n"][ok], axis=1)
        out.update(
            spp_pos_diff_max_m=float(dp.max()),
            spp_pos_diff_rms_m=float(np.sqrt(np.mean(dp**2))),
            spp_vel_diff_max_mps=float(dv.max()),
            spp_vel_diff_rms_mps=float(np.sqrt(np.mean(dv**2))),
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
        "nav/time": Series(r.time, "s", "", "1PPS epoch"),
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
        "epochs/update_time": Series(r.update_time, "s", "", "propagation + update wall time"),
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
    if info.get("spp_pos") is not None:
        d["spp/pos_e"] = Series(info["spp_pos"], "m", "e", "SPP antenna position at each epoch")
        d["spp/vel_n"] = Series(info["spp_vel_n"], "m/s", "n", "SPP range-rate velocity")
    d["nav/forward_heading"] = Series(
        forward_heading(r, info["forward"]), "rad", "", "heading of the body forward axis"
    )
    return d


def _report(scenario, r, s, info):
    source = "recording " + scenario.data.file.name if scenario.data else "simulated flight"
    rows = [
        [name, float(r.state[-1, i]), float(r.sigma[-1, i])]
        for i, name in enumerate(r.layout.names)
    ]
    lines = [
        f"{r.model.upper()}-{r.coupling.upper()} ({len(r.layout.names)} states) on the "
        f"{source}: {r.time.size} epochs, {r.flight_time:.1f} s",
        f"realtime factor {s.realtime_factor:.4g} (wall {r.wall_time:.3g} s, first epoch "
        f"includes JIT compilation), update {1e3 * s.update_time_mean_s:.3g} ms mean",
        f"NIS mean {s.nis_mean:.3g}, NEES mean {s.nees_mean:.3g}, rejected "
        f"{s.rejected_measurements}, coasted epochs {s.coasted_epochs}",
    ]
    if info.get("heading_init") is not None:
        h = info["heading_init"]
        axis = h.mat_nb @ info["forward"]
        used = ", ".join(f"{t:g}" for t in h.epochs)
        lines.append(
            f"initial attitude: levelled on {list(scenario.data.static_window_s)} s; heading "
            f"of the forward axis {math.degrees(math.atan2(axis[1], axis[0])):.2f} deg "
            f"(body x {h.heading / DEG:.2f} deg) from the velocity at {used} s"
        )
    lines += ["", "final states (SI)", format_table(rows, ["state", "estimate", "sigma"])]
    return "\n".join(lines)
