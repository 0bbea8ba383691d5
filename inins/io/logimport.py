"""Read a lab IMU log (CSV, HDF5 or PSINS text) as typed chunks in SI, body axes.

:class:`LogReader` reads the log in blocks (:mod:`inins.io.logformats`) and yields
:class:`LogChunk` s, so memory does not grow with the length of the log;
``inins import-log`` (:mod:`inins.commands.import_log`) writes them in the
table-data layout and keeps block statistics for the stationary check. On the
way every row is checked (finite numbers, integer counts, increasing time without
gaps).

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

import functools
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from inins.core.records import Step, TableChunk
from inins.core.units import ARCSEC, DEG, G0
from inins.exceptions import InputError
from inins.io.logformats import Hdf5Log, PsinsHeader, TextLog, open_psins

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
class CsvFormat:
    """How a text log is split (``delimiter`` None: runs of blanks)."""

    delimiter: str | None = ","
    comment: str = "#"
    skip_lines: int = 0
    header: bool = False


@dataclass(frozen=True)
class ScreeningOptions:
    """The stationary check's settings (see :mod:`inins.calibration.stationary`)."""

    block_s: float = 1.0
    min_hold_s: float = 10.0
    screen: bool = True
    std_ratio: float = 3.0
    rate_sigma: float = 6.0
    guard_s: float = 5.0


ColumnRefs = int | str | list | None
"""A column (0-based index or name), a list of them, or an HDF5 2-D dataset name."""


@dataclass(frozen=True)
class LogImport:
    """Everything the import needs, SI (made from the scenario by the command)."""

    path: Path
    format: str
    csv: CsvFormat
    time: int | str | None
    gyro_cols: ColumnRefs
    accel_cols: ColumnRefs
    angle_cols: ColumnRefs
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
    steps: tuple[Step, ...] | None
    check: ScreeningOptions


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
        keys = [
            f"{s} {a} (PSINS column {j})"
            for j, (s, a) in enumerate((s, a) for s in ("gyro", "accel") for a in "xyz")
        ]
        return lambda: log.blocks(range(6)), log.size, header, keys
    refs, keys = _refs(cfg)
    if cfg.format == "hdf5":
        log = Hdf5Log(cfg.path)
        return lambda: log.blocks(refs, keys), log.size, None, keys
    csv = cfg.csv
    log = TextLog(cfg.path, csv.delimiter, csv.comment, csv.skip_lines, csv.header)
    index = [log.column_index(r, k) for r, k in zip(refs, keys, strict=True)]
    return lambda: log.blocks(index), log.size, None, keys


@dataclass(frozen=True)
class Resolved:
    """What the scenario and the PSINS header give together: ``dt`` (s, None: from the
    time column), ``lla`` (rad, rad, m), ``g`` (m/s^2 of the log's g units),
    ``gyro_pw`` and ``accel_pw`` (3,) rad and m/s per count in log axes (or None),
    ``overrides`` (scenario keys that replaced a header value) and the header."""

    dt: float | None
    lla: np.ndarray
    g: float
    gyro_pw: np.ndarray | None
    accel_pw: np.ndarray | None
    overrides: list
    header: PsinsHeader | None


def resolve(cfg, header):
    """Values the scenario leaves to the PSINS header: dt, site, pulse weights, g."""
    h = vars(header) if header else {}
    g = cfg.g_unit or h.get("g_mps2") or G0
    overrides = [
        k
        for k, v in (("accel.g_mps2", cfg.g_unit), ("log.sample_rate_hz", cfg.dt))
        if header and v is not None
    ]
    lla = []
    for key, value, scale in zip(
        ("lat_deg", "lon_deg", "height_m"), cfg.site, (DEG, DEG, 1.0), strict=True
    ):
        if value is not None and header:
            overrides.append(f"site.{key}")
        lla.append(value if value is not None else h[key] * scale)
    pws = {}
    for key, sensor, hkey, scale in (
        ("gyro.pulse_weight_arcsec", cfg.gyro, "gyro_pulse_arcsec", ARCSEC),
        ("accel.pulse_weight_ug_s", cfg.accel, "accel_pulse_ug_s", 1e-6),
    ):
        name = key.split(".")[0]
        pw = sensor.pulse_weight
        if pw is not None and header:
            overrides.append(key)
        if pw is None and sensor.counts:
            pw = np.asarray(h[hkey], dtype=float) * scale
        pws[name] = None if pw is None else pw * (g if sensor.per_g else 1.0)
    return Resolved(
        cfg.dt or h.get("dt_s"), np.array(lla), g, pws["gyro"], pws["accel"], overrides, header
    )


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
            what = (
                "goes back or repeats"
                if step[r] <= 0
                else "has a gap"
                if step[r] > GAP_FACTOR * dt
                else "steps too short"
            )
            raise InputError(
                f"time {what}: {t[r]:.9g} s, {step[r]:.6g} s after {before}; expected steps "
                f"of {dt:.6g} s (between {SHORT_FACTOR} and {GAP_FACTOR} sample intervals)",
                source=self.source,
                key=self.key,
                line=block.line(r),
            )
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
        raise InputError(
            f"{_row(block, r)}got {block.values[r, j]}; expected a finite number",
            source=source,
            key=keys[j],
            line=block.line(r),
        )


def _axis_map(mat_bl):
    """The signed permutation ``mat_bl`` as (log column, sign) per body axis."""
    return _axis_map_of(np.asarray(mat_bl, dtype=float).tobytes())


@functools.lru_cache(maxsize=16)
def _axis_map_of(key):
    """:func:`_axis_map` of the matrix with these bytes, found once (six flatnonzero
    per block and sensor were 4 ns a row)."""
    mat_bl = np.frombuffer(key).reshape(3, 3)
    return tuple(
        (int(np.flatnonzero(row)[0]), float(row[np.flatnonzero(row)[0]])) for row in mat_bl
    )


def _increments(block, c0, sensor, pw, dt, mat_bl, keys, source, g=1.0):
    """Body-frame increments of a block: int64 counts or SI floats, and SI floats.

    ``g`` (m/s^2) is the log's g unit: a float column in a multiple of g
    (``sensor.per_g``) is multiplied by it (pulse weights ``pw`` already are).

    ``mat_bl`` is a signed permutation, so each body axis is one log column times a
    sign (and the scale): done element-wise, bit for bit what ``values @ mat.T`` gives
    (its two other terms are exact zeros; the sum starts at +0, so a zero comes out +0).
    """
    values = block.values[:, c0 : c0 + 3]
    axes = _axis_map(mat_bl)
    if sensor.counts:
        frac = values != np.rint(values)
        if frac.any():
            r, j = np.argwhere(frac)[0]
            raise InputError(
                f"{_row(block, r)}got {values[r, j]}; expected an integer pulse count",
                source=source,
                key=keys[c0 + j],
                line=block.line(r),
            )
        stored = np.empty(values.shape, dtype=np.int64)
        for i, (j, sign) in enumerate(axes):
            np.multiply(values[:, j], sign, out=stored[:, i], casting="unsafe")
        return stored, stored * (np.abs(mat_bl) @ pw)
    scale = (
        sensor.factor * (g if sensor.per_g else 1.0) * (dt if sensor.quantity == "rate" else 1.0)
    )
    si = np.empty(values.shape)
    for i, (j, sign) in enumerate(axes):
        np.multiply(values[:, j], sign * scale, out=si[:, i])
    si += 0.0
    return si, si


@dataclass(frozen=True)
class LogChunk:
    """Rows of the log: the :class:`~inins.core.records.TableChunk` in SI, body axes
    (encoder readings when the log has table angles, else none), and the IMU rows as
    stored: int pulse counts (body axes) for a counting sensor, else the SI floats."""

    table: TableChunk
    stored_dtheta: np.ndarray
    stored_dv: np.ndarray


@dataclass(frozen=True)
class LogExtent:
    """What reading found: ``n`` samples, ``t0``, ``dt`` (s), ``time_span`` (first and
    last time of the time column, or None) and ``rows_per_s`` read."""

    n: int
    t0: float
    dt: float
    time_span: tuple | None
    rows_per_s: float


class LogReader:
    """Read, check and convert a log chunk by chunk.

    ``resolved`` is known on opening; ``dt`` after the first chunk; ``extent``
    after :meth:`chunks` is exhausted.
    """

    def __init__(self, cfg):
        self.cfg = cfg
        self._blocks, self.size, header, self._keys = open_log(cfg)
        self.resolved = resolve(cfg, header)
        self.dt = self.resolved.dt
        self.extent = None
        self.n_angles = len(cfg.gimbals) if cfg.angle_cols is not None else 0

    def chunks(self, progress=None):
        """Yield :class:`LogChunk` s; ``progress(done, total)`` after each."""
        cfg, res, keys = self.cfg, self.resolved, self._keys
        source = str(cfg.path)
        has_time = cfg.time is not None
        g0, a0 = int(has_time), int(has_time) + 3
        timecheck = _TimeCheck(source, "log.columns.time")
        n, start = 0, time.perf_counter()
        for block in self._blocks():
            _finite(block, keys, source)
            t = block.values[:, 0] * cfg.time_scale if has_time else None
            if self.dt is None:
                if t.size < 2:
                    raise InputError(
                        "need at least 2 rows to find the sample interval; set log.sample_rate_hz",
                        source=source,
                    )
                # the median step, its rate rounded to 9 digits (undoes the float error of
                # differences of large times: 1000.2 - 1000.1 = 0.09999999999990905)
                step = float(np.median(np.diff(t[:1001])))
                if not step > 0:
                    raise InputError(
                        f"the time column does not increase (median step {step:g}); "
                        "is it the time?",
                        source=source,
                        key="log.columns.time",
                    )
                self.dt = 1.0 / float(f"{1.0 / step:.9g}")
            dt = self.dt
            if has_time:
                timecheck(block, t, dt)
            stored_g, dtheta = _increments(
                block, g0, cfg.gyro, res.gyro_pw, dt, cfg.mat_bl, keys, source
            )
            stored_a, dv = _increments(
                block, a0, cfg.accel, res.accel_pw, dt, cfg.mat_bl, keys, source, res.g
            )
            for name, stored, sensor in (
                ("dtheta", stored_g, cfg.gyro),
                ("dv", stored_a, cfg.accel),
            ):
                if sensor.counts and np.abs(stored).max(initial=0) > np.iinfo(np.int32).max:
                    raise InputError(
                        f"{name} counts overflow int32 in the rows from {block.where(0)}",
                        source=source,
                    )
            angles = block.values[:, a0 + 3 :] * cfg.angle_scale
            if not has_time:  # the end of each sample interval
                t = np.arange(n + 1, n + 1 + len(block.values)) * dt
            yield LogChunk(
                TableChunk(n, dtheta, dv, t, angles),
                stored_g.astype(np.int32) if cfg.gyro.counts else stored_g,
                stored_a.astype(np.int32) if cfg.accel.counts else stored_a,
            )
            n += len(block.values)
            if progress is not None:
                progress(block.done, self.size)
        if n < 2:
            raise InputError(f"the log has {n} data rows; expected a record", source=source)
        elapsed = time.perf_counter() - start
        span = (timecheck.first, timecheck.last) if has_time else None
        if res.header:
            t0 = res.header.t0_s
        elif has_time:
            t0 = span[0] - (self.dt if cfg.time_marks == "end" else 0.0)
        else:
            t0 = 0.0
        self.extent = LogExtent(n, t0, self.dt, span, n / max(elapsed, 1e-9))
