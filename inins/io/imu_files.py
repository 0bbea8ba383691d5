"""IMU logs for the loosely coupled filter: a CSV of rates and a .mat array of increments.

Both readers return an :class:`ImuRates` in SI units and body axes (forward, right,
down after the axis map), checked by :func:`inins.io.imu_checks.check_rates` (NaN,
time order, rate, gaps, impossible values, stuck and saturated axes: bad input naming
the file and line or row). The CSV is parsed a block of lines at a time, each line
bounded (:mod:`inins.io.textlines`): junk is refused at its first line, in memory
proportional to the rows before it.
"""

import math
from dataclasses import dataclass

import numpy as np

from inins.exceptions import InputError
from inins.io import imu_checks, matfile, textlines
from inins.io.solution_checks import RowNames

G0 = 9.80665
"""Standard gravity (m/s^2): the unit g of an accelerometer."""
AXIS = {
    "x": (0, 1.0),
    "-x": (0, -1.0),
    "y": (1, 1.0),
    "-y": (1, -1.0),
    "z": (2, 1.0),
    "-z": (2, -1.0),
}
"""IMU axis name -> (index, sign)."""
BLOCK = 65536
"""Lines parsed at a time."""


@dataclass(frozen=True, eq=False)
class ImuRates:
    """An IMU log of rates: ``time`` (n,) s on the log's own axis, ``gyro`` (n, 3) rad/s,
    ``accel`` (n, 3) m/s^2, in body axes (forward, right, down) after the axis map;
    ``odometer`` (n,) m/s or None; ``rows`` names a row in messages
    (:class:`~inins.io.solution_checks.RowNames`, None: row ``i`` of the arrays)."""

    path: str
    time: np.ndarray
    gyro: np.ndarray
    accel: np.ndarray
    odometer: np.ndarray | None = None
    rows: RowNames | None = None

    def row_names(self):
        """The :class:`RowNames` of the log (dataset-style rows when none were given)."""
        return self.rows or RowNames(self.path, base=0)


def axis_map(axes):
    """``(index (3,), sign (3,))`` of an axis map, body x, y, z = ``sign * imu[index]``.

    Raises
    ------
    InputError
        An unknown name, an axis named twice, or a mirror image (a left-handed map).
    """
    try:
        index = [AXIS[a][0] for a in axes]
        sign = np.array([AXIS[a][1] for a in axes])
    except (KeyError, TypeError):
        raise InputError(
            f"axes {list(axes)}: each must be one of {', '.join(AXIS)}", key="axes"
        ) from None
    if sorted(index) != [0, 1, 2]:
        raise InputError(f"axes {list(axes)} do not name x, y and z once each", key="axes")
    m = np.zeros((3, 3))
    m[[0, 1, 2], index] = sign
    if np.linalg.det(m) < 0:
        raise InputError(
            f"axes {list(axes)} are a mirror image (left-handed): body x, y, z must be a "
            "rotation of the IMU axes (change the sign of one axis)",
            key="axes",
        )
    return index, sign


def _parse_block(block, width, path):
    """(k, width) floats of ``[(line, text), ...]``; the first bad line named.

    numpy's compiled text reader first (``numpy.loadtxt``: each field read as ``float``
    reads it, or refused: it takes a subset of what ``float`` takes, no comments, no
    quotes); a block it refuses is read again field by field, which names the line."""
    try:
        a = np.loadtxt([text for _, text in block], delimiter=",", comments=None, ndmin=2)
        if a.shape[1] == width:
            return a
    except ValueError:
        pass
    try:
        a = np.array([text.split(",") for _, text in block], dtype=float)
        if a.ndim == 2 and a.shape[1] == width:
            return a
    except ValueError:
        pass
    for n, text in block:  # name the line
        parts = text.split(",")
        if len(parts) != width:
            raise InputError(f"expected {width} fields, got {len(parts)}", source=path, line=n)
        for p in parts:
            try:
                float(p)
            except ValueError:
                raise InputError(f"not a number: {p.strip()[:40]!r}", source=path, line=n) from None
    raise InputError("unreadable rows", source=path, line=block[0][0])


def read_csv_numbers(path, what="a CSV of numbers", header=None):
    """``(array (n, k), line (n,))`` of a numeric CSV (blank lines skipped); with a list
    ``header`` its first line is a header row of column names, stripped, stored there."""
    path = str(path)
    parts, numbers, block, width = [], [], [], None
    for n, text in textlines.lines(path, what=what):
        if not text.strip():
            continue
        if header is not None and width is None:
            header.extend(name.strip() for name in text.split(","))
            width = len(header)
            continue
        if width is None:
            width = len(text.split(","))
        block.append((n, text))
        if len(block) == BLOCK:
            parts.append(_parse_block(block, width, path))
            numbers.append([k for k, _ in block])
            block = []
    if block:
        parts.append(_parse_block(block, width, path))
        numbers.append([k for k, _ in block])
    if not parts:
        return np.zeros((0, 0)), np.zeros(0, np.int64)
    return np.concatenate(parts), np.concatenate(numbers).astype(np.int64)


def _column(index, width, key, path):
    if not 0 <= index < width:
        raise InputError(
            f"column {index} is outside the {width} fields of a row (0-based)", source=path,
            key=key,
        )  # fmt: skip
    return index


def _named(columns, header, key, path):
    """Column names of the header row (and 0-based indices) as indices; an unknown name
    is bad input naming the file, its header line and ``key``."""
    out = []
    for c in columns:
        if isinstance(c, str):
            if c not in header:
                raise InputError(
                    f"column {c!r} not in the header {header}", source=path, line=1, key=key
                )
            c = header.index(c)
        out.append(int(c))
    return out


def read_imu_rates_csv(
    path,
    accel_columns,
    gyro_columns,
    time_column,
    time_scale,
    accel_unit,
    gyro_unit,
    axes,
    odometer_column=None,
    odometer_scale=1.0,
):
    """Read a numeric CSV of IMU rates (one sample a row).

    Columns are 0-based indices, or names of a header row: where any column is given
    by name the file's first line is that header row. ``axes``: for body x, y, z the IMU
    axis (``"-x"``: minus IMU x). Bad input: an unknown column name, rows with the wrong
    number of fields or non-numbers, a column outside the row, and the rules of
    :mod:`inins.io.imu_checks` (file and line named).
    """
    path = str(path)
    index, sign = axis_map(axes)
    named = [*accel_columns, *gyro_columns, time_column, odometer_column]
    header = [] if any(isinstance(c, str) for c in named) else None
    a, line = read_csv_numbers(path, "an IMU log (CSV of numbers)", header)
    if header is not None:
        accel_columns = _named(accel_columns, header, "accel_columns", path)
        gyro_columns = _named(gyro_columns, header, "gyro_columns", path)
        time_column = _named([time_column], header, "time_column", path)[0]
        if odometer_column is not None:
            odometer_column = _named([odometer_column], header, "odometer_column", path)[0]
    if a.shape[0] < 2:
        last = int(line[-1]) if line.size else 1
        raise InputError(f"{a.shape[0]} IMU rows, at least 2 needed", source=path, line=last)
    width = a.shape[1]
    cols = {"accel_columns": accel_columns, "gyro_columns": gyro_columns}
    for key, c in cols.items():
        for j in c:
            _column(int(j), width, key, path)
    _column(int(time_column), width, "time_column", path)
    acc = a[:, list(accel_columns)] * (G0 if accel_unit == "g" else 1.0)
    gyro = a[:, list(gyro_columns)] * (math.pi / 180.0 if gyro_unit == "dps" else 1.0)
    odo = None
    if odometer_column is not None:
        odo = a[:, _column(int(odometer_column), width, "odometer_column", path)] * odometer_scale
    keys = {"time": "time_column", "gyro": "gyro_columns", "accel": "accel_columns"}
    rows = RowNames(path, line=line, keys=keys | {"odometer": "odometer_column"})
    imu = ImuRates(
        path, a[:, int(time_column)] * time_scale, gyro[:, index] * sign, acc[:, index] * sign,
        odo, rows,
    )  # fmt: skip
    imu_checks.check_rates(imu, rows)
    return imu


def read_imu_increments_mat(path, variable, gyro_columns, accel_columns, time_column, axes):
    """IMU increments (rad, m/s over each interval ending at its time tag) from a .mat
    array, as rates at the interval midpoints (:class:`ImuRates`); the rules of
    :mod:`inins.io.imu_checks` on the increments' time (no gap allowance) and rates,
    rows named 1-based."""
    path = str(path)
    index, sign = axis_map(axes)
    key = "post.imu.mat_variable"
    a = matfile.mat_array(path, variable, key, min_rows=2)
    t = matfile.columns(a, [time_column], path, variable, "post.imu.time_column")[:, 0]
    inc_g = matfile.columns(a, gyro_columns, path, variable, "post.imu.gyro_columns")
    inc_a = matfile.columns(a, accel_columns, path, variable, "post.imu.accel_columns")
    rows = RowNames(path, base=1, keys=dict.fromkeys(("time", "gyro", "accel"), variable))
    imu_checks.check_time(t, rows, increments=True)
    dt = np.diff(t, prepend=t[0] - np.median(np.diff(t)))
    with np.errstate(over="ignore", invalid="ignore"):  # beyond any IMU: refused below
        gyro, acc = (inc_g / dt[:, None])[:, index] * sign, (inc_a / dt[:, None])[:, index] * sign
    imu = ImuRates(path, t - 0.5 * dt, gyro, acc, None, rows)
    imu_checks.check_rates(imu, rows, increments=True)
    return imu
