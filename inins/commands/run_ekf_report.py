"""The engineer's view of a run-ekf result: every state in SI and in its lab unit (m,
m/s, deg, ug, deg/h, arcsec), beside the truth and the error in sigmas where the
truth is known (a simulated flight), and "n/a (recording without truth)" where it
is not; never a bare "nan".

:func:`state_truth` gives the true value of each sensor state from the simulated
sensor errors (the estimate of a bias or misalignment state is the sensor's total in
both couplings: FB folds its corrections back into the state, see
``states/estimate``); the figures draw it as the zero or non-zero truth line.
"""

import math
from dataclasses import dataclass

import numpy as np

from inins.core.units import ARCSEC, DEG, DPH, UG
from inins.ekf import scoring
from inins.results import Series, format_table

NO_TRUTH = "n/a (recording without truth)"
_UNITS = (  # state-name prefix -> (lab unit, SI per lab unit)
    ("dr_", "m", 1.0),
    ("dv_", "m/s", 1.0),
    ("phi_", "deg", DEG),
    ("ba_", "ug", UG),
    ("bg_", "deg/h", DPH),
    ("ma_", "arcsec", ARCSEC),
    ("mg_", "arcsec", ARCSEC),
    ("clock_bias", "m", 1.0),
    ("clock_drift", "m/s", 1.0),
    ("isb_", "m", 1.0),
)
_GYRO_MIS = ("mg_xy", "mg_xz", "mg_yx", "mg_yz", "mg_zx", "mg_zy")
_ACCEL_MIS = ("ma_yx", "ma_zx", "ma_zy")


def lab_unit(name):
    """``(unit, SI per unit)`` of a state, e.g. ``bg_z`` -> ``("deg/h", 4.85e-6)``."""
    for prefix, unit, scale in _UNITS:
        if name.startswith(prefix):
            return unit, scale
    return "SI", 1.0


def state_truth(errors, names, system_bias=None):
    """``{state: true value (SI)}`` of the sensor states of a simulated flight (biases,
    misalignments) and of its inter-system bias states (``system_bias``: ``{name: m}``),
    empty without truth (``errors`` None, a recording)."""
    if errors is None:
        return {}
    truth = dict(system_bias or {})
    for i, axis in enumerate("xyz"):
        truth[f"bg_{axis}"] = float(errors.gyro_bias[i])
        truth[f"ba_{axis}"] = float(errors.accel_bias[i])
    truth.update(zip(_GYRO_MIS, map(float, errors.gyro_misalignment), strict=True))
    truth.update(zip(_ACCEL_MIS, map(float, errors.accel_misalignment), strict=True))
    return {name: value for name, value in truth.items() if name in names}


def number(value, fmt=".4g", missing=NO_TRUTH):
    """``value`` formatted, or ``missing`` for None / NaN (never "nan")."""
    if value is None or not np.isfinite(value):
        return missing
    return format(float(value), fmt)


def final_states(names, estimate, sigma, truth):
    """Report lines: the final states in SI and lab units, with truth and error/sigma
    (a truth column only where some truth is known)."""
    has_truth = bool(truth)
    rows = []
    for name, est, sig in zip(names, estimate, sigma, strict=True):
        unit, scale = lab_unit(name)
        row = [name, f"{est:.6g}", f"{sig:.3g}", f"{est / scale:.5g}", f"{sig / scale:.3g}", unit]
        if has_truth:
            true = truth.get(name)
            if true is None:
                row += ["-", "-"]
            else:
                row += [f"{true / scale:.5g}", f"{(est - true) / sig:+.2f}" if sig > 0 else "-"]
        rows.append(row)
    header = ["state", "estimate SI", "sigma SI", "estimate", "sigma", "unit"]
    if has_truth:
        header += ["truth", "(est-truth)/sigma"]
    lines = ["", "final states: SI and lab units", format_table(rows, header)]
    if has_truth:
        lines.append(
            "truth: the simulated sensor errors; '-' where the state has no single true "
            "value (navigation errors, clock)"
        )
    else:
        lines.append(f"truth: {NO_TRUTH}")
    return lines


def truth_table(results, truth):
    """Report lines: each result that has a truth, estimated vs true, error."""
    if not truth:
        return []
    rows = []
    for name, true in truth.items():
        value = results.get(name)
        err = None if value is None or true is None else value - true
        why = "n/a (not estimated by this model)" if value is None else NO_TRUTH
        rows.append(
            [name, number(value, ".5g", "n/a"), number(true, ".5g"), number(err, "+.3g", why)]
        )
    return [
        "",
        "results against the truth",
        format_table(rows, ["result", "value", "truth", "error"]),
    ]


def summary_line(s, has_truth):
    """``NIS mean ..., NEES mean ...`` with n/a where not applicable."""
    nees = number(s.nees_mean, ".3g", NO_TRUTH if not has_truth else "n/a")
    return (
        f"NIS mean {number(s.nis_mean, '.3g', 'n/a (no update)')}, NEES mean {nees}, "
        f"rejected {s.rejected_measurements}, coasted epochs {s.coasted_epochs}"
    )


def heading_line(s, window_s, has_truth):
    """Heading-error RMS in deg and arcsec over the turning window, or n/a."""
    if not has_truth:
        return f"heading error: {NO_TRUTH} (the figure shows the filter's heading correction)"
    rms = s.heading_err_rms_deg
    final = s.heading_err_final_deg
    if rms is None or not math.isfinite(rms):
        return "heading error: n/a"
    return (
        f"heading error RMS from {window_s:g} s: {rms:.4g} deg ({rms * 3600:.4g} arcsec), "
        f"final {number(final, '.4g', 'n/a')} deg"
    )


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


@dataclass(frozen=True)
class TightSmoothed:
    """What the smoother and the outage protocol add to a tight run's results, datasets
    and report."""

    results: dict
    datasets: dict
    report: str


def tight_outages(result, smoothed, windows):
    """Results (lab units) and report lines of the outage protocol
    (:func:`inins.ekf.scoring.tight_outage_scores`); nulls and no text without truth or
    windows."""
    out = dict.fromkeys(TIGHT_OUTAGE_NAMES)
    scores = scoring.tight_outage_scores(result, smoothed, windows)
    if scores is None:
        return out, ""
    fwd, smd = scores
    out.update(
        outages_scored=int(fwd.window.shape[0]),
        outage_fwd_drift_hor_rms_m=fwd.rms_horizontal,
        outage_fwd_drift_3d_rms_m=fwd.rms_3d,
        outage_fwd_heading_end_rms_deg=fwd.rms_heading / DEG,
    )
    if smd is not None:
        out.update(
            outage_sm_drift_hor_rms_m=smd.rms_horizontal,
            outage_sm_drift_3d_rms_m=smd.rms_3d,
            outage_sm_heading_end_rms_deg=smd.rms_heading / DEG,
        )
    lines = [f"\n\nOutages ({fwd.window.shape[0]}, no GNSS measurement used), against truth:"]
    lines.append(
        "  window (s)        fwd hor / 3D max (m)  heading end (deg)"
        + ("   sm hor / 3D max (m)  heading end (deg)" if smd is not None else "")
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


def tight_smoothed(result, smoothed, windows=()):
    """Results, datasets and report of a tight run's ``smoothed`` solution
    (:class:`inins.ekf.smoother.Smoothed`, None: nulls) and its outage ``windows`` (s)."""
    out = dict.fromkeys(TIGHT_SMOOTH_NAMES)
    scores, text = tight_outages(result, smoothed, windows)
    if smoothed is None:
        return TightSmoothed(out | scores, {}, text)
    f = scoring.smoothing_figures(result, smoothed)
    out.update(
        smoothed_hor_sigma_median_m=f.smoothed_hor_sigma_median,
        forward_hor_sigma_median_m=f.forward_hor_sigma_median,
        smoothed_heading_sigma_start_deg=f.smoothed_heading_sigma_start / DEG,
        smoothed_forward_hor_diff_max_m=f.hor_diff_max,
        smoothed_pos_err_rms_m=f.smoothed_pos_err_rms,
    )
    datasets = {
        "smoothed/lla": Series(smoothed.lla, "rad, rad, m", "", "RTS-smoothed position (IMU)"),
        "smoothed/vel_n": Series(smoothed.vel, "m/s", "n", "smoothed velocity"),
        "smoothed/quat_nb": Series(smoothed.quat, "1", "nb", "smoothed attitude"),
        "smoothed/sigma": Series(smoothed.sigma, "SI", "", "smoothed 1-sigma of each state"),
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
