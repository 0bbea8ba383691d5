"""``inins run-ekf`` with a ``post:`` section: a recorded drive post-processed loosely coupled.

The run is read -> prepare -> filter -> smooth -> score -> write, each step a call:

1. read: the GNSS solution file, the IMU log and a reference attitude
   (:mod:`inins.io.post_inputs`);
2. prepare (:func:`inins.ekf.post.prepare`): the quality flags kept and their sigmas
   scaled, the IMU-to-GNSS time mapping, the rates resampled to a uniform grid
   (compensated with ``compensation: FILE``), the initial state, the outage windows;
3. filter (:func:`inins.ekf.post.forward`, the loosely coupled run of
   :mod:`inins.ekf.loose`) into temporary memory maps (:func:`inins.io.scratch.memmap_store`);
4. smooth (:func:`inins.ekf.post.smooth`, RTS);
5. score (:mod:`inins.ekf.scoring`): antenna positions of the forward and smoothed
   solutions against the reference epochs (quality flag ``reference_q`` of the file)
   in the outage windows, the attitude against a reference attitude; with a
   ``reference:`` section, against that trajectory too (:mod:`run_ekf_post_reference`);
6. write: results in lab units, datasets and the report (:mod:`run_ekf_post_report`).
"""

import dataclasses
import math

import numpy as np

from inins.calibration.imu_model import compensate
from inins.commands import run_ekf_post_reference, run_ekf_post_report
from inins.commands._compensation import scenario_terms
from inins.core.units import DEG, UG
from inins.ekf import gate, gnss_time, motion_check, post, scoring
from inins.io import imu_units, post_inputs, scratch
from inins.results import CommandResult, Series
from inins.scenario.si.run_ekf_post import loose_config, post_settings

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
    "post_clock_rate_t",
    "post_clock_rate_threshold",
    "post_clock_rate_applied",
    "post_time_offset_ref_s",
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
    "post_gnss_rejected",
    "post_gnss_reinit",
    "post_reference_screened",
    "post_heading_diff_mean_deg",
    "post_heading_diff_std_deg",
    "post_sm_heading_diff_mean_deg",
    "post_sm_heading_diff_std_deg",
    "post_tilt_diff_max_deg",
    "post_filter_wall_s",
    "post_smoother_wall_s",
    "post_start_gps_week",
    "post_start_gps_sow_s",
    "post_motion_heading_course_deg",
    "post_motion_heading_course_max_deg",
    *run_ekf_post_reference.NAMES,
)
"""Results of a ``post:`` run (null where not applicable)."""
SPIKE_Q = -1
"""The quality flag a position spike is given (:func:`read`): neither used nor a reference."""


def read(p):
    """The files of the ``post:`` section ``p``: (GNSS solutions, IMU log, reference Euler
    angles or None, the spikes); the IMU's units and axes checked against the solutions
    (:func:`inins.io.imu_units.check_against_gnss`). The solution times are GPS time
    (:func:`inins.ekf.gnss_time.solution_on_gps_time`). Epochs whose position is a spike
    (:func:`inins.ekf.gate.solution_spikes`, the outlier gate's bound) are left out, and a
    velocity spike's velocity, before anything uses them (a position spike keeps its row
    under the quality flag :data:`SPIKE_Q`, which no scenario selects): the spikes' times
    (s from the file's first epoch) as (position, velocity)."""
    gnss = gnss_time.solution_on_gps_time(post_inputs.read_gnss(p.gnss))
    imu = post_inputs.read_imu(p.imu)
    reference = post_inputs.read_reference_euler(p.gnss)
    limit = gate.bound(p.outlier_gate.probability, p.outlier_gate.sigma_scale)
    pos, vel = gate.solution_spikes(
        gnss.time, gnss.lla, gnss.sigma_ned, gnss.vel_ned, gnss.sigma_vel, limit
    )
    found = (gnss.time[pos] - gnss.time[0], gnss.time[vel & ~pos] - gnss.time[0])
    if vel.any():
        nan = np.where(vel[:, None], np.nan, 1.0)
        gnss = dataclasses.replace(gnss, vel_ned=gnss.vel_ned * nan, sigma_vel=gnss.sigma_vel * nan)
    checked = gnss.select(~pos) if pos.any() else gnss
    imu_units.check_against_gnss(imu, checked, p.imu.axes, **imu_units.post_settings(p))
    if pos.any():  # kept in the record (its time axis and rows), under no quality flag
        gnss = dataclasses.replace(gnss, q=np.where(pos, SPIKE_Q, gnss.q))
    return gnss, imu, reference, found


def compensation(scenario):
    """``(dtheta, dv, dt) -> (dtheta, dv)`` of the scenario's ``compensation: FILE``, or None."""
    terms = scenario_terms(scenario)
    if terms is None:
        return None
    return lambda dtheta, dv, dt: compensate(dtheta, dv, dt, terms)


def filter_and_smooth(prepared, config, smooth):
    """The forward run and (``smooth``) its RTS pass, in temporary memory maps; the
    :class:`~inins.ekf.post.PostRun` copied out of them."""
    with scratch.memmap_store() as store:
        fwd, wall_f = post.forward(prepared, config, store)
        sm, wall_s = post.smooth(fwd, store) if smooth else (None, None)
        return post.solutions(fwd, sm, wall_f, wall_s)


def score(gnss, prepared, done, settings, limit=math.inf):
    """Outage scores against the reference epochs of ``gnss`` (dict ``fwd``/``sm`` ->
    :class:`~inins.ekf.outages.OutageScore`), attitude differences against the
    reference attitude (dict, empty without one), and the times (s) of the reference
    epochs left out: those the outlier gate (bound ``limit``) rejects
    (:func:`inins.ekf.scoring.screen_references`)."""
    sel = gnss.q == settings.reference_q
    ref_time, ref_lla = gnss.time[sel] - gnss.time[0], gnss.lla[sel]
    solutions = {"fwd": done.forward} | ({"sm": done.smoothed} if done.smoothed else {})
    keep = scoring.screen_references(
        done.time,
        done.smoothed or done.forward,
        settings.lever_arm,
        ref_time,
        ref_lla,
        gnss.sigma_ned[sel] ** 2,
        limit,
        done.rejected[:, 0] | done.rejected[:, 1],
    )
    scores = scoring.outage_scores(
        done.time,
        solutions,
        settings.lever_arm,
        ref_time[keep],
        ref_lla[keep],
        prepared.outages,
        prepared.t0,
        (settings.reference_q, str(gnss.path)),
    )
    attitude = {}
    if prepared.reference_attitude is not None:
        attitude = scoring.attitude_differences(
            done.time,
            {k: s.quat for k, s in solutions.items()},
            prepared.gnss_time,
            prepared.reference_attitude,
            prepared.t0 + settings.score_from,
        )
    return scores, attitude, ref_time[~keep]


def run(scenario, seed, *, sink=None, progress=None):
    """Post-process the scenario's drive (module docstring)."""
    p = scenario.post
    ref = run_ekf_post_reference.read(p.reference)  # a bad reference before the long reads
    gnss, imu, reference, found = read(p)
    settings = post_settings(p)
    prepared = post.prepare(gnss, imu, settings, reference, compensation(scenario))
    config = loose_config(p, prepared.dt, settings.lever_arm)
    done = filter_and_smooth(prepared, config, settings.smooth)
    limit = gate.bound(config.outlier_probability, config.outlier_sigma_scale)
    scores, attitude, screened = score(gnss, prepared, done, settings, limit)
    ref_scores = run_ekf_post_reference.score(ref, p.reference, gnss, prepared, done)
    out = _results(prepared, done, scores, attitude) | run_ekf_post_reference.results(ref_scores)
    out["post_reference_screened"] = int(screened.size)
    out["post_gnss_rejected"] += int(found[0].size + found[1].size)
    gated = run_ekf_post_report.Gated(
        limit,
        done.time[done.rejected.any(axis=1)] - prepared.t0,
        done.time[done.reinit] - prepared.t0,
        screened - prepared.t0,
        found[0] - prepared.t0,
        found[1] - prepared.t0,
    )
    warnings = ()
    if p.init == "motion":
        out, warnings = _motion_heading(p, settings, prepared, done, config, out)
    start = gnss_time.absolute_start(float(gnss.time[0]))
    attrs = {"states": config.n, "coupling_mode": p.coupling_mode}
    if start is not None:
        out.update(post_start_gps_week=start.week, post_start_gps_sow_s=start.sow)
        attrs |= {"time_origin_gps_week": start.week, "time_origin_gps_sow": start.sow}
        attrs["time_origin_utc"] = start.utc or ""
    report = run_ekf_post_report.report(
        p, out, scores, prepared.fit, prepared.t0, prepared.outages, start, gated
    )
    report = "\n".join([report, *run_ekf_post_reference.report_lines(p.reference, out)])
    return CommandResult(
        command="run-ekf",
        results=out,
        datasets=_datasets(p, gnss, prepared, done, scores, attitude)
        | run_ekf_post_reference.datasets(ref, p.reference, gnss, ref_scores),
        attrs={"post": attrs},
        report=report,
        warnings=warnings,
    )


def built_in_checks(scenario, results):
    """The run's own verdict (a failed one exits 1 like a scenario check): after an
    alignment from the motion, the forward heading within ``motion_heading_bound_deg``
    of the GNSS course (:mod:`inins.ekf.motion_check`)."""
    p = scenario.post
    if p is None or results.get("post_motion_heading_course_deg") is None:
        return []
    return [f"post_motion_heading_course_deg < {p.motion_heading_bound_deg:g}"]


def _motion_heading(p, settings, prepared, done, config, out):
    """The heading-course check of the first minute of motion: results and a warning
    with the figures when it fails."""
    start = prepared.t0 + settings.static_window[1]
    forward_b = config.c_vb().T @ np.array([1.0, 0.0, 0.0])
    sol = prepared.solution
    hc = motion_check.heading_course(
        done.time, done.forward.quat, forward_b, sol.time, sol.lla, settings.motion_speed, start
    )
    if hc is None:
        return out, ()
    out = out | {
        "post_motion_heading_course_deg": hc.median / DEG,
        "post_motion_heading_course_max_deg": hc.max / DEG,
    }
    if hc.median / DEG < p.motion_heading_bound_deg:
        return out, ()
    a, b = (v - prepared.t0 for v in hc.window)
    return out, (
        f"the alignment from the motion failed: the forward heading is {hc.median / DEG:.1f} "
        f"deg (median; largest {hc.max / DEG:.1f} deg) from the GNSS course over the "
        f"{hc.epochs} epochs faster than {p.motion_speed_mps:g} m/s in {a:.0f}-{b:.0f} s "
        f"from the run start, above the bound motion_heading_bound_deg "
        f"{p.motion_heading_bound_deg:g} deg (a start in motion? wrong imu.axes or "
        "mounting_deg?)",
    )


def _results(prepared, done, scores, attitude):
    """The flat results (lab units) of a run."""
    out = dict.fromkeys(RESULT_NAMES)
    used = ~(done.rejected[:, 0] | done.reinit)  # the fixes the filter took as they came
    nis = done.innovation[used, :3] ** 2 / done.variance[used, :3]
    out.update(
        post_epochs=int(done.time.size),
        post_gnss_used=done.used,
        post_outages=len(prepared.outages),
        post_initial_heading_deg=float(prepared.heading.heading / DEG),
        post_nis_pos_mean=float(np.nanmean(nis)) if np.isfinite(nis).any() else None,
        post_filter_wall_s=done.filter_wall_s,
        post_stationary_epochs=done.stationary,
        post_gnss_rejected=int(np.sum(done.rejected.any(axis=1))),
        post_gnss_reinit=int(np.sum(done.reinit)),
        post_smoother_wall_s=done.smoother_wall_s,
    )
    for key, prefix in (("fwd", ""), ("sm", "sm_")):
        if key in attitude:
            a = attitude[key]
            out[f"post_{prefix}heading_diff_mean_deg"] = a.heading_mean / DEG
            out[f"post_{prefix}heading_diff_std_deg"] = a.heading_std / DEG
    if attitude:
        out["post_tilt_diff_max_deg"] = max(a.tilt_mean_max for a in attitude.values()) / DEG
    final = (done.smoothed or done.forward).sensors[-1]
    for i, axis in enumerate("xyz"):
        out[f"post_accel_bias_{axis}_ug"] = float(final[i] / UG)
        out[f"post_gyro_bias_{axis}_dph"] = float(final[3 + i] / DEG * 3600.0)
    fit = prepared.fit
    if fit is not None:
        out.update(
            post_time_offset_fit_s=fit.offset,
            post_time_offset_fit_sigma_s=run_ekf_post_report.null(fit.offset_sigma),
            post_time_offset_ref_s=fit.t_ref_gnss,
            post_time_fit_residual_rms_s=fit.residual_rms(),
            post_clock_rate_applied=fit.model != "constant",
        )
        test = fit.rate_test
        if test is not None:  # the line's rate, applied or not (the test's figures)
            out.update(
                post_clock_rate_ppm=test.rate * 1e6,
                post_clock_rate_sigma_ppm=run_ekf_post_report.null(test.sigma * 1e6),
                post_clock_rate_t=test.t,
                post_clock_rate_threshold=test.threshold,
            )
    if done.offset is not None:
        out["post_time_offset_state_s"], out["post_time_offset_state_sigma_s"] = done.offset
    for key, prefix in (("fwd", "fwd"), ("sm", "sm")):
        if key in scores:
            s = scores[key]
            out[f"post_{prefix}_drift_hor_rms_m"] = s.rms_horizontal
            out[f"post_{prefix}_drift_3d_rms_m"] = s.rms_3d
            out[f"post_{prefix}_drift_hor_max_m"] = float(s.max_horizontal.max())
    return out


def _solution_series(key, time, s, what):
    """A solution's series, on GNSS time as ``post/time`` says (:mod:`inins.ekf.gnss_time`)."""
    s = gnss_time.on_gnss_time(time, s)
    return {
        f"post/{key}/lla": Series(s.lla, "rad, rad, m", "", f"{what} solution (IMU)"),
        f"post/{key}/vel_n": Series(s.vel, "m/s", "n", f"{what} velocity"),
        f"post/{key}/quat_nb": Series(s.quat, "1", "nb", f"{what} attitude"),
        f"post/{key}/sigma": Series(s.sigma, "SI", "", f"{what} 1-sigma of each state"),
        f"post/{key}/sensors": Series(s.sensors, "m/s^2, rad/s", "b", f"{what} sensor estimates"),
    }


def _datasets(p, gnss, prepared, done, scores, attitude):
    """The HDF5 datasets of a run."""
    t0, wins = prepared.t0, prepared.outages
    ref_sel = gnss.q == p.reference_q
    d = {
        "post/time": Series(
            done.time,
            "s",
            "",
            "GNSS time from the solution file's first epoch (attributes of post: its GPS "
            "week, seconds of week and UTC); every solution is at these times",
        )
    }
    d |= _solution_series("forward", done.time, done.forward, "forward")
    d["post/innovation"] = Series(
        done.innovation, "m, m/s", "n", "pos N E D, vel N E D innovations"
    )
    d["post/innovation_variance"] = Series(done.variance, "m^2, m^2/s^2", "n", "their variances")
    if done.smoothed is not None:
        d |= _solution_series("smoothed", done.time, done.smoothed, "smoothed")
    d["post/reference/time"] = Series(
        gnss.time[ref_sel] - gnss.time[0], "s", "", f"reference epochs (Q={p.reference_q})"
    )
    d["post/reference/lla"] = Series(
        gnss.lla[ref_sel], "rad, rad, m", "", "reference antenna positions"
    )
    d["post/lever_arm"] = Series(np.asarray(p.lever_arm_m, float), "m", "b", "antenna minus IMU")
    for key, s in (("forward", done.forward), ("smoothed", done.smoothed)):
        if s is not None and s.offset is not None:
            d[f"post/{key}/time_offset"] = Series(s.offset, "s", "", "offset state")
    d["post/outage_windows"] = Series(
        np.asarray(wins, float).reshape(-1, 2), "s", "", "outage windows [start, end)"
    )
    for name, a in attitude.items():
        key = {"fwd": "forward", "sm": "smoothed"}[name]
        d[f"post/{key}/attitude_time"] = Series(a.time, "s", "", "epochs scored on attitude")
        d[f"post/{key}/attitude_minus_reference"] = Series(
            a.euler, "rad", "", "roll, pitch, heading minus the reference attitude"
        )
    for key, sc in scores.items():
        d[f"post/outages/{key}/window"] = Series(sc.window - t0, "s", "", "from run start")
        d[f"post/outages/{key}/max_horizontal"] = Series(sc.max_horizontal, "m", "", "")
        d[f"post/outages/{key}/max_3d"] = Series(sc.max_3d, "m", "", "")
    return d
