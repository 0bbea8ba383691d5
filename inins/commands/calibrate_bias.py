"""``inins calibrate-bias``: gyro-bias calibration on a rate table (spec §4, paper 000).

Loads the table record (a data file, or the ``simulate:`` section in memory), runs
:func:`inins.calibration.bias.calibrate_bias` and builds the flat results, truth,
datasets and text report from its outcome.
"""

import numpy as np

from inins.calibration import bias, budget, ett, exact_model, three_axis
from inins.calibration.alignment import HeadingSource
from inins.commands import figures
from inins.commands._table import load_record
from inins.core import rotation
from inins.core.units import ARCSEC, DEG, DEG_RTH, DPH, HOUR, PPM, UG, UG_RTHZ, UG_S
from inins.results import CommandResult, Series, format_table
from inins.scenario.calibrate_bias import CalibrateBiasScenario

SCENARIO_MODEL = CalibrateBiasScenario
FIGURES = {
    "calibrate-bias-roll.png": figures.calibrate_bias_roll,
    "calibrate-bias-pitch.png": figures.calibrate_bias_pitch,
}


def run(scenario, seed, *, sink=None, progress=None):
    """Calibrate from the scenario's data file or its in-memory simulation."""
    record, sensor = load_record(scenario.data, scenario.simulate, seed)
    settings = method_settings(scenario, sensor, _ett(scenario, record))
    labels = scenario.sequence.vertical_labels
    found = three_axis.calibrate_three_axis(
        record, settings, None if labels is None else tuple(labels), progress
    )
    return build(found.level, record, settings, scenario.paper000_case, found.pitched)


def _ett(scenario, record):
    """The ETT mounting for alignment method ett: from a file, or from this record."""
    if scenario.alignment.method != "ett":
        return None
    if scenario.alignment.ett_file is not None:
        from inins.commands.align_ett import read_ett_result

        return read_ett_result(scenario.alignment.ett_file)
    nominal = None if scenario.simulate is None else scenario.simulate.mount.nominal()
    return ett.align_ett(record, ett.EttOptions(mat_tb0=nominal)).result


def method_settings(scenario, sensor=None, ett_result=None):
    """The method settings in SI; ``sensor`` (SensorErrors of a simulation) fills the
    noise figures the scenario leaves out; ``ett_result`` is the ETT mounting."""
    n = scenario.noise
    arw = n.arw_deg_rth and [a * DEG_RTH for a in n.arw_deg_rth]
    if arw is None and sensor is not None:
        arw = sensor.gyro_arw
    vrw = (
        n.vrw_ug_rthz * UG_RTHZ
        if n.vrw_ug_rthz is not None
        else sensor.accel_vrw
        if sensor is not None
        else None
    )
    quantum = (
        n.accel_pulse_weight_ug_s * UG_S
        if n.accel_pulse_weight_ug_s is not None
        else float(sensor.accel_pulse_weight.mean())
        if sensor is not None
        else 0.0
    )
    a = scenario.alignment
    return bias.Settings(
        align_duration=a.duration_s,
        heading=None if a.heading_deg is None else a.heading_deg * DEG,
        heading_method=bias.HeadingMethod(a.method),
        heading_sigma=a.heading_sigma_arcsec * ARCSEC,
        epoch_window=scenario.sequence.epoch_window_s,
        settle=scenario.sequence.settle_s,
        labels=None if scenario.sequence.labels is None else tuple(scenario.sequence.labels),
        output_rate=scenario.navigation.output_rate_hz,
        free=scenario.navigation.mode == "free",
        arw=arw,
        vrw=vrw,
        accel_quantum=quantum,
        bias_z=scenario.gyro_bias_z_dph * DPH,
        k_sigma=scenario.mount_detection.k_sigma,
        floor=scenario.mount_detection.floor_arcsec * ARCSEC,
        ett=ett_result,
        bias_bound=_bias_bound(scenario, sensor),
        stated=_stated(scenario.uncertainty),
    )


def _stated(u):
    """The scenario's stated 1-sigma sensor errors in SI."""
    return budget.StatedErrors(
        accel_bias=u.accel_bias_ug * UG,
        gyro_bias_z=u.gyro_bias_z_dph * DPH,
        gyro_scale=np.broadcast_to(np.asarray(u.gyro_scale_ppm, float) * PPM, (3,)).copy(),
        gyro_misalignment=np.full(6, u.gyro_misalignment_arcsec * ARCSEC),
        bias_instability=u.gyro_bias_instability_dph * DPH,
        corr_time=u.gyro_bias_corr_time_s,
    )


def _bias_bound(scenario, sensor):
    """Largest gyro bias (rad/s) for the gyrocompass check: the scenario's stated bound,
    else the simulated bias (its magnitude), else None (checked on the estimates)."""
    stated = scenario.alignment.gyro_bias_bound_dph
    if stated is not None:
        return stated * DPH
    if sensor is not None:
        return float(np.linalg.norm(sensor.gyro_bias))
    return None


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


def _dph(value):
    return None if value is None else float(value / DPH)


def _arcsec(value):
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


def build(outcome, record, settings, paper_case=None, pitched=None):
    """The CommandResult of calibrate-bias; ``pitched``: the second (pitch 90 deg) return
    sequence, whose results give the body z entries (issue 7 item 7)."""
    results, names = _outcome_results(outcome)
    truth = _truth(outcome, names)
    report = _report(outcome, record, settings, names, paper_case)
    warnings = _warnings(outcome)
    if pitched is not None:
        z_results, z_names = _outcome_results(pitched)
        results.update({k: v for k, v in z_results.items() if _is_z(k)})
        names.update({k: v for k, v in z_names.items() if _is_z(k)})
        truth.update({k: v for k, v in _truth(pitched, z_names).items() if _is_z(k)})
        report += "\n\n" + _pitched_report(pitched, z_names)
        east = f"beta_{AXES[pitched.geometry.east]}:"
        warnings += tuple(  # an east axis other than z is taken from the level sequence
            f"pitched sequence: {w}"
            for w in _warnings(pitched)
            if pitched.geometry.east == 2 or not w.startswith(east)
        )
    return CommandResult(
        "calibrate-bias",
        results,
        truth,
        _datasets(outcome),
        _attrs(outcome, record),
        report,
        warnings,
    )


def _is_z(key):
    return key.startswith(("beta_z", "mount_z"))


def _pitched_report(pitched, names):
    g = pitched.geometry
    a = pitched.seq.positions[0]
    return "\n".join(
        [
            f"second return sequence (pitch gimbal at 90 deg, from {a.start:g} s): body "
            f"{AXES[pitched.track.down_axis]} vertical, {AXES[g.east]} east, "
            f"{AXES[g.north]} north; its vertical bias taken from the level sequence "
            f"({pitched_vertical(pitched)}); the level sequence ran again with its beta_z",
            "estimates (deg/h)",
            _estimate_table(pitched, names),
            "mount rotation from the return to the start attitude (000 eqs. 35, 43)",
            _mount_table(pitched),
            _choice_line(pitched),
            *([_budget_table(chosen_budget(pitched))] if chosen_budget(pitched) else []),
        ]
    )


def pitched_vertical(pitched):
    """The vertical bias the pitched sequence took as known, as text."""
    return f"beta_{AXES[pitched.track.down_axis]} = {pitched.vertical_bias / DPH:.6g} deg/h"


def _outcome_results(outcome):
    """Flat results (lab units) of one calibration and its ``result_names``."""
    names = result_names(outcome)
    results = {}
    for name, (value, sigma) in names.items():
        results[f"{name}_dph"] = _dph(value)
        results[f"{name}_sigma_dph"] = _dph(sigma)
    budgets = chosen_budget(outcome)
    for axis in range(3):
        terms = budgets.get(axis)
        results[f"beta_{AXES[axis]}_u_dph"] = None if terms is None else terms["total"] / DPH
        for t in budget.TERMS:
            results[f"beta_{AXES[axis]}_u_{t}_dph"] = None if terms is None else terms[t] / DPH
    heading_err = initial_heading_error(outcome)
    results["initial_heading_err_deg"] = None if heading_err is None else heading_err / DEG
    h = outcome.geometry.horizontal
    for axis in range(3):
        i = h.index(axis) if axis in h else None
        results[f"mount_{AXES[axis]}_arcsec"] = (
            None if i is None else _arcsec(outcome.check.residual[i])
        )
        results[f"mount_{AXES[axis]}_sigma_arcsec"] = (
            None if i is None else _arcsec(outcome.check.sigma[i])
        )
    t_a, t_b = outcome.seq.hold_times
    results.update(
        {"hold_a_s": t_a, "hold_b_s": t_b, "heading_deg": float(outcome.align.euler[2] / DEG)}
    )
    return results, names


def _truth(outcome, names):
    if not outcome.truth:
        return {}
    bias = outcome.truth.bias
    truth = {f"{n}_dph": float(bias[AXES.index(n.split("_")[1])] / DPH) for n in names}
    truth["initial_heading_err_deg"] = float(outcome.truth.phi0[2] / DEG)
    return truth


def _warnings(outcome):
    out = list(outcome.warnings)
    if not outcome.geometry.aligned:
        out.append(
            "no horizontal IMU axis points east at the first position (within 10 deg): "
            "the east/north split of the return-sequence formulas is approximate"
        )
    if not outcome.seq.has_return:
        out.append(outcome.choice.reason)
    elif outcome.choice.east_formula is None:
        out.append("beta_" + AXES[outcome.geometry.east] + ": " + outcome.choice.reason)
    return tuple(out)


def _datasets(outcome):
    tr = outcome.track
    return {
        "nav/time": Series(tr.time, "s", "", "navigation output times"),
        "nav/tilt": Series(
            outcome.eps,
            "rad",
            "b",
            "tilt of the computed attitude about "
            "the body axes (000's roll and pitch), zero about the vertical",
        ),
        "nav/euler": Series(
            rotation.euler_from_mat(tr.mat_nb), "rad", "nb", "computed roll, pitch, heading"
        ),
        "nav/vel_n": Series(tr.vel_n, "m/s", "n", "computed velocity = velocity error"),
        "epochs/window": Series(outcome.seq.epochs, "s", "", "epoch windows 0-4 (000 Table 1)"),
        "epochs/tilt": Series(outcome.epoch_tilts, "rad", "b", "mean tilt per epoch window"),
        **{
            f"estimates/{k}": Series(
                np.array([v.value, v.sigma]),
                "rad/s",
                "b",
                f"{METHOD_TITLES[k]}: bias and 1-sigma of the horizontal axes",
            )
            for k, v in outcome.estimates.items()
        },
        "mount/residual": Series(
            np.array([outcome.check.residual, outcome.check.sigma, outcome.threshold]),
            "rad",
            "b",
            "return-to-start residual, its 1-sigma, the threshold",
        ),
    }


def _attrs(outcome, record):
    return {
        "": {"data_source": record.source},
        "alignment": {
            "method": outcome.align.method,
            "mat_nb": outcome.align.mat_nb,
            "duration_s": outcome.align.duration,
            "heading_sigma_rad": outcome.align.heading_sigma,
        },
        "choice": {
            "east_formula": outcome.choice.east_formula or "none",
            "reason": outcome.choice.reason,
        },
        "geometry": {
            "east_axis": AXES[outcome.geometry.east],
            "north_axis": AXES[outcome.geometry.north],
        },
    }


def _report(outcome, record, settings, names, paper_case):
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
        _noise_line(outcome),
        "",
        "estimates (deg/h)",
        _estimate_table(outcome, names),
        "",
        "mount rotation from the return to the start attitude (000 eqs. 35, 43)",
        _mount_table(outcome),
        "",
        _choice_line(outcome),
    ]
    budgets = chosen_budget(outcome)
    if budgets:
        lines += ["", _budget_table(budgets)]
    if outcome.truth:
        lines += ["", _truth_lines(outcome)]
    if paper_case is not None:
        lines += ["", _paper_table(outcome, names, paper_case)]
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


def _budget_table(budgets):
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


def _choice_line(outcome):
    g = outcome.geometry
    if not outcome.seq.has_return:
        return "automatic choice: none. " + outcome.choice.reason
    return (
        f"automatic choice: beta_{AXES[g.north]} from eq. 38; beta_{AXES[g.east]}: "
        + (outcome.choice.east_formula or "none")
        + ". "
        + outcome.choice.reason
    )


def _noise_line(outcome):
    arw, vrw, estimated = outcome.noise
    source = ("estimated from the alignment window", "stated")
    return (
        f"noise for the 1-sigma: ARW {np.array2string(arw / DEG_RTH, precision=5)} "
        f"deg/sqrt(h) ({source[not estimated[0]]}), VRW "
        f"{np.array2string(vrw / UG_RTHZ, precision=3)} ug/sqrt(Hz) "
        f"({source[not estimated[1]]})"
    )


def _estimate_table(outcome, names):
    truth = outcome.truth.bias if outcome.truth else None
    rows = []
    for name, (value, sigma) in names.items():
        if value is None:
            continue  # not applicable (null in summary.json)
        axis = AXES.index(name.split("_")[1])
        err = None if value is None or truth is None else (value - truth[axis]) / DPH
        rows.append([name + "_dph", _dph(value), _dph(sigma), err, chosen_mark(outcome, name)])
    return format_table(
        rows,
        ["result", "value", "1-sigma", "error", "chosen"],
        ["", "deg/h", "deg/h", "deg/h", ""],
        fmt=".5g",
    )


def _mount_table(outcome):
    c = outcome.check
    rows = [
        [
            AXES[a],
            _arcsec(c.residual[i]),
            _arcsec(c.sigma[i]),
            _arcsec(outcome.threshold[i]),
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


def _truth_lines(outcome):
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


def _paper_table(outcome, names, case):
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


# -- declared names and size, before the run ------------------------------------------
_ESTIMATES = ("attitude", "velocity", "eq38", "eq44", "eq45", "")


def declared_results(scenario):
    """``(results, truth)`` names a run may give, for validating checks before it.

    Every horizontal axis could be either of x, y, z (the geometry is found from the
    data), so the names cover all three; a name this run does not give makes its check
    fail ("not available") rather than be bad input.
    """
    betas = [f"beta_{a}_{m}_dph".replace("__", "_") for a in AXES for m in _ESTIMATES]
    results = [*betas, *(b.replace("_dph", "_sigma_dph") for b in betas)]
    results += [f"mount_{a}_{s}arcsec" for a in AXES for s in ("", "sigma_")]
    results += [f"beta_{a}_u{t}_dph" for a in AXES for t in ("", *(f"_{t}" for t in budget.TERMS))]
    results += ["initial_heading_err_deg", "hold_a_s", "hold_b_s", "heading_deg"]
    return tuple(results), (*betas, "initial_heading_err_deg")


def estimate(scenario):
    """Size of the run: the in-memory simulation, or None for a data file (read in chunks)."""
    from inins.commands.budget import table_estimate

    return None if scenario.simulate is None else table_estimate(scenario.simulate, True)


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
                f"{name} = {_dph(value):.5f} +/- {_dph(sigma):.5f} deg/h (1-sigma), from {formula}"
            )
    out.append(_choice_line(outcome))
    return out
