"""``inins calibrate-bias``: gyro-bias calibration on a rate table (spec §4, paper 000).

Loads the table record (a data file, or the ``simulate:`` section in memory), applies
the ``compensation:`` file to its increments as they are read (when given), runs
:func:`inins.calibration.bias.calibrate_bias` and builds the flat results, truth,
datasets and text report from its outcome.
"""

import numpy as np

from inins.calibration import budget, ett, three_axis
from inins.commands import calibrate_bias_figures
from inins.commands._compensation import CompensatedRecord, scenario_terms
from inins.commands._table import load_record, read_ett_result, table_estimate
from inins.commands.calibrate_bias_report import (
    AXES,
    METHOD_TITLES,
    arcsec,
    chosen_budget,
    dph,
    initial_heading_error,
    pitched_report,
    report,
    result_names,
)
from inins.core import rotation
from inins.core.units import DEG, DPH
from inins.results import CommandResult, Series
from inins.scenario.calibrate_bias import CalibrateBiasScenario
from inins.scenario.si.calibrate_bias import method_settings

SCENARIO_MODEL = CalibrateBiasScenario
FIGURES = {
    "calibrate-bias-roll.png": calibrate_bias_figures.calibrate_bias_roll,
    "calibrate-bias-pitch.png": calibrate_bias_figures.calibrate_bias_pitch,
}


def run(scenario, seed, *, sink=None, progress=None):
    """Calibrate from the scenario's data file or its in-memory simulation."""
    record, sensor = load_record(scenario.data, scenario.simulate, seed)
    record = CompensatedRecord.wrap(record, scenario_terms(scenario))
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
        return read_ett_result(scenario.alignment.ett_file)
    nominal = None if scenario.simulate is None else scenario.simulate.mount.nominal()
    return ett.align_ett(record, ett.EttOptions(mat_tb0=nominal)).result


def build(outcome, record, settings, paper_case=None, pitched=None):
    """The CommandResult of calibrate-bias; ``pitched``: the second (pitch 90 deg) return
    sequence, whose results give the body z entries (issue 7 item 7)."""
    results, names = _outcome_results(outcome)
    truth = _truth(outcome, names)
    text = report(outcome, record, settings, names, paper_case)
    warnings = _warnings(outcome)
    if pitched is not None:
        z_results, z_names = _outcome_results(pitched)
        results.update({k: v for k, v in z_results.items() if _is_z(k)})
        names.update({k: v for k, v in z_names.items() if _is_z(k)})
        truth.update({k: v for k, v in _truth(pitched, z_names).items() if _is_z(k)})
        text += "\n\n" + pitched_report(pitched, z_names)
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
        text,
        warnings,
    )


def _is_z(key):
    return key.startswith(("beta_z", "mount_z"))


def _outcome_results(outcome):
    """Flat results (lab units) of one calibration and its ``result_names``."""
    names = result_names(outcome)
    results = {}
    for name, (value, sigma) in names.items():
        results[f"{name}_dph"] = dph(value)
        results[f"{name}_sigma_dph"] = dph(sigma)
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
            None if i is None else arcsec(outcome.check.residual[i])
        )
        results[f"mount_{AXES[axis]}_sigma_arcsec"] = (
            None if i is None else arcsec(outcome.check.sigma[i])
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
    return None if scenario.simulate is None else table_estimate(scenario.simulate, True)
