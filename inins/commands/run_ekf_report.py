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

import numpy as np

from inins.core.units import ARCSEC, DEG, DPH, UG
from inins.results import format_table

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
