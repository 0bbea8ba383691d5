"""``inins align-ett``: azimuth of the IMU on the table from the pitch-90 deg / level
positions with accelerometers only (spec §5, 000 §3.1), compared with gyrocompassing.

Runs :func:`inins.calibration.ett.align_ett` on the scenario's table record and writes
the ``ett`` group of ``align-ett.h5``, the summary numbers and the report;
:func:`inins.commands._table.read_ett_result` reads that group back for calibrate-bias.

Layout written by ``inins align-ett`` (every dataset has ``units``, ``frame`` and
``description`` attributes)::

    /ett                  attrs: gimbals (outer first), vertical_label, level_label,
                          data_source
    /ett/mat_tb (3, 3)    estimated IMU body -> table platform (1)
    /ett/mat_tb0 (3, 3)   nominal mounting; mat_tb = mat_tb0 exp([mu x])
    /ett/mu (3,)          mounting misalignment, b frame (rad)
    /ett/heading_rad, heading_sigma_rad ()   IMU heading at the level position, 1 sigma
    /ett/level_angles (g,), vertical_angles (g,)   table angles of the positions (rad)
    /ett/mat_n_base (3, 3), axes (g, 3)      table base -> NED and gimbal axes used
    /ett/f_b (2, 3)       mean specific force at the vertical, level position (m/s^2)
    /ett/windows (2, 2)   [start, end] of the vertical, level windows (s)

The IMU heading at any table position is the heading of ``mat_nt(encoder) @ mat_tb``
(:meth:`inins.calibration.ett.EttResult.heading_at`).
"""

import numpy as np

from inins.calibration.ett import align_ett, paper_angles
from inins.commands import align_ett_figures
from inins.commands._table import load_record, table_estimate
from inins.core import rotation
from inins.core.units import ARCSEC
from inins.results import CommandResult, Series, format_table
from inins.scenario.align_ett import AlignEttScenario
from inins.scenario.si.align_ett import options

SCENARIO_MODEL = AlignEttScenario
FIGURES = {"align-ett.png": align_ett_figures.align_ett_geometry}
RESULT_NAMES = (
    "heading_deg",
    "heading_sigma_deg",
    "heading_sigma_noise_deg",
    "heading_sigma_bias_deg",
    "heading_sigma_table_deg",
    "azimuth_offset_arcsec",
    "tilt_x_arcsec",
    "tilt_y_arcsec",
    "time_used_s",
    "gyrocompass_heading_deg",
    "gyrocompass_heading_sigma_deg",
    "gyrocompass_time_s",
    "heading_err_deg",
    "heading_err_pred_deg",
    "gyrocompass_heading_err_deg",
    "gyrocompass_heading_err_pred_deg",
    "err_ratio",
)
"""Every result name (the ``*_err*`` ones and ``err_ratio`` only where truth is known)."""
TRUTH_NAMES = (
    "heading_deg",
    "gyrocompass_heading_deg",
    "azimuth_offset_arcsec",
    "tilt_x_arcsec",
    "tilt_y_arcsec",
)


def declared_results(scenario):
    """Names of the results and truth a run gives (checks are validated against them)."""
    return RESULT_NAMES, TRUTH_NAMES


def estimate(scenario):
    """Size of the run: the in-memory simulation, or None for a data file (read in chunks)."""
    return None if scenario.simulate is None else table_estimate(scenario.simulate, True)


def run(scenario, seed, *, sink=None, progress=None):
    """ETT alignment of the scenario's table record (the data file, or the ``simulate``
    section simulated in memory with ``seed``); see :func:`align_ett`."""
    record, _ = load_record(scenario.data, scenario.simulate, seed, progress)
    estimate = align_ett(record, options(scenario))
    return command_result(estimate, record.gimbals, record.source)


def _deg(rad):
    return float(np.degrees(rad))


def _wrap_deg(rad):
    return float(np.degrees(rotation.wrap_angle(rad)))


def scalars(estimate):
    """Summary numbers (results, truth), flat and unit-suffixed."""
    r, s, gc = estimate.result, estimate.sigma, estimate.gyrocompass
    gc_heading = float(gc.euler[2])
    results = {
        "heading_deg": _deg(r.heading),
        "heading_sigma_deg": _deg(r.heading_sigma),
        "heading_sigma_noise_deg": _deg(s.noise),
        "heading_sigma_bias_deg": _deg(s.bias),
        "heading_sigma_table_deg": _deg(np.hypot(s.encoder, s.azimuth)),
        "azimuth_offset_arcsec": estimate.alpha / ARCSEC,
        "tilt_x_arcsec": estimate.beta / ARCSEC,
        "tilt_y_arcsec": estimate.gamma / ARCSEC,
        "time_used_s": estimate.time_used,
        "gyrocompass_heading_deg": _deg(gc_heading),
        "gyrocompass_heading_sigma_deg": _deg(gc.heading_sigma),
        "gyrocompass_time_s": estimate.gyrocompass_time,
    }
    truth = {}
    t = estimate.truth
    if t is not None:
        err = _wrap_deg(r.heading - t.heading)
        gc_err = _wrap_deg(gc_heading - t.gyrocompass_heading)
        results.update(
            {
                "heading_err_deg": err,
                "heading_err_pred_deg": _deg(t.heading_err_pred),
                "gyrocompass_heading_err_deg": gc_err,
                "gyrocompass_heading_err_pred_deg": _deg(t.gyrocompass_err_pred),
                "err_ratio": abs(err) / abs(gc_err) if gc_err != 0.0 else None,
            }
        )
        alpha, beta, gamma = paper_angles(t.mu, r.mat_tb0)
        truth = {
            "heading_deg": _deg(t.heading),
            "gyrocompass_heading_deg": _deg(t.gyrocompass_heading),
            "azimuth_offset_arcsec": alpha / ARCSEC,
            "tilt_x_arcsec": beta / ARCSEC,
            "tilt_y_arcsec": gamma / ARCSEC,
        }
    return results, truth


def datasets(estimate):
    """The ``ett`` group as :class:`~inins.results.Series`."""
    r, v, lv = estimate.result, estimate.vertical, estimate.level
    return {
        "ett/mat_tb": Series(r.mat_tb, "1", "tb", "estimated IMU body -> table platform"),
        "ett/mat_tb0": Series(r.mat_tb0, "1", "tb", "nominal mounting"),
        "ett/mu": Series(r.mu, "rad", "b", "mounting misalignment, mat_tb = mat_tb0 exp([mu x])"),
        "ett/heading_rad": Series(
            np.float64(r.heading), "rad", "", "IMU heading at the level position"
        ),
        "ett/heading_sigma_rad": Series(
            np.float64(r.heading_sigma), "rad", "", "1 sigma of the heading"
        ),
        "ett/level_angles": Series(r.level_angles, "rad", "t", "table angles, level position"),
        "ett/vertical_angles": Series(v.angles, "rad", "t", "table angles, vertical position"),
        "ett/mat_n_base": Series(r.mat_n_base, "1", "n", "table base -> NED used"),
        "ett/axes": Series(r.axes, "1", "t", "gimbal axes, outer first, in parent frames"),
        "ett/f_b": Series(
            np.stack([v.f_b, lv.f_b]),
            "m/s^2",
            "b",
            "mean specific force at the vertical and level positions",
        ),
        "ett/windows": Series(
            np.array([[v.time_start, v.time_end], [lv.time_start, lv.time_end]]),
            "s",
            "",
            "averaging windows of the vertical and level positions",
        ),
    }


def report(estimate, gimbals, source):
    """Report body: positions, ETT vs gyrocompass, heading error budget, 000 eq. 48."""
    r, s = estimate.result, estimate.sigma
    results, truth = scalars(estimate)
    positions = [
        [
            name,
            p.label,
            p.time_start,
            p.time_end,
            *np.degrees(p.angles),
            *(p.f_b / np.linalg.norm(p.f_b)),
        ]
        for name, p in (("vertical", estimate.vertical), ("level", estimate.level))
    ]
    compare = [
        [
            "ETT (accelerometers)",
            results["heading_deg"],
            results["heading_sigma_deg"],
            estimate.time_used,
            results.get("heading_err_deg"),
        ],
        [
            "gyrocompass",
            results["gyrocompass_heading_deg"],
            results["gyrocompass_heading_sigma_deg"],
            estimate.gyrocompass_time,
            results.get("gyrocompass_heading_err_deg"),
        ],
    ]
    budget = [
        [name, value / ARCSEC]
        for name, value in (
            ("accelerometer noise", s.noise),
            ("accelerometer bias", s.bias),
            ("encoder noise", s.encoder),
            ("table base azimuth", s.azimuth),
        )
    ]
    budget.append(["total (rss)", r.heading_sigma / ARCSEC])
    angles = [
        ["alpha (azimuth offset)", estimate.alpha / ARCSEC, truth.get("azimuth_offset_arcsec")],
        ["beta (tilt about 000 x)", estimate.beta / ARCSEC, truth.get("tilt_x_arcsec")],
        ["gamma (tilt about 000 y)", estimate.gamma / ARCSEC, truth.get("tilt_y_arcsec")],
    ]
    lines = [
        f"data: {source}",
        "noise of the window means: "
        + ("stated" if estimate.noise_stated else "from the data (scatter of block means)"),
        "",
        "positions (000 §3.1)",
        format_table(
            positions,
            [
                "position",
                "label",
                "start",
                "end",
                *[f"{g}" for g in gimbals],
                "f_x/|f|",
                "f_y/|f|",
                "f_z/|f|",
            ],
            ["", "", "s", "s", *["deg"] * len(gimbals), "", "", ""],
            fmt=".6g",
        ),
        "",
        "heading of the IMU at the level position",
        format_table(
            compare,
            ["method", "heading", "1 sigma", "time", "error"],
            ["", "deg", "deg", "s", "deg"],
            fmt=".6g",
        ),
        "",
        "ETT heading 1 sigma budget",
        format_table(budget, ["source", "1 sigma"], ["", "arcsec"], fmt=".4g"),
        "",
        "misalignment of the IMU relative to the table, 000 eq. 48 (B = W A U^-1)",
        format_table(angles, ["angle", "estimate", "truth"], ["", "arcsec", "arcsec"], fmt=".6g"),
    ]
    if estimate.truth is not None:
        lines += [
            "",
            "first-order predictions from the truth: ETT error "
            f"{results['heading_err_pred_deg']:.3g} deg (accelerometer bias), "
            f"gyrocompass error {results['gyrocompass_heading_err_pred_deg']:.3g} deg "
            "(-eps_E / (W cos lat))",
        ]
    return "\n".join(lines)


def command_result(estimate, gimbals, source):
    """The :class:`~inins.results.CommandResult` of one align-ett run."""
    results, truth = scalars(estimate)
    attrs = {
        "ett": {
            "gimbals": list(gimbals),
            "vertical_label": estimate.vertical.label,
            "level_label": estimate.level.label,
            "data_source": source,
        }
    }
    return CommandResult(
        "align-ett",
        results,
        truth,
        datasets(estimate),
        attrs,
        report(estimate, gimbals, source),
        estimate.warnings,
    )
