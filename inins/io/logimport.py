"""Import a lab IMU log (CSV, HDF5 or PSINS text) into the table-data layout.

The log is read in blocks (:mod:`inins.io.logformats`) and streamed into a
:class:`inins.results.SeriesSink` in the layout of :mod:`inins.io.tabledata`,
so memory does not grow with the length of the log. On the way every row is
checked (finite numbers, integer counts, increasing time without gaps) and
block statistics are kept for the stationary check (:mod:`inins.io.logcheck`).

Units: pulse counts stay counts (int32 with a ``pulse_weight`` attribute in
rad or m/s per body axis, as simulate-table writes them); increments in
physical units become SI floats; rates become increments ``rate * dt`` with
the nominal sample interval dt. Axes are mapped onto the body frame by the
signed permutation ``mat_bl`` (``v_b = mat_bl @ v_log``).

Time: a time column must increase, with no step longer than 1.5 or shorter
than 0.5 nominal sample intervals (a gap or a doubled row is an error). The
file keeps a uniform grid ``t0 + k dt``: t0 is the first row's time less one
interval when times mark the end of the interval (the default), the PSINS
header t0, or 0 without a time column. Steps given in the scenario are in
this same time base.
"""

import time
from dataclasses import dataclass

import numpy as np

from inins.core.units import ARCSEC, DEG, G0
from inins.exceptions import InputError
from inins.io import logcheck
from inins.io.logformats import Hdf5Log, TextLog, open_psins
from inins.results import CommandResult, Series
from inins.table import kinematics
from inins.table.record import Step

GAP_FACTOR = 1.5
"""A time step longer than this many sample intervals is a gap."""
SHORT_FACTOR = 0.5
"""A time step shorter than this many sample intervals is an error."""


@dataclass(frozen=True)
class Sensor:
    """How three log columns become increments.

    ``factor`` is SI per log unit (a multiple of g when ``per_g``);
    ``pulse_weight`` (3,), log axes, is rad or g*s per count, None for the
    PSINS header's.
    """

    quantity: str
    factor: float
    counts: bool
    pulse_weight: np.ndarray | None
    per_g: bool = False


@dataclass(frozen=True)
class StepSpec:
    """A step of the motion given in the scenario (times s, angles rad)."""

    kind: str
    label: str
    axis: int
    start: float
    end: float
    angles_start: np.ndarray
    angles_end: np.ndarray


@dataclass(frozen=True)
class LogImport:
    """Everything the import needs, SI (made by the scenario's ``to_import``)."""

    path: object
    format: str
    csv: object
    time: object
    gyro_cols: object
    accel_cols: object
    angle_cols: object
    time_scale: float
    time_marks: str
    dt: float | None
    gyro: Sensor
    accel: Sensor
    g_unit: float | None
    mat_bl: np.ndarray
    site: tuple
    gimbals: tuple
    base_azimuth: float
    angle_scale: float
    hold_tolerance: float
    hold_margin: float
    steps: tuple | None
    check: object


def _refs(cfg):
    """Column references and their scenario keys: time?, gyro (3), accel (3), angles (g)."""
    refs, keys = [], []

    def add(value, key, count):
        if isinstance(value, str) and cfg.format == "hdf5":
            value = [f"{value}[{j}]" for j in range(count)]
        for j, ref in enumerate(value):
            refs.append(ref)
            keys.append(f"log.columns.{key}[{j}]")

    if cfg.time is not None:
        refs.append(cfg.time)
        keys.append("log.columns.time")
    add(cfg.gyro_cols, "gyro", 3)
    add(cfg.accel_cols, "accel", 3)
    if cfg.angle_cols is not None:
        add(cfg.angle_cols, "table_angles", len(cfg.gimbals))
    return refs, keys


def open_log(cfg):
    """Open the log: ``(blocks, size, header, keys)``.

    ``blocks()`` yields :class:`inins.io.logformats.Block` s whose columns are
    time (if any), gyro x y z, accel x y z, table angles (if any); ``size``
    is the progress total; ``header`` the PSINS header (or None); ``keys`` the
    scenario key of each column.
    """
    if cfg.format == "psins":
        log, header = open_psins(cfg.path)
        keys = [f"{s} {a} (PSINS column {j})" for j, (s, a) in
                enumerate((s, a) for s in ("gyro", "accel") for a in "xyz")]
        return lambda: log.blocks(range(6)), log.size, header, keys
    refs, keys = _refs(cfg)
    if cfg.format == "hdf5":
        log = Hdf5Log(cfg.path)
        return lambda: log.blocks(refs, keys), log.size, None, keys
    csv = cfg.csv
    log = TextLog(cfg.path, None if csv.delimiter == "whitespace" else csv.delimiter,
                  csv.comment, csv.skip_lines, csv.header)
    index = [log.column_index(r, k) for r, k in zip(refs, keys, strict=True)]
    return lambda: log.blocks(index), log.size, None, keys


def resolve(cfg, header):
    """Values the scenario leaves to the PSINS header: dt, site, pulse weights, g.

    Returns
    -------
    dict
        ``dt`` (s or None), ``lla`` (rad, rad, m), ``g`` (m/s^2), ``gyro_pw`` and
        ``accel_pw`` (3,) rad and m/s per count in log axes (or None), and
        ``overrides``: scenario keys that replaced a header value.
    """
    h = header or {}
    g = cfg.g_unit or h.get("g_mps2") or G0
    overrides = [k for k, v in (("accel.g_mps2", cfg.g_unit), ("log.sample_rate_hz", cfg.dt))
                 if header and v is not None]
    lla = []
    for key, value, scale in zip(("lat_deg", "lon_deg", "height_m"), cfg.site,
                                 (DEG, DEG, 1.0), strict=True):
        if value is not None and header:
            overrides.append(f"site.{key}")
        lla.append(value if value is not None else h[key] * scale)
    pws = {}
    for key, sensor, hkey, scale in (("gyro.pulse_weight_arcsec", cfg.gyro,
                                      "gyro_pulse_arcsec", ARCSEC),
                                     ("accel.pulse_weight_ug_s", cfg.accel,
                                      "accel_pulse_ug_s", 1e-6)):
        name = key.split(".")[0]
        pw = sensor.pulse_weight
        if pw is not None and header:
            overrides.append(key)
        if pw is None and sensor.counts:
            pw = np.asarray(h[hkey], dtype=float) * scale
        pws[name] = None if pw is None else pw * (g if sensor.per_g else 1.0)
    return {"dt": cfg.dt or h.get("dt_s"), "lla": np.array(lla), "g": g,
            "gyro_pw": pws["gyro"], "accel_pw": pws["accel"], "overrides": overrides}


class _TimeCheck:
    """Time column checks across blocks: finite, increasing, no gaps."""

    def __init__(self, source, key):
        self.source, self.key = source, key
        self.first = self.last = None
        self.last_where = None

    def __call__(self, block, t, dt):
        prev = np.concatenate([[self.last if self.last is not None else t[0] - dt], t[:-1]])
        step = t - prev
        bad = np.flatnonzero((step <= 0) | (step > GAP_FACTOR * dt) | (step < SHORT_FACTOR * dt))
        if bad.size:
            r = int(bad[0])
            before = block.where(r - 1) if r else self.last_where
            what = ("goes back or repeats" if step[r] <= 0 else
                    "has a gap" if step[r] > GAP_FACTOR * dt else "steps too short")
            raise InputError(
                f"time {what}: {t[r]:.9g} s, {step[r]:.6g} s after {before}; expected steps "
                f"of {dt:.6g} s (between {SHORT_FACTOR} and {GAP_FACTOR} sample intervals)",
                source=self.source, key=self.key, line=block.line(r))
        if self.first is None:
            self.first = float(t[0])
        self.last, self.last_where = float(t[-1]), block.where(len(t) - 1)


def _row(block, r):
    """``"row N: "`` for an HDF5 log (a text log's line goes into the error's line)."""
    return "" if block.lines is not None else f"{block.where(r)}: "


def _finite(block, keys, source):
    bad = ~np.isfinite(block.values)
    if bad.any():
        r, j = np.argwhere(bad)[0]
        raise InputError(f"{_row(block, r)}got {block.values[r, j]}; expected a finite "
                         "number", source=source, key=keys[j], line=block.line(r))


def _increments(block, cols, sensor, pw, dt, mat_bl, keys, source):
    """Body-frame increments of a block: int64 counts or SI floats, and SI floats."""
    values = block.values[:, cols]
    if sensor.counts:
        frac = values != np.rint(values)
        if frac.any():
            r, j = np.argwhere(frac)[0]
            raise InputError(f"{_row(block, r)}got {values[r, j]}; expected an integer pulse "
                             "count", source=source, key=keys[cols[j]], line=block.line(r))
        stored = values.astype(np.int64) @ np.rint(mat_bl).astype(np.int64).T
        return stored, stored * (np.abs(mat_bl) @ pw)
    scale = sensor.factor * (dt if sensor.quantity == "rate" else 1.0)
    si = values @ (mat_bl.T * scale)
    return si, si


def _declare(sink, cfg, res, n_angles):
    for name, sensor, pw, unit in (("dtheta", cfg.gyro, res["gyro_pw"], "rad"),
                                   ("dv", cfg.accel, res["accel_pw"], "m/s")):
        if sensor.counts:
            sink.create(f"imu/{name}", (3,), np.int32, "count", "b",
                        f"IMU {name} pulse counts per sample",
                        attrs={"pulse_weight": np.abs(cfg.mat_bl) @ pw})
        else:
            sink.create(f"imu/{name}", (3,), np.float64, unit, "b",
                        f"IMU {name} increments per sample")
    if n_angles:
        sink.create("table/time", (), np.float64, "s", "", "time of the encoder readings")
        sink.create("table/encoder", (n_angles,), np.float64, "rad", "t",
                    "encoder readings, outer gimbal first")


def stream(cfg, sink, progress=None):
    """Read, check and convert the log, streaming it into ``sink``.

    Returns
    -------
    dict
        ``n`` samples, ``t0`` and ``dt`` (s), ``lla``, ``header``, ``blocks``
        (:class:`inins.io.logcheck.BlockStats`), ``time_span`` (first and last
        time of the time column, or None), ``rate_s`` (rows/s read), and the
        :func:`resolve` values.
    """
    blocks, size, header, keys = open_log(cfg)
    res = resolve(cfg, header)
    source = str(cfg.path)
    has_time = cfg.time is not None
    gcols = [int(has_time) + j for j in range(3)]
    acols = [int(has_time) + 3 + j for j in range(3)]
    n_angles = len(cfg.gimbals) if cfg.angle_cols is not None else 0
    _declare(sink, cfg, res, n_angles)
    timecheck = _TimeCheck(source, "log.columns.time")
    dt, stats, n, start = res["dt"], None, 0, time.perf_counter()
    for block in blocks():
        _finite(block, keys, source)
        t = block.values[:, 0] * cfg.time_scale if has_time else None
        if dt is None:
            if t.size < 2:
                raise InputError("need at least 2 rows to find the sample interval; "
                                 "set log.sample_rate_hz", source=source)
            # the median step, its rate rounded to 9 digits (undoes the float error of
            # differences of large times: 1000.2 - 1000.1 = 0.09999999999990905)
            dt = 1.0 / float(f"{1.0 / float(np.median(np.diff(t[:1001]))):.9g}")
        if has_time:
            timecheck(block, t, dt)
        if stats is None:
            stats = logcheck.BlockStats.start(dt, cfg.check.block_s, n_angles)
        stored_g, dtheta = _increments(block, gcols, cfg.gyro, res["gyro_pw"], dt, cfg.mat_bl,
                                       keys, source)
        stored_a, dv = _increments(block, acols, cfg.accel, res["accel_pw"], dt, cfg.mat_bl,
                                   keys, source)
        for name, stored, sensor in (("dtheta", stored_g, cfg.gyro), ("dv", stored_a, cfg.accel)):
            if sensor.counts and np.abs(stored).max(initial=0) > np.iinfo(np.int32).max:
                raise InputError(f"{name} counts overflow int32 in the rows from "
                                 f"{block.where(0)}", source=source)
            sink.append(f"imu/{name}", stored.astype(np.int32) if sensor.counts else stored)
        angles = block.values[:, acols[-1] + 1:] * cfg.angle_scale
        if n_angles:
            k = np.arange(n, n + len(block.values))
            sink.append("table/time", t if has_time else (k + 1) * dt)
            sink.append("table/encoder", angles)
        stats.add(dtheta, dv, angles)
        n += len(block.values)
        if progress is not None:
            progress(block.done, size)
    if n < 2:
        raise InputError(f"the log has {n} data rows; expected a record", source=source)
    elapsed = time.perf_counter() - start
    span = (timecheck.first, timecheck.last) if has_time else None
    if header:
        t0 = header["t0_s"]
    elif has_time:
        t0 = span[0] - (dt if cfg.time_marks == "end" else 0.0)
    else:
        t0 = 0.0
    return {**res, "n": n, "t0": t0, "dt": dt, "header": header, "blocks": stats.finish(),
            "time_span": span, "rate_s": n / max(elapsed, 1e-9)}


def scenario_steps(cfg, t0, dt, n):
    """Steps of the scenario as sample ranges; warnings for steps cut at the end."""
    steps, warnings = [], []
    for i, s in enumerate(cfg.steps):
        first = max(0, int(np.ceil((s.start - t0) / dt - 1e-9)))
        stop = min(n, int(np.floor((s.end - t0) / dt + 1e-9)))
        if stop <= first:
            end = t0 + n * dt
            raise InputError(f"step {i} ({s.start:g} s to {s.end:g} s) holds no whole sample "
                             f"of the log ({t0:.6g} s to {end:.6g} s)", key=f"steps[{i}]")
        if s.end > t0 + n * dt + 1e-9:
            warnings.append(f"step {i} ({s.label or s.kind}) ends after the log; cut at "
                            f"{t0 + n * dt:.6g} s")
        steps.append(Step(s.kind, s.label, s.axis, s.start, s.end, first, stop,
                                        s.angles_start, s.angles_end))
    return steps, warnings


def import_log(cfg, sink, progress=None):
    """``inins import-log`` end to end: stream the log into ``sink`` and check every hold.

    Parameters
    ----------
    cfg : LogImport
    sink : inins.results.SeriesSink
    progress : callable, optional
        ``progress(done, total)``.

    Returns
    -------
    inins.results.CommandResult
    """
    run = stream(cfg, sink, progress)
    n, t0, dt, stats = run["n"], run["t0"], run["dt"], run["blocks"]
    g = len(cfg.gimbals)
    warnings = []
    if cfg.steps:
        steps, warnings = scenario_steps(cfg, t0, dt, n)
    elif cfg.angle_cols is not None:
        steps = logcheck.encoder_steps(stats, t0, dt, n, cfg.hold_tolerance, cfg.hold_margin)
    else:
        steps = [Step("hold", "log", -1, t0, t0 + n * dt, 0, n, np.zeros(g),
                                    np.zeros(g))]
    checks = logcheck.check_holds(stats, steps, run["lla"], cfg.check)
    datasets = {**logcheck.step_datasets(steps, g), **logcheck.block_datasets(stats, t0, dt)}
    if cfg.angle_cols is None:
        datasets["table/time"] = Series(np.zeros(0), "s", "", "time of the encoder readings")
        datasets["table/encoder"] = Series(np.zeros((0, g)), "rad", "t",
                                           "encoder readings (none in this log)")
    lla = run["lla"]
    attrs = {
        "site": {"lat_rad": lla[0], "lon_rad": lla[1], "height_m": lla[2]},
        "imu": {"t0_s": t0, "dt_s": dt, "sample_rate_hz": 1.0 / dt},
        "table": {"gimbals": list(cfg.gimbals), "axes": kinematics.gimbal_axes(cfg.gimbals),
                  "mat_n_base": kinematics.base_matrix(cfg.base_azimuth)},
        "import": {"file": cfg.path.name, "format": cfg.format, "mat_bl": cfg.mat_bl,
                   "g_unit_mps2": run["g"]},
    }
    if not any(c is not None for c in checks):
        warnings.append(f"no hold of at least {cfg.check.min_hold_s:g} s: nothing checked")
    results = {"samples": n, "duration_s": n * dt, "sample_rate_hz": 1.0 / dt,
               "steps": len(steps), "holds_checked": sum(c is not None for c in checks),
               **logcheck.first_results(checks, lla)}
    report = logcheck.report(cfg, run, steps, checks)
    return CommandResult(command="import-log", results=results, datasets=datasets,
                         attrs=attrs, report=report, warnings=tuple(warnings))

