"""``inins import-log``: a lab IMU log into the table-data layout, with a stationary
check of every hold (spec §3).

:class:`inins.io.logimport.LogReader` reads the log as typed chunks; they stream
into the table-data layout (:mod:`inins.io.tabledata`) while block statistics are
kept (:class:`inins.calibration.stationary.BlockStats`); the holds come from the
scenario, from the table angles, or the whole log is one; each is checked by
:func:`inins.calibration.stationary.check_holds`. With ``compensation: FILE`` (a
calibrate-imu compensation file) the increments are compensated as they are formed
and stored as float64 SI increments instead of pulse counts (the layout allows
either; the compensated increments are no longer whole pulses), the file's name and
SHA-256 under the ``import`` attributes. Scenario keys:
:mod:`inins.scenario.import_log`.
"""

from dataclasses import dataclass, replace

import numpy as np

from inins.calibration import stationary
from inins.calibration.imu_model import compensate
from inins.commands import import_log_figures
from inins.commands._compensation import compensation_provenance, scenario_terms
from inins.commands.import_log_report import hold_numbers, report
from inins.core.records import Step, StepKind
from inins.exceptions import InputError
from inins.io import tabledata
from inins.io.logimport import (
    LogExtent,
    LogReader,
    Resolved,
)
from inins.results import CommandResult, NullSink, Series
from inins.scenario.import_log import ImportLogScenario, import_settings
from inins.table import kinematics

SCENARIO_MODEL = ImportLogScenario
FIGURES = {"import-log.png": import_log_figures.import_log_checks}
HOLD_NAMES = (
    "roll_deg",
    "pitch_deg",
    "heading_deg",
    "heading_sigma_deg",
    "earth_rate_dph",
    "earth_rate_err_pct",
    "earth_rate_horizontal_dph",
    "earth_rate_horizontal_err_pct",
    "implied_lat_deg",
    "implied_lat_err_deg",
    "gravity_err_ug",
    "hold_s",
    "quiet_s",
    "heading_unscreened_deg",
    "earth_rate_horizontal_unscreened_dph",
    "implied_lat_unscreened_deg",
    *(f"arw_{a}_deg_rth" for a in "xyz"),
    *(f"vrw_{a}_ug_rthz" for a in "xyz"),
)
"""Results of the first checked hold (:func:`hold_numbers`); absent if no hold is checked."""
RESULT_NAMES = ("samples", "duration_s", "sample_rate_hz", "steps", "holds_checked", *HOLD_NAMES)


def declared_results(scenario):
    """Names of the results and truth a run gives (checks are validated against them)."""
    return RESULT_NAMES, ()


def estimate(scenario):
    """Size of the import: the output is at most about the log's size (text and 16-bit
    binary logs are larger per sample than the stored increments)."""
    from inins.commands.budget import Estimate

    try:
        size = scenario.log.file.stat().st_size
    except OSError:
        return None  # the reader says what is wrong with the file
    return Estimate(0, 2 * size, 256 << 20, "log.file")


@dataclass(frozen=True)
class LogRun:
    """What reading the log gave: the resolved settings, the extent and the block
    statistics."""

    resolved: Resolved
    extent: LogExtent
    stats: stationary.BlockStats


def run(scenario, seed, *, sink=None, progress=None):
    """Import the scenario's log, streaming the table-data layout into ``sink``.

    ``seed`` is unused (nothing is random).
    """
    cfg = import_settings(scenario)
    terms = scenario_terms(scenario)
    sink = NullSink() if sink is None else sink
    reader = LogReader(cfg)
    res, g = reader.resolved, len(cfg.gimbals)
    weights = tuple(
        None if not sensor.counts or terms is not None else np.abs(cfg.mat_bl) @ pw
        for sensor, pw in ((cfg.gyro, res.gyro_pw), (cfg.accel, res.accel_pw))
    )
    tabledata.declare(sink, g, weights, encoder=reader.n_angles > 0)
    stats = None
    for part in reader.chunks(progress):
        if stats is None:
            stats = stationary.BlockStats.start(reader.dt, cfg.check.block_s, reader.n_angles)
        table, stored = part.table, (part.stored_dtheta, part.stored_dv)
        if terms is not None:
            dth, dv = compensate(table.dtheta, table.dv, reader.dt, terms)
            table, stored = replace(table, dtheta=dth, dv=dv), (dth, dv)
        tabledata.append_chunk(sink, table, stored=stored, encoder=reader.n_angles > 0)
        stats.add(table.dtheta, table.dv, table.encoder)
    log = LogRun(res, reader.extent, stats.finish())
    result = _result(cfg, log)
    if scenario.compensation is not None:
        result.attrs["import"].update(compensation_provenance(scenario.compensation))
    return result


def _result(cfg, log):
    n, t0, dt = log.extent.n, log.extent.t0, log.extent.dt
    g = len(cfg.gimbals)
    warnings = []
    if cfg.steps:
        steps, warnings = scenario_steps(cfg, t0, dt, n)
    elif cfg.angle_cols is not None:
        steps = stationary.encoder_steps(log.stats, t0, dt, n, cfg.hold_tolerance, cfg.hold_margin)
    else:
        steps = [Step(StepKind.HOLD, "log", -1, t0, t0 + n * dt, 0, n, np.zeros(g), np.zeros(g))]
    lla = log.resolved.lla
    checks = stationary.check_holds(log.stats, steps, lla, cfg.check)
    datasets = {**tabledata.encode_steps(steps, g), **block_datasets(log.stats, t0, dt)}
    if cfg.angle_cols is None:
        datasets["table/time"] = tabledata.series("table/time", np.zeros(0))
        datasets["table/encoder"] = tabledata.series(
            "table/encoder", np.zeros((0, g)), g, "encoder readings (none in this log)"
        )
    attrs = {
        "site": {"lat_rad": lla[0], "lon_rad": lla[1], "height_m": lla[2]},
        "imu": {"t0_s": t0, "dt_s": dt, "sample_rate_hz": 1.0 / dt},
        "table": {
            "gimbals": list(cfg.gimbals),
            "axes": kinematics.gimbal_axes(cfg.gimbals),
            "mat_n_base": kinematics.base_matrix(cfg.base_azimuth),
        },
        "import": {
            "file": cfg.path.name,
            "format": cfg.format,
            "mat_bl": cfg.mat_bl,
            "g_unit_mps2": log.resolved.g,
        },
    }
    if not any(c is not None for c in checks):
        warnings.append(f"no hold of at least {cfg.check.min_hold_s:g} s: nothing checked")
    results = {
        "samples": n,
        "duration_s": n * dt,
        "sample_rate_hz": 1.0 / dt,
        "steps": len(steps),
        "holds_checked": sum(c is not None for c in checks),
        **first_results(checks, lla),
    }
    return CommandResult(
        command="import-log",
        results=results,
        datasets=datasets,
        attrs=attrs,
        report=report(cfg, log, steps, checks),
        warnings=tuple(warnings),
    )


def scenario_steps(cfg, t0, dt, n):
    """Steps of the scenario as sample ranges; warnings for steps cut at the end."""
    steps, warnings = [], []
    for i, s in enumerate(cfg.steps):
        first = max(0, int(np.ceil((s.start_time - t0) / dt - 1e-9)))
        stop = min(n, int(np.floor((s.end_time - t0) / dt + 1e-9)))
        if stop <= first:
            end = t0 + n * dt
            raise InputError(
                f"step {i} ({s.start_time:g} s to {s.end_time:g} s) holds no whole sample "
                f"of the log ({t0:.6g} s to {end:.6g} s)",
                key=f"steps[{i}]",
            )
        if s.end_time > t0 + n * dt + 1e-9:
            warnings.append(
                f"step {i} ({s.label or s.kind}) ends after the log; cut at {t0 + n * dt:.6g} s"
            )
        steps.append(replace(s, start_index=first, stop_index=stop))
    return steps, warnings


def first_results(checks, lla):
    """Flat results of the first checked hold (in time order), or {}."""
    first = next((c for c in checks if c is not None), None)
    return {} if first is None else hold_numbers(first, lla)


def block_datasets(stats, t0, dt):
    """Block means of the log (what the check works on), under ``check/``."""
    tau = stats.duration
    n = stats.dtheta.shape[0]
    return {
        "check/time": Series(t0 + tau * np.arange(1, n + 1), "s", "", "end of each block"),
        "check/omega_b": Series(stats.dtheta / tau, "rad/s", "b", "block mean angular rate"),
        "check/f_b": Series(stats.dv / tau, "m/s^2", "b", "block mean specific force"),
        "check/gyro_spread": Series(
            stats.spread / dt, "rad/s", "b", "standard deviation of the gyro samples in each block"
        ),
    }
