"""The rules every IMU log of rates meets, checked once as it is read.

:func:`check_rates` is called by every reader of an IMU log for the loosely coupled
filter (a CSV of rates, a .mat array of increments, the recorded-solution layout), so
that ``import-flight format: solution`` and ``run-ekf post:`` refuse the same logs
(spec §10a). Refused, as bad input naming the file and the line (text), row
(.mat, 1-based) or dataset and row (HDF5, 0-based):

- NaN or infinity anywhere (time, gyro, accelerometer, odometer);
- time that does not increase (a repeated or swapped sample);
- a median sample interval outside :data:`INTERVAL_S` (10 Hz - 20 kHz): no strapdown
  IMU logs a vehicle's motion slower than 10 Hz, and a rate far outside the band is a
  time column in the wrong unit (the message names the likely one);
- a gap: a step longer than :data:`GAP_INTERVALS` median intervals and, for rates
  (which are interpolated onto the filter's grid), longer than :data:`GAP_S` as well;
  an increment cannot be interpolated, so an increment log has no such allowance;
- a rate no IMU measures (:data:`MAX_GYRO_RADPS`, :data:`MAX_ACCEL_MPS2`);
- an axis that reads one value on every row (stuck, or a column of zeros);
- saturation: an axis holding its largest magnitude for :data:`SATURATION_RUN` or more
  consecutive samples (the sensor's range reached: the motion beyond it is lost).

The checks against the GNSS solution (units and axes at rest and in the turns) are
:mod:`inins.io.imu_units`.
"""

import numpy as np

from inins.exceptions import InputError

INTERVAL_S = (5e-5, 0.1)
"""Median sample interval accepted (s): 20 kHz to 10 Hz."""
GAP_INTERVALS = 2.5
"""A step longer than this many median intervals is a gap (samples lost)..."""
GAP_S = 0.1
"""... and, for a log of rates, also longer than this (s): linear interpolation of the
rates over 0.1 s misses nothing a vehicle does; over a minute it invents the motion."""
MAX_GYRO_RADPS = 100.0
"""Largest angular rate accepted (rad/s, 5,730 deg/s; as the flight layout's rule)."""
MAX_ACCEL_MPS2 = 2000.0
"""Largest specific force accepted (m/s^2, 204 g)."""
MAX_SPEED_MPS = 1e3
"""Largest odometer speed accepted (m/s)."""
SATURATION_RUN = 5
"""Consecutive samples at an axis's largest magnitude that mean saturation."""

_UNIT_HINTS = (
    (1e-3, "time in milliseconds read as seconds (time_scale_s: 0.001)?"),
    (1e-6, "time in microseconds read as seconds (time_scale_s: 1e-6)?"),
    (1e3, "time in seconds read as milliseconds (time_scale_s: 1)?"),
    (1e6, "time in seconds read as microseconds (time_scale_s: 1)?"),
    (1e-9, "time in nanoseconds read as seconds (time_scale_s: 1e-9)?"),
)


def _what(value):
    if np.isnan(value):
        return "NaN"
    if np.isinf(value):
        return "infinity" if value > 0 else "-infinity"
    return f"{value:.6g}"


def _interval_hint(dt):
    for factor, hint in _UNIT_HINTS:
        if INTERVAL_S[0] <= dt * factor <= INTERVAL_S[1]:
            return f": {hint}"
    return ": the time column or its scale is wrong"


def check_time(time, rows, increments=False):
    """Finite, increasing time at a plausible rate without gaps (module docstring).

    Parameters
    ----------
    time : ndarray (n,), s
    rows : :class:`inins.io.solution_checks.RowNames`
        How rows are named (rule ``time``).
    increments : bool
        The log holds increments (no allowance for interpolation across a gap).

    Returns
    -------
    float
        The median interval (s).
    """
    if time.size < 2:
        raise InputError(
            f"{time.size} IMU samples, at least 2 needed", source=rows.source,
            key=rows.keys.get("time"),
        )  # fmt: skip
    bad = np.flatnonzero(~np.isfinite(time))
    if bad.size:
        raise rows.error(bad[0], f"time is {_what(time[bad[0]])}", "time")
    step = np.diff(time)
    back = np.flatnonzero(step <= 0.0)
    if back.size:
        i = int(back[0]) + 1
        raise rows.error(
            i,
            f"time {time[i]:.6f} s does not increase (previous sample {time[i - 1]:.6f} s): "
            "samples duplicated or out of order",
            "time",
        )
    dt = float(np.median(step))
    if not INTERVAL_S[0] <= dt <= INTERVAL_S[1]:
        raise InputError(
            f"median sample interval {dt:.4g} s ({1.0 / dt:.4g} Hz) is outside "
            f"{INTERVAL_S[0]:g}-{INTERVAL_S[1]:g} s (20 kHz - 10 Hz){_interval_hint(dt)}",
            source=rows.source,
            key=rows.keys.get("time"),
        )
    limit = GAP_INTERVALS * dt if increments else max(GAP_INTERVALS * dt, GAP_S)
    gap = np.flatnonzero(step > limit)
    if gap.size:
        i = int(gap[0]) + 1
        raise rows.error(
            i,
            f"gap of {step[i - 1]:.4g} s in the IMU time after {time[i - 1]:.6f} s "
            f"({gap.size} gaps longer than {limit:.3g} s; median interval {dt:.4g} s): "
            "samples lost, refused rather than bridged (split the log)",
            "time",
        )
    return dt


def check_values(values, rows, rule, what, limit, unit):
    """Finite values within ``limit`` (absolute) on every row; no stuck or saturated axis.

    Parameters
    ----------
    values : ndarray (n, k)
    rows : RowNames
    rule : str
        The rule name for :class:`~inins.io.solution_checks.RowNames` (``gyro``,
        ``accel``, ``odometer``).
    what : sequence of str
        The name of each column ("gyro x", ...).
    limit : float
    unit : str
    """
    finite = np.isfinite(values)
    bad = np.flatnonzero(~finite.all(axis=1))
    if bad.size:
        i = int(bad[0])
        j = int(np.flatnonzero(~finite[i])[0])
        more = f" ({bad.size - 1} more rows like it)" if bad.size > 1 else ""
        raise rows.error(i, f"{what[j]} is {_what(values[i, j])}{more}", rule)
    big = np.abs(values) > limit
    bad = np.flatnonzero(big.any(axis=1))
    if bad.size:
        i = int(bad[0])
        j = int(np.flatnonzero(big[i])[0])
        raise rows.error(
            i,
            f"{what[j]} reads {values[i, j]:.6g} {unit}, beyond any IMU ({limit:g} {unit}): "
            "a unit or column wrong?",
            rule,
        )
    if values.shape[0] < 2:
        return
    for j in range(values.shape[1]):
        x = values[:, j]
        if np.all(x == x[0]):
            raise InputError(
                f"{what[j]} reads {x[0]:.6g} {unit} on every one of the {x.size} rows: a "
                "stuck or missing axis (or the wrong column)",
                source=rows.source,
                key=rows.keys.get(rule, rule),
            )
        _saturation(x, rows, rule, what[j], unit)


def _saturation(x, rows, rule, what, unit):
    peak = np.abs(x).max()
    at = np.abs(x) == peak
    if np.count_nonzero(at) < SATURATION_RUN:
        return
    edges = np.diff(np.concatenate([[0], at.astype(np.int8), [0]]))
    starts, stops = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    longest = int(np.argmax(stops - starts))
    run = int(stops[longest] - starts[longest])
    if run >= SATURATION_RUN:
        raise rows.error(
            starts[longest],
            f"{what} holds its largest magnitude {peak:.6g} {unit} for {run} consecutive "
            f"samples ({np.count_nonzero(at)} in all): saturated, the motion beyond the "
            "sensor's range is lost",
            rule,
        )


def check_rates(imu, rows, increments=False):
    """Every rule of the module docstring on an :class:`~inins.io.imu_files.ImuRates`.

    Returns
    -------
    float
        The median sample interval (s).
    """
    dt = check_time(np.asarray(imu.time, float), rows, increments)
    check_values(imu.gyro, rows, "gyro", ("gyro x", "gyro y", "gyro z"), MAX_GYRO_RADPS, "rad/s")
    check_values(
        imu.accel, rows, "accel", ("accel x", "accel y", "accel z"), MAX_ACCEL_MPS2, "m/s^2"
    )
    if imu.odometer is not None:
        odo = np.asarray(imu.odometer, float)[:, None]
        finite = np.isfinite(odo[:, 0])
        bad = np.flatnonzero(~finite | (np.abs(np.where(finite, odo[:, 0], 0)) > MAX_SPEED_MPS))
        if bad.size:
            raise rows.error(
                bad[0],
                f"odometer speed {_what(odo[bad[0], 0])} m/s is not a speed "
                f"(finite, within {MAX_SPEED_MPS:g} m/s)",
                "odometer",
            )
    return dt
