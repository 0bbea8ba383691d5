"""Raw-count IMU logs without a table, and calibrate-imu compensation files.

Raw logs: one text file per triad (plain or gzip), rows ``time (s), x, y, z counts``,
the layout of the imu_tk test data. Compensation files: the YAML text written by
``inins calibrate-imu`` (read back, as a scenario model, by
:func:`inins.commands._compensation.compensation_terms`: io loads no scenario).
"""

import gzip
from pathlib import Path

import numpy as np

from inins.exceptions import InputError


def _open_text(path):
    path = Path(path)
    if path.suffix == ".gz":
        return gzip.open(path, "rt", encoding="utf-8")
    return path.open("r", encoding="utf-8")


def read_counts(path):
    """``(time (n,), counts (n, 3))`` of one raw-count file; bad input names file and line."""
    try:
        with _open_text(path) as fh:
            rows = np.loadtxt(fh, dtype=float, ndmin=2)
    except OSError as exc:
        raise InputError(f"cannot read ({exc.strerror or exc})", source=str(path)) from None
    except ValueError as exc:
        raise InputError(f"not a table of numbers: {exc}", source=str(path)) from None
    if rows.shape[1] != 4:
        raise InputError(
            f"expected 4 columns (time, x, y, z counts), got {rows.shape[1]}", source=str(path)
        )
    bad = np.flatnonzero(~np.isfinite(rows).all(axis=1))
    if bad.size:
        raise InputError("not a finite number", source=str(path), line=int(bad[0]) + 1)
    step = np.diff(rows[:, 0])
    back = np.flatnonzero(step <= 0)
    if back.size:
        raise InputError(
            "time does not increase (repeated or going back)",
            source=str(path),
            line=int(back[0]) + 2,
        )
    gap = np.flatnonzero(step > 5.0 * np.median(step))
    if gap.size:
        raise InputError(
            f"gap in time: {step[gap[0]]:.4g} s between samples (median {np.median(step):.4g} s)",
            source=str(path),
            line=int(gap[0]) + 2,
        )
    return rows[:, 0], rows[:, 1:]


def read_raw_log(accel_file, gyro_file, saturation):
    """Both triads of a raw log: ``time, accel counts, gyro counts``.

    Raises
    ------
    InputError
        Unreadable or malformed files, rows that disagree in time, saturated counts
        (naming the file and line of the first).
    """
    t_a, acc = read_counts(accel_file)
    t_g, gyro = read_counts(gyro_file)
    if t_a.shape != t_g.shape or not np.allclose(t_a, t_g, rtol=0, atol=1e-6):
        raise InputError(
            f"the gyro rows do not match the accelerometer rows in time ({t_g.size} rows "
            f"against {t_a.size})",
            source=str(gyro_file),
        )
    lo, hi = saturation
    for path, counts in ((accel_file, acc), (gyro_file, gyro)):
        sat = np.flatnonzero(((counts <= lo) | (counts >= hi)).any(axis=1))
        if sat.size:
            raise InputError(
                f"saturated counts ({sat.size} rows at {lo:g} or {hi:g}, first at "
                f"t = {t_a[sat[0]]:.3f} s)",
                source=str(path),
                line=int(sat[0]) + 1,
                key="log.saturation_counts",
            )
    return t_a, acc, gyro


def compensation_text(payload):
    """YAML text of a compensation file (a plain dict)."""
    import yaml

    return "# calibrate-imu compensation file: apply with compensation: FILE\n" + yaml.safe_dump(
        payload, sort_keys=False, default_flow_style=None
    )
