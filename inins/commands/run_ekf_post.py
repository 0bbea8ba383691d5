"""``inins run-ekf`` with a ``post:`` section: a recorded drive post-processed loosely coupled.

1. Read the GNSS solution file (:mod:`inins.io.solution_files`), keep the quality
   flags asked for, scale their sigmas; read the IMU log of rates.
2. Time mapping (:mod:`inins.ekf.timeoffset`): the IMU yaw rate against the GNSS
   course rate in windows, a line ``t_gnss = t_imu + a + b (t_imu - t_ref)``; the
   filter's ``dt_g`` state the residual constant offset.
3. Resample the rates to a uniform grid on the GNSS axis (linear interpolation of
   the rates at each interval's midpoint, times the interval).
4. Level on the static window, heading from the first motion
   (:func:`inins.ekf.sources.velocity_heading`).
5. The loosely coupled forward run (:func:`inins.ekf.loose.run_loose`) with the
   outage windows coasted, its store in temporary memory maps
   (:func:`inins.io.scratch.memmap_store`); RTS smoothing (:mod:`inins.ekf.smoother`).
6. The outage protocol (:mod:`inins.ekf.outages`): antenna positions of the forward
   and smoothed solutions against the reference epochs (quality flag
   ``reference_q`` of the file, by default the RTK-fixed ones).
"""

import math
import time as _time
from dataclasses import dataclass

import numpy as np

from inins.calibration.imu_model import compensate
from inins.commands import run_ekf_post_report
from inins.commands._compensation import scenario_terms
from inins.core import earth, error_model, rotation, strapdown
from inins.core.units import DEG, UG
from inins.ekf import outages, smoother, sources, timeoffset
from inins.ekf.tight_store import TightStore
from inins.exceptions import InputError
from inins.io import imu_units, scratch, solution_layout
from inins.io import solution_files as sf
from inins.results import CommandResult, Series
from inins.scenario.si.run_ekf_post import loose_config

RESULT_NAMES = (
    "post_epochs",
    "post_gnss_used",
    "post_outages",
    "post_fwd_drift_hor_rms_m",
    "post_fwd_drift_3d_rms_m",
    "post_sm_drift_hor_rms_m",
    "post_sm_drift_3d_rms_m",
    "post_fwd_drift_hor_max_m",
    "post_sm_drift_hor_max_m",
    "post_time_offset_fit_s",
    "post_time_offset_fit_sigma_s",
    "post_time_fit_residual_rms_s",
    "post_clock_rate_ppm",
    "post_clock_rate_sigma_ppm",
    "post_time_offset_state_s",
    "post_time_offset_state_sigma_s",
    "post_initial_heading_deg",
    "post_nis_pos_mean",
    "post_accel_bias_x_ug",
    "post_accel_bias_y_ug",
    "post_accel_bias_z_ug",
    "post_gyro_bias_x_dph",
    "post_gyro_bias_y_dph",
    "post_gyro_bias_z_dph",
    "post_stationary_epochs",
    "post_heading_diff_mean_deg",
    "post_heading_diff_std_deg",
    "post_sm_heading_diff_mean_deg",
    "post_sm_heading_diff_std_deg",
    "post_tilt_diff_max_deg",
    "post_filter_wall_s",
    "post_smoother_wall_s",
)
"""Results of a ``post:`` run (null where not applicable)."""


def read_post_gnss(g):
    """The :class:`~inins.io.solution_files.SolutionFile` of a ``post.gnss`` section."""
    if g.format == "rtklib":
        sol = sf.read_rtklib_pos(g.file)
    elif g.format == "recorded":
        sol = solution_layout.read_recorded_solution(g.file)
    elif g.format == "mat":
        cols = {k: int(v) for k, v in g.columns.items()}
        sol = sf.read_solution_mat(
            g.file, g.mat_variable, cols, g.angle_unit, g.sigma_m, g.sigma_vel_mps
        )
    else:
        sol = sf.read_solution_csv(g.file, g.columns, g.angle_unit, g.time_scale_s)
    return sol


def read_post_imu(i):
    """The :class:`~inins.io.solution_files.ImuRates` of a ``post.imu`` section."""
    if i.format == "recorded":
        return solution_layout.read_recorded_imu(i.file)
    elif i.format == "mat":
        return sf.read_imu_increments_mat(
            i.file,
            i.mat_variable,
            i.gyro_columns,
            i.accel_columns,
            i.time_column,
            i.axes,
        )
    else:
        return sf.read_imu_rates_csv(
            i.file,
            i.accel_columns,
            i.gyro_columns,
            i.time_column,
            i.time_scale_s,
            i.accel_unit,
            i.gyro_unit,
            i.axes,
            i.odometer_column,
            i.odometer_scale_mps,
        )


def _reference_attitude(g):
    """Reference ``mat_nb`` (m, 3, 3) of a .mat solution with attitude columns, or None."""
    if g.format != "mat" or g.attitude_columns is None:
        return None
    c = g.attitude_columns
    a = sf.read_mat_columns(
        g.file, g.mat_variable, [c["roll"], c["pitch"], c["yaw"]], "post.gnss.attitude_columns"
    )
    k = DEG if g.angle_unit == "deg" else 1.0
    return rotation.mat_from_euler(a[:, 0] * k, a[:, 1] * k, g.yaw_sign * a[:, 2] * k)


def _uniform(tig, rates, dt, t0, t1):
    """Increments (n, 3) on ``[t0 + k dt, t0 + (k + 1) dt]`` from rates at times ``tig``."""
    grid = np.arange(t0, t1 - 0.5 * dt, dt)
    mid = grid + 0.5 * dt
    return np.stack([np.interp(mid, tig, rates[:, i]) for i in range(3)], -1) * dt, grid


def run(scenario, seed, *, sink=None, progress=None):
    """Post-process the scenario's drive (module docstring)."""
    from inins.ekf import loose  # the loose filter: only this path (lazily)

    p = scenario.post
    g = p.gnss
    full = read_post_gnss(g)
    keep = np.isin(full.q, g.q_flags)
    if not keep.any():
        raise InputError(
            f"no epoch with a quality flag in {g.q_flags}",
            source=str(g.file),
            key="post.gnss.q_flags",
        )
    sol = full.select(keep)
    scale = np.array([g.sigma_scale.get(int(q), 1.0) for q in sol.q])
    imu = read_post_imu(p.imu)
    imu_units.check_against_gnss(imu, full, p.imu.axes, **imu_units.post_settings(p))
    ref_att = _reference_attitude(g)
    if ref_att is not None:
        ref_att = ref_att[keep]
    if p.aiding.odometer_sigma_mps > 0 and imu.odometer is None:
        raise InputError(
            "odometer aiding needs imu.odometer_column", key="post.aiding.odometer_sigma_mps"
        )
    t_g0 = float(full.time[0])
    tg = sol.time - t_g0
    ti = imu.time - imu.time[0]
    # 2. time mapping
    fit = None
    # velocities from the positions (central differences): the course, and the
    # initial heading where the file has no velocities
    ecef = earth.ecef_from_llh(sol.lla[:, 0], sol.lla[:, 1], sol.lla[:, 2])
    m_en = earth.mat_en(sol.lla[0, 0], sol.lla[0, 1])
    vel = np.gradient((ecef - ecef[0]) @ m_en, tg, axis=0)
    vel_init = np.where(np.isfinite(sol.vel_ned), sol.vel_ned, vel)
    if p.time.fit == "turn_rate":
        course = timeoffset.course_rate(tg, vel, min_speed=p.motion_speed_mps)
        start = p.static_window_s[1]
        w = p.time.window_s
        windows = [(a, a + w) for a in np.arange(start, tg[-1] - w + 1e-9, w)]
        if not windows:
            raise InputError(
                "the drive is shorter than one time-fit window", key="post.time.window_s"
            )
        fit = timeoffset.fit_clock(
            ti,
            imu.gyro[:, 2],
            tg,
            course,
            windows,
            search=(-p.time.search_s, p.time.search_s),
            piecewise=p.time.model == "piecewise",
        )
        tig = fit.to_gnss(ti)
    else:
        tig = ti + p.time.offset_s
    # 3. uniform grid where IMU and GNSS overlap
    dt = 1.0 / p.imu.rate_hz
    t0 = max(math.ceil(tig[0] / dt) * dt, float(tg[0]))
    t1 = min(float(tig[-1]), float(tg[-1]))
    if not t1 > t0 + 10.0:
        raise InputError(
            f"IMU ({tig[0]:.1f}..{tig[-1]:.1f} s) and GNSS ({tg[0]:.1f}..{tg[-1]:.1f} s) "
            "overlap by less than 10 s (GNSS time from its first epoch)",
            source=str(p.imu.file),
            key="post.time",
        )
    dth, grid = _uniform(tig, imu.gyro, dt, t0, t1)
    dvv, _ = _uniform(tig, imu.accel, dt, t0, t1)
    terms = scenario_terms(scenario)
    if terms is not None:
        dth, dvv = compensate(dth, dvv, dt, terms)
    # 4. initial attitude
    first = int(np.searchsorted(tg, t0))
    lla0 = sol.lla[min(first, len(tg) - 1)]
    sw = (t0 + p.static_window_s[0], t0 + p.static_window_s[1])
    if p.init == "reference":
        if ref_att is None:
            raise InputError("init: reference needs gnss.attitude_columns", key="post.init")
        j = min(first, len(tg) - 1)
        eul = rotation.euler_from_mat(ref_att[j]) + np.array([0, 0, p.init_heading_error_deg * DEG])
        mat0 = rotation.mat_from_euler(*eul)
        vel0 = vel_init[j]
        lla0 = error_model.lla_offset(sol.lla[j], -vel0 * (tg[j] - t0))
        init = sources.HeadingInit(mat0, float(eul[2]), 0.0, tg[j : j + 1])
    else:
        vel0 = np.zeros(3)
        try:
            init = sources.velocity_heading(
                grid + dt, dth, dvv, dt, lla0, sw, tg, vel_init, p.motion_speed_mps
            )
        except InputError as exc:  # its keys are the tight scenario's
            key = str(exc.key or "").replace("data.", "post.")
            raise InputError(exc.message, source=str(g.file), key=key) from None
    lever = np.asarray(p.lever_arm_m, float)
    lla_imu = error_model.lla_offset(lla0, -(init.mat_nb @ lever))
    nav0 = strapdown.NavState.from_attitude(init.mat_nb, vel0, lla_imu)
    # 5. outages and the run
    o = p.outages
    t_end = float(grid[-1] + dt)
    wins = []
    if o.every_s is not None:
        first_s = None if o.first_s is None else t0 + o.first_s
        wins += outages.periodic_windows(
            t0, t_end, o.every_s, o.length_s, first_s, key="post.outages"
        )
    if o.windows:
        wins += outages.check_windows(
            [(t0 + a, t0 + b) for a, b in o.windows], t0, t_end, key="post.outages.windows"
        )
    wins = sorted(wins)
    cfg = loose_config(p, dt, lever)
    stat_w = p.aiding.stationary_windows_s
    stat_w = None if stat_w is None else [(t0 + a, t0 + b) for a, b in stat_w]
    use_vel = g.use_velocity
    inside = (tg >= t0 - 1e-9) & (tg <= t_end + 1e-9)  # epochs the IMU covers
    solution = loose.GnssSolution(
        tg[inside],
        sol.lla[inside],
        (sol.sigma_ned * scale[:, None])[inside],
        sol.vel_ned[inside] if use_vel else None,
        (sol.sigma_vel * scale[:, None])[inside] if use_vel else None,
    )
    with scratch.memmap_store() as store:
        tick = _time.perf_counter()
        fwd = loose.run_loose(
            cfg,
            nav0,
            t0,
            lambda a, b: (dth[a:b], dvv[a:b]),
            solution,
            outages=wins,
            store=store,
            stationary_windows=stat_w,
            odometer=None if imu.odometer is None else (tig, imu.odometer),
        )
        n_stat = int(np.sum(fwd.stationary))
        wall_f = _time.perf_counter() - tick
        tick = _time.perf_counter()
        sm = smoother.smooth(fwd, store) if p.smoother == "rts" else None
        wall_s = _time.perf_counter() - tick if sm is not None else None
        quat, vel_f, lla_f, sens, sig = (np.array(a) for a in fwd.output())
        time = np.array(fwd.time)
        x_last, P_last = np.array(fwd.x[-1]), np.array(fwd.P[-1])
        innov, var = np.array(fwd.innovation), np.array(fwd.variance)
        # the residual offset state: compare at the instant a tag was taken
        off_f = np.array(fwd.x[:, -1]) if p.time.state else None
        off_s = None
        if sm is not None:
            sq, sv, sl = np.array(sm.quat), np.array(sm.vel), np.array(sm.lla)
            ssens, ssig = np.array(sm.sensors), np.array(sm.sigma)
            s0_td = float(sm.s[0, -1]) if p.time.state else None
            s0_td_sig = float(sm.sigma[0, -1]) if p.time.state else None
            off_s = np.array(sm.s[:, -1]) if p.time.state else None
    # 6. scoring against the reference epochs
    ref_sel = full.q == p.reference_q
    rt = full.time[ref_sel] - t_g0
    idx = np.searchsorted(rt, time)
    idx = np.minimum(idx, max(rt.size - 1, 0))
    hit = (rt.size > 0) & (np.abs(rt[idx] - time) < 1e-6) if rt.size else np.zeros(time.size, bool)
    scores = {}
    if wins:
        for a, b in wins:
            if not np.any(hit & (time >= a) & (time < b)):
                raise InputError(
                    f"the reference (quality {p.reference_q}) has no epoch in the outage "
                    f"[{a - t0:g}, {b - t0:g}) s: it does not cover the run",
                    source=str(g.file),
                    key="post.reference_q",
                )
        ref = full.lla[ref_sel][idx[hit]]
        mats = rotation.mat_from_quat(quat)
        scores["fwd"] = outages.score(
            time[hit],
            loose.antenna_positions(quat, lla_f, lever, vel_f, off_f)[hit],
            None,
            ref,
            None,
            wins,
        )
        if sm is not None:
            scores["sm"] = outages.score(
                time[hit],
                loose.antenna_positions(sq, sl, lever, sv, off_s)[hit],
                None,
                ref,
                None,
                wins,
            )
        del mats
    td = cfg.n_base if p.time.state else None
    out = dict.fromkeys(RESULT_NAMES)
    nis = innov[:, :3] ** 2 / var[:, :3]
    out.update(
        post_epochs=int(time.size),
        post_gnss_used=int(np.sum(fwd.used)),
        post_outages=len(wins),
        post_initial_heading_deg=float(init.heading / DEG),
        post_nis_pos_mean=float(np.nanmean(nis)) if np.isfinite(nis).any() else None,
        post_filter_wall_s=wall_f,
        post_stationary_epochs=n_stat,
        post_smoother_wall_s=wall_s,
    )
    if ref_att is not None:
        _attitude_scores(out, time, quat, sq if sm is not None else None, tg, ref_att, t0, p)
    final = ssens[-1] if sm is not None else sens[-1]
    for i, axis in enumerate("xyz"):
        out[f"post_accel_bias_{axis}_ug"] = float(final[i] / UG)
        out[f"post_gyro_bias_{axis}_dph"] = float(final[3 + i] / DEG * 3600.0)
    if fit is not None:
        out.update(
            post_time_offset_fit_s=fit.offset,
            post_time_offset_fit_sigma_s=run_ekf_post_report.null(fit.offset_sigma),
            post_clock_rate_ppm=fit.rate * 1e6,
            post_time_fit_residual_rms_s=float(
                np.sqrt(
                    np.mean((fit.to_gnss(fit.lags[:, 0] - fit.lags[:, 1]) - fit.lags[:, 0]) ** 2)
                )
            ),
            post_clock_rate_sigma_ppm=run_ekf_post_report.null(fit.rate_sigma * 1e6),
        )
    if td is not None:
        est, sd = float(x_last[td]), float(math.sqrt(P_last[td, td]))
        if sm is not None:
            est, sd = s0_td, s0_td_sig
        out.update(post_time_offset_state_s=est, post_time_offset_state_sigma_s=sd)
    if "fwd" in scores:
        f = scores["fwd"]
        out.update(
            post_fwd_drift_hor_rms_m=f.rms_horizontal,
            post_fwd_drift_3d_rms_m=f.rms_3d,
            post_fwd_drift_hor_max_m=float(f.max_horizontal.max()),
        )
    if "sm" in scores:
        s = scores["sm"]
        out.update(
            post_sm_drift_hor_rms_m=s.rms_horizontal,
            post_sm_drift_3d_rms_m=s.rms_3d,
            post_sm_drift_hor_max_m=float(s.max_horizontal.max()),
        )
    datasets = {
        "post/time": Series(time, "s", "", "filter epoch, GNSS time from the file's first epoch"),
        "post/forward/lla": Series(lla_f, "rad, rad, m", "", "forward solution (IMU)"),
        "post/forward/vel_n": Series(vel_f, "m/s", "n", "forward velocity"),
        "post/forward/quat_nb": Series(quat, "1", "nb", "forward attitude"),
        "post/forward/sigma": Series(sig, "SI", "", "forward 1-sigma of each state"),
        "post/forward/sensors": Series(sens, "m/s^2, rad/s", "b", "forward sensor estimates"),
        "post/innovation": Series(innov, "m, m/s", "n", "pos N E D, vel N E D innovations"),
        "post/innovation_variance": Series(var, "m^2, m^2/s^2", "n", "their variances"),
    }
    if sm is not None:
        datasets |= {
            "post/smoothed/lla": Series(sl, "rad, rad, m", "", "smoothed solution (IMU)"),
            "post/smoothed/vel_n": Series(sv, "m/s", "n", "smoothed velocity"),
            "post/smoothed/quat_nb": Series(sq, "1", "nb", "smoothed attitude"),
            "post/smoothed/sigma": Series(ssig, "SI", "", "smoothed 1-sigma of each state"),
            "post/smoothed/sensors": Series(ssens, "m/s^2, rad/s", "b", "smoothed sensors"),
        }
    datasets["post/reference/time"] = Series(rt, "s", "", f"reference epochs (Q={p.reference_q})")
    datasets["post/reference/lla"] = Series(
        full.lla[ref_sel], "rad, rad, m", "", "reference antenna positions"
    )
    datasets["post/lever_arm"] = Series(lever, "m", "b", "antenna minus IMU")
    if off_f is not None:
        datasets["post/forward/time_offset"] = Series(off_f, "s", "", "offset state")
        if off_s is not None:
            datasets["post/smoothed/time_offset"] = Series(off_s, "s", "", "offset state")
    datasets["post/outage_windows"] = Series(
        np.asarray(wins, float).reshape(-1, 2), "s", "", "outage windows [start, end)"
    )
    for key, sc in scores.items():
        datasets[f"post/outages/{key}/window"] = Series(sc.window - t0, "s", "", "from run start")
        datasets[f"post/outages/{key}/max_horizontal"] = Series(sc.max_horizontal, "m", "", "")
        datasets[f"post/outages/{key}/max_3d"] = Series(sc.max_3d, "m", "", "")
    report = run_ekf_post_report.report(p, out, scores, fit, t0, wins)
    return CommandResult(
        command="run-ekf",
        results=out,
        datasets=datasets,
        attrs={"post": {"states": cfg.n, "coupling_mode": p.coupling_mode}},
        report=report,
    )


def _attitude_scores(out, time, quat, squat, tg, ref_att, t0, p):
    """Attitude minus the reference at the solution epochs from score_from_s on."""
    idx = np.clip(np.searchsorted(tg, time), 0, tg.size - 1)
    ok = (np.abs(tg[idx] - time) < 1e-6) & (time >= t0 + p.score_from_s)
    if not ok.any():
        raise InputError("no reference attitude epoch to score", key="post.score_from_s")
    ref = np.array([rotation.euler_from_mat(m) for m in ref_att[idx[ok]]])
    tilt = []
    for key, q in (("", quat), ("sm_", squat)):
        if q is None:
            continue
        e = np.array([rotation.euler_from_mat(m) for m in rotation.mat_from_quat(q[ok])]) - ref
        e = np.degrees((e + math.pi) % (2 * math.pi) - math.pi)
        out[f"post_{key}heading_diff_mean_deg"] = float(e[:, 2].mean())
        out[f"post_{key}heading_diff_std_deg"] = float(e[:, 2].std())
        tilt.append(float(np.abs(e[:, :2].mean(0)).max()))
    out["post_tilt_diff_max_deg"] = max(tilt)


# --------------------------------------------------------------------------- tight smoothing

TIGHT_SMOOTH_NAMES = (
    "smoothed_hor_sigma_median_m",
    "forward_hor_sigma_median_m",
    "smoothed_heading_sigma_start_deg",
    "smoothed_forward_hor_diff_max_m",
    "smoothed_pos_err_rms_m",
)
"""Results of ``filter.smoother: rts`` in the tight mode (null without it)."""


TIGHT_OUTAGE_NAMES = (
    "outages_scored",
    "outage_fwd_drift_hor_rms_m",
    "outage_fwd_drift_3d_rms_m",
    "outage_fwd_heading_end_rms_deg",
    "outage_sm_drift_hor_rms_m",
    "outage_sm_drift_3d_rms_m",
    "outage_sm_heading_end_rms_deg",
)
"""Outage scores of a tight run against truth (``filter.outages_s`` on a simulated flight;
``sm``: with ``filter.smoother: rts``; null otherwise)."""


def tight_outages(result, sm, windows):
    """Outage protocol of a tight run (:func:`inins.ekf.outages.score`): per window of
    ``filter.outages_s`` (the filter coasts there: no GNSS measurement is used) the
    maximum horizontal and 3D drift against truth and the heading error at its last
    epoch; the RMS of those over the windows, forward and (``sm`` given) smoothed.

    Truth is the forward output minus its recorded error (position ``nav_error[:, 0:3]``,
    heading ``heading_error``); the smoothed heading error is the smoothed minus the
    forward heading plus the forward error. Returns ``(results, report)``; nulls and no
    text without truth or windows."""
    out = dict.fromkeys(TIGHT_OUTAGE_NAMES)
    if not windows or result.nav_error.shape[0] != result.time.size or result.time.size == 0:
        return out, ""
    true_lla = error_model.lla_offset(result.lla, -result.nav_error[:, 0:3])
    fwd_yaw = rotation.euler_from_mat(rotation.mat_from_quat(result.quat_nb))[:, 2]
    true_yaw = fwd_yaw - result.heading_error

    def yaw_mat(yaw):
        zero = np.zeros_like(yaw)
        return rotation.mat_from_euler(zero, zero, yaw)

    ref = yaw_mat(true_yaw)
    fwd = outages.score(result.time, result.lla, yaw_mat(fwd_yaw), true_lla, ref, windows)
    out.update(
        outages_scored=int(fwd.window.shape[0]),
        outage_fwd_drift_hor_rms_m=fwd.rms_horizontal,
        outage_fwd_drift_3d_rms_m=fwd.rms_3d,
        outage_fwd_heading_end_rms_deg=fwd.rms_heading / DEG,
    )
    lines = [f"\n\nOutages ({fwd.window.shape[0]}, no GNSS measurement used), against truth:"]
    lines.append(
        "  window (s)        fwd hor / 3D max (m)  heading end (deg)"
        + ("   sm hor / 3D max (m)  heading end (deg)" if sm is not None else "")
    )
    smd = None
    if sm is not None:
        sm_yaw = rotation.euler_from_mat(rotation.mat_from_quat(sm.quat))[:, 2]
        smd = outages.score(result.time, sm.lla, yaw_mat(sm_yaw), true_lla, ref, windows)
        out.update(
            outage_sm_drift_hor_rms_m=smd.rms_horizontal,
            outage_sm_drift_3d_rms_m=smd.rms_3d,
            outage_sm_heading_end_rms_deg=smd.rms_heading / DEG,
        )
    for k, (a, b) in enumerate(fwd.window):
        row = (
            f"  [{a:7.1f}, {b:7.1f})  {fwd.max_horizontal[k]:9.3f} / {fwd.max_3d[k]:9.3f}"
            f"  {fwd.heading_end[k] / DEG:17.4f}"
        )
        if smd is not None:
            row += (
                f"   {smd.max_horizontal[k]:9.3f} / {smd.max_3d[k]:9.3f}"
                f"  {smd.heading_end[k] / DEG:17.4f}"
            )
        lines.append(row)
    rms = f"  RMS of the maxima: forward {fwd.rms_horizontal:.3f} m horizontal"
    if smd is not None:
        rms += f", smoothed {smd.rms_horizontal:.3f} m"
    lines.append(rms)
    return out, "\n".join(lines)


@dataclass(frozen=True)
class TightSmoothed:
    """What the smoother adds to a tight run's results, datasets and report."""

    results: dict
    datasets: dict
    report: str


def tight_store(filter_settings):
    """A :class:`inins.ekf.tight_store.TightStore` when the scenario smooths, else None."""
    return TightStore() if filter_settings.smoother == "rts" else None


def tight_smoothed(result, store, windows=()):
    """Smooth a tight run recorded in ``store`` (None: nulls); score the outage
    ``windows`` (s) against truth, forward and smoothed (:func:`tight_outages`)."""
    out = dict.fromkeys(TIGHT_SMOOTH_NAMES)
    if store is None:
        scores, text = tight_outages(result, None, windows)
        return TightSmoothed(out | scores, {}, text)
    sm = smoother.smooth(store.run())
    scores, text = tight_outages(result, sm, windows)
    fwd_h = np.hypot(result.sigma[:, 0], result.sigma[:, 1])
    sm_h = np.hypot(sm.sigma[:, 0], sm.sigma[:, 1])
    diff = error_model.position_error_ned(result.lla, sm.lla)
    out.update(
        smoothed_hor_sigma_median_m=float(np.median(sm_h)),
        forward_hor_sigma_median_m=float(np.median(fwd_h)),
        smoothed_heading_sigma_start_deg=float(sm.sigma[0, 8] / DEG),
        smoothed_forward_hor_diff_max_m=float(np.hypot(diff[:, 0], diff[:, 1]).max()),
    )
    if result.nav_error.shape[0]:
        # truth position = forward output minus its error
        true = error_model.lla_offset(result.lla, -result.nav_error[:, 0:3])
        err = error_model.position_error_ned(sm.lla, true)
        out["smoothed_pos_err_rms_m"] = float(np.sqrt(np.mean(np.sum(err**2, axis=1))))
    datasets = {
        "smoothed/lla": Series(sm.lla, "rad, rad, m", "", "RTS-smoothed position (IMU)"),
        "smoothed/vel_n": Series(sm.vel, "m/s", "n", "smoothed velocity"),
        "smoothed/quat_nb": Series(sm.quat, "1", "nb", "smoothed attitude"),
        "smoothed/sigma": Series(sm.sigma, "SI", "", "smoothed 1-sigma of each state"),
    }
    report = (
        f"\n\nRTS smoothing: median horizontal 1-sigma {out['forward_hor_sigma_median_m']:.3g} m "
        f"forward, {out['smoothed_hor_sigma_median_m']:.3g} m smoothed; heading 1-sigma at the "
        f"start {out['smoothed_heading_sigma_start_deg']:.3g} deg smoothed; largest horizontal "
        f"forward-smoothed difference {out['smoothed_forward_hor_diff_max_m']:.3g} m"
        + (
            ""
            if out["smoothed_pos_err_rms_m"] is None
            else f"; smoothed position error RMS {out['smoothed_pos_err_rms_m']:.3g} m"
        )
    )
    return TightSmoothed(out | scores, datasets, report + text)
