"""calibrate-bias's text report and the flat result names of its estimates (000 §3.2).

The report opens with the verdict (which estimate to trust and why), then the estimates
side by side with their 1-sigma, the uncertainty budget, the mount check, the truth
where known and, for the paper 000 cases, the paper's numbers beside ours.
"""

import numpy as np

from inins.calibration import bias, budget, exact_model, three_axis
from inins.calibration.alignment import HeadingSource
from inins.core.units import ARCSEC, DEG, DEG_RTH, DPH, HOUR, UG_RTHZ
from inins.results import format_table

AXES = "xyz"
ALIGNMENT_LABELS = {
    bias.HeadingMethod.GYROCOMPASS: "gyrocompass",
    bias.HeadingMethod.KNOWN: "known heading",
    bias.HeadingMethod.ETT: "ETT",
}
METHOD_TITLES = {
    "attitude": "attitude error, two positions (000 eqs. 28-29)",
    "velocity": "velocity error, quadratic fit (000 eq. 12)",
    "eq44": "return sequence: eq. 44 (east) + eq. 38 (north)",
    "eq45": "return sequence: eq. 45 (east) + eq. 38 (north)",
    "eq38": "return sequence: eq. 38 alone (north), east bias from the velocity method",
}
PAPER = {  # 000 §3.2 (deg per T); None where the paper gives no number
    1: {"eq38": -0.0034, "eq44": 0.0016, "eq45": None},
    2: {"eq38": -0.0037, "eq44": 0.0016, "eq45": 0.00352},
    3: {"eq38": -0.0034, "eq44": 0.004435, "eq45": 0.00345},
    4: {"eq38": -0.0034, "eq44": None, "eq45": 0.00164},
}
PAPER_TRUTH = {"beta_x": 0.0016, "beta_y": -0.0034}
PAPER_NOTES = (
    "000 prints eq. 49 as -0.0037/T, but its own terms (-0.00024 + 0.0066 - 0.0072 - "
    "0.0059)/2 give -0.00337/T: an arithmetic slip.",
    "Where a formula is biased, 000's printed values are 8-13 % above what its eqs. 44-45 "
    "predict for the stated disturbance ((M3 + M4)/2T = 0.0025/T for eq. 44; "
    "psi_U(0) omega_N = beta_x for eq. 45); ours follow the equations (and the exact linear "
    "model to < 0.2 %). The paper does not give the details (T, navigation mode) that "
    "would explain its excess.",
)


def dph(value):
    return None if value is None else float(value / DPH)


def arcsec(value):
    """arcsec, None where not applicable (NaN)."""
    return float(value / ARCSEC) if np.isfinite(value) else None


FORMULAS = ("attitude", "velocity", "eq38", "eq44", "eq45")
"""Per-axis result names ``beta_<axis>_<formula>``; eq. 38 applies to the axis pointing
north at A, eqs. 44-45 to the one pointing east, the others are null."""


def result_names(outcome):
    """``name -> (value rad/s, sigma rad/s)`` of every estimate, unit suffix added later.

    The same names in every run (issue 7): every formula on every body axis x, y, z, and
    the chosen ``beta_<axis>``, (None, None) where not applicable (the vertical axis, eq. 38
    on the east axis, eqs. 44-45 on the north axis, no return to the first position).
    """
    g = outcome.geometry
    h = g.horizontal
    est = outcome.estimates
    out = {f"beta_{a}_{f}": (None, None) for a in AXES for f in FORMULAS}
    for name in ("attitude", "velocity"):
        for i, axis in enumerate(h):
            out[f"beta_{AXES[axis]}_{name}"] = (est[name].value[i], est[name].sigma[i])
    if "eq44" in est:
        ie = h.index(g.east)
        north = outcome.chosen[g.north]
        out[f"beta_{AXES[g.north]}_eq38"] = north[:2]
        for f in ("eq44", "eq45"):
            out[f"beta_{AXES[g.east]}_{f}"] = (est[f].value[ie], est[f].sigma[ie])
    for axis in range(3):
        chosen = outcome.chosen.get(axis)
        out[f"beta_{AXES[axis]}"] = (None, None) if chosen is None else chosen[:2]
    return out


def chosen_budget(outcome):
    """``axis -> {term: 1-sigma rad/s, "total": ...}`` of each chosen bias (issue 7 item 6)."""
    return three_axis.chosen_budgets(outcome)


def initial_heading_error(outcome):
    """Initial heading error (rad) the calibration implies: the gyrocompass equilibrium
    ``asin((mat_nb b)_E / (W cos lat))`` with the chosen biases (000 §3.2,
    :func:`inins.calibration.exact_model.gyrocompass_heading_error`), 0 for a known heading."""
    if outcome.align.method != HeadingSource.GYROCOMPASS:
        return 0.0
    if outcome.choice.east_formula is None:
        return None  # the east bias, and with it the heading error, is not known
    est = outcome.estimates[outcome.choice.east_formula]
    bias = np.zeros(3)
    bias[outcome.geometry.horizontal] = est.value
    return exact_model.gyrocompass_heading_error(outcome.track.mat_nb[0], bias, outcome.track.lat)


def report(outcome, record, settings, names, paper_case):
    seq, al = outcome.seq, outcome.align
    g = outcome.geometry
    t_a, t_b = seq.hold_times
    roll, pitch, heading = al.euler / DEG
    lines = [
        *verdict_lines(outcome),
        "",
        f"data: {record.source}, {record.n_samples} samples at {1 / record.dt:g} Hz",
        "sequence (000 Table 1): "
        + ", ".join(
            f"{k} = {'/'.join(p.labels)} {p.start:g}-{p.end:g} s"
            for k, p in zip(("A", "B", "A'"), seq.positions, strict=True)
            if p is not None
        ),
        f"navigation time at A {t_a:.1f} s, at B {t_b:.1f} s; "
        f"{'free-inertial' if settings.free else 'stationary (known position, zero velocity)'}"
        f" navigation, output every {np.median(np.diff(outcome.track.time)):g} s",
        f"alignment: {ALIGNMENT_LABELS[settings.heading_method]} over {al.duration:g} s: "
        f"roll {roll:.5f}, pitch {pitch:.5f}, "
        f"heading {heading:.5f} deg"
        + (f" (1-sigma {al.heading_sigma / DEG:.2g} deg)" if al.heading_sigma > 0 else ""),
        f"axes at A: body {AXES[g.east]} points east, {AXES[g.north]} north",
        noise_line(outcome),
        "",
        "estimates (deg/h)",
        estimate_table(outcome, names),
        "",
        "mount rotation from the return to the start attitude (000 eqs. 35, 43)",
        mount_table(outcome),
        "",
        choice_line(outcome),
    ]
    budgets = chosen_budget(outcome)
    if budgets:
        lines += ["", budget_table(budgets)]
    if outcome.truth:
        lines += ["", truth_lines(outcome)]
    if paper_case is not None:
        lines += ["", paper_table(outcome, names, paper_case)]
    return "\n".join(lines)


BUDGET_TITLES = {
    "random": "random (sensor noise, alignment noise)",
    "accel_bias": "accelerometer bias through levelling",
    "gyro_bias_z": "vertical gyro bias taken as known",
    "gyro_scale": "gyro scale factor",
    "misalignment": "gyro misalignment",
    "bias_instability": "gyro bias instability",
    "total": "combined 1-sigma u (quadrature sum)",
}


def budget_table(budgets):
    axes = sorted(budgets)
    rows = [
        [BUDGET_TITLES[t], *(budgets[a][t] / DPH for a in axes)] for t in (*budget.TERMS, "total")
    ]
    return (
        "uncertainty budget of the chosen biases (1-sigma, from the stated sensor errors; "
        "summary.json: beta_<axis>_u_dph and beta_<axis>_u_<term>_dph)\n"
        + format_table(
            rows,
            ["term", *(f"beta_{AXES[a]}" for a in axes)],
            ["", *["deg/h"] * len(axes)],
            fmt=".3g",
        )
    )


def choice_line(outcome):
    g = outcome.geometry
    if not outcome.seq.has_return:
        return "automatic choice: none. " + outcome.choice.reason
    return (
        f"automatic choice: beta_{AXES[g.north]} from eq. 38; beta_{AXES[g.east]}: "
        + (outcome.choice.east_formula or "none")
        + ". "
        + outcome.choice.reason
    )


def noise_line(outcome):
    arw, vrw, estimated = outcome.noise
    source = ("estimated from the alignment window", "stated")
    return (
        f"noise for the 1-sigma: ARW {np.array2string(arw / DEG_RTH, precision=5)} "
        f"deg/sqrt(h) ({source[not estimated[0]]}), VRW "
        f"{np.array2string(vrw / UG_RTHZ, precision=3)} ug/sqrt(Hz) "
        f"({source[not estimated[1]]})"
    )


def estimate_table(outcome, names):
    truth = outcome.truth.bias if outcome.truth else None
    rows = []
    for name, (value, sigma) in names.items():
        if value is None:
            continue  # not applicable (null in summary.json)
        axis = AXES.index(name.split("_")[1])
        err = None if value is None or truth is None else (value - truth[axis]) / DPH
        rows.append([name + "_dph", dph(value), dph(sigma), err, chosen_mark(outcome, name)])
    return format_table(
        rows,
        ["result", "value", "1-sigma", "error", "chosen"],
        ["", "deg/h", "deg/h", "deg/h", ""],
        fmt=".5g",
    )


def mount_table(outcome):
    c = outcome.check
    rows = [
        [
            AXES[a],
            arcsec(c.residual[i]),
            arcsec(c.sigma[i]),
            arcsec(outcome.threshold[i]),
            "n/a"
            if not np.isfinite(c.residual[i])
            else "yes"
            if abs(c.residual[i]) > outcome.threshold[i]
            else "no",
        ]
        for i, a in enumerate(outcome.geometry.horizontal)
    ]
    return format_table(
        rows,
        ["axis", "residual", "1-sigma", "threshold", "turned"],
        ["", "arcsec", "arcsec", "arcsec", ""],
        fmt=".4g",
    )


def truth_lines(outcome):
    tr = outcome.truth
    h = outcome.geometry.horizontal
    rows = [[name, *(p / DPH)] for name, p in tr.predicted.items()]
    table = format_table(
        rows, ["method", *(f"beta_{AXES[a]}" for a in h)], ["", *["deg/h"] * len(h)], fmt=".5g"
    )
    return (
        "truth: "
        + ", ".join(f"beta_{AXES[a]} = {tr.bias[a] / DPH:.6g} deg/h" for a in h)
        + f", initial heading error {tr.phi0[2] / DEG:.5g} deg\n"
        "error each method should carry by the linear error model (000 eqs. 26-45, "
        "exact gains) for the simulated mount rotation and initial attitude error:\n" + table
    )


def paper_table(outcome, names, case):
    b = outcome.seq.positions[1]
    t_hold = (b.end - b.start) / HOUR  # 000's T: the hold time
    g = outcome.geometry
    e, n = AXES[g.east], AXES[g.north]
    rows = []
    for formula, key in (
        ("eq38", f"beta_{n}_eq38"),
        ("eq44", f"beta_{e}_eq44"),
        ("eq45", f"beta_{e}_eq45"),
    ):
        ours = names[key][0]
        ours_t = None if ours is None else ours / DPH * t_hold
        rows.append([formula, PAPER[case][formula], ours_t])
    table = format_table(rows, ["formula", "000 §3.2", "inins"], ["", "deg/T", "deg/T"], fmt=".5g")
    return (
        f"paper 000 §3.2 case {case} (T = {t_hold * HOUR:g} s; truth "
        f"beta_x = {PAPER_TRUTH['beta_x']}/T, beta_y = {PAPER_TRUTH['beta_y']}/T)\n"
        + table
        + "\n"
        + "\n".join("note: " + s for s in PAPER_NOTES)
    )


# -- the verdict: which estimate to trust -------------------------------------------
def chosen_mark(outcome, name):
    """``"<- chosen"`` on the estimate the automatic choice took for its axis, else ""."""
    for axis, pick in outcome.chosen.items():
        if pick is not None and name == f"beta_{AXES[axis]}_{pick[2]}":
            return "<- chosen"
    return ""


def verdict_lines(outcome):
    """The report's opening three lines: beta_x and beta_y with 1-sigma (the chosen
    estimates), and the formula chosen and why."""
    out = []
    for axis in sorted(outcome.chosen):
        pick = outcome.chosen[axis]
        name = f"beta_{AXES[axis]}"
        if pick is None:
            out.append(f"{name}: no valid formula (see the choice below)")
        else:
            value, sigma, formula = pick
            out.append(
                f"{name} = {dph(value):.5f} +/- {dph(sigma):.5f} deg/h (1-sigma), from {formula}"
            )
    out.append(choice_line(outcome))
    return out


def pitched_report(pitched, names):
    g = pitched.geometry
    a = pitched.seq.positions[0]
    return "\n".join(
        [
            f"second return sequence (pitch gimbal at 90 deg, from {a.start:g} s): body "
            f"{AXES[pitched.track.down_axis]} vertical, {AXES[g.east]} east, "
            f"{AXES[g.north]} north; its vertical bias taken from the level sequence "
            f"({pitched_vertical(pitched)}); the level sequence ran again with its beta_z",
            "estimates (deg/h)",
            estimate_table(pitched, names),
            "mount rotation from the return to the start attitude (000 eqs. 35, 43)",
            mount_table(pitched),
            choice_line(pitched),
            *([budget_table(chosen_budget(pitched))] if chosen_budget(pitched) else []),
        ]
    )


def pitched_vertical(pitched):
    """The vertical bias the pitched sequence took as known, as text."""
    return f"beta_{AXES[pitched.track.down_axis]} = {pitched.vertical_bias / DPH:.6g} deg/h"
