"""The recorded-solution layout: a GNSS solution file joined to an IMU log (HDF5).

``import-flight`` with ``format: solution`` writes it; ``run-ekf``'s ``post:`` section
reads it back (``imu.format: recorded`` and ``gnss.format: recorded``), so a drive
imported once runs through the loosely coupled filter exactly as from its source files.
A layout of its own (``layout`` = ``"inins-recorded-solution"``, ``layout_version`` 1)
beside the recorded-flight layout of :mod:`inins.io.flight_layout`, whose raw-observation
files are unchanged (their version stays 1 and they read as before). Datasets, SI:

``solution/time`` (m,) s, ``solution/lla`` (m, 3) rad, rad, m, ``solution/sigma_ned``
(m, 3) m, ``solution/vel_ned`` (m, 3) m/s (NaN: none), ``solution/sigma_vel`` (m, 3)
m/s, ``solution/q`` (m,) quality flag, ``solution/line`` (m,) 1-based line of the
source; ``imu/time`` (n,) s on the log's own axis, ``imu/gyro`` (n, 3) rad/s,
``imu/accel`` (n, 3) m/s^2 in body axes (forward, right, down), ``imu/odometer`` (n,)
m/s when the log has one. Attribute ``source_solution`` and ``source_imu``: the files
they came from (messages of later checks name them with the row).
"""

from pathlib import Path

import h5py
import numpy as np

from inins.exceptions import InputError
from inins.io import imu_checks
from inins.io.imu_files import ImuRates
from inins.io.solution_checks import RowNames
from inins.io.solution_files import checked

LAYOUT = "inins-recorded-solution"
LAYOUT_VERSION = 1

SOLUTION = (
    ("time", "s", "GNSS time of each solution epoch"),
    ("lla", "rad, rad, m", "latitude, longitude, ellipsoidal height"),
    ("sigma_ned", "m", "position 1-sigma north, east, down"),
    ("vel_ned", "m/s", "velocity north, east, down (NaN: not in the file)"),
    ("sigma_vel", "m/s", "velocity 1-sigma north, east, down"),
    ("q", "", "quality flag (RTKLIB Q: 1 fix, 2 float, 5 single)"),
    ("line", "", "1-based line of the epoch in the source file"),
)
IMU = (
    ("time", "s", "sample time on the IMU log's own axis"),
    ("gyro", "rad/s", "angular rate, body axes"),
    ("accel", "m/s^2", "specific force, body axes"),
)


def solution_arrays(sol, imu):
    """``{path: (value, unit, description)}`` of the layout (module docstring)."""
    out = {f"solution/{k}": (np.asarray(getattr(sol, k)), u, d) for k, u, d in SOLUTION}
    out |= {f"imu/{k}": (np.asarray(getattr(imu, k)), u, d) for k, u, d in IMU}
    if imu.odometer is not None:
        out["imu/odometer"] = (np.asarray(imu.odometer), "m/s", "odometer speed")
    return out


def solution_attrs(sol, imu):
    """Root attributes of the layout."""
    return {
        "layout": LAYOUT,
        "layout_version": LAYOUT_VERSION,
        "source_solution": str(sol.path),
        "source_imu": str(imu.path),
    }


def _open(path):
    path = Path(path)
    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        raise InputError(f"not a readable HDF5 file: {exc}", source=str(path)) from exc
    if f.attrs.get("layout") != LAYOUT:
        got = f.attrs.get("layout")
        f.close()
        raise InputError(
            f"not a recorded-solution file (layout attribute {got!r}, expected {LAYOUT!r}; "
            "write one with import-flight format: solution)",
            source=str(path),
            key="/",
        )
    version = f.attrs.get("layout_version")
    if version != LAYOUT_VERSION:
        f.close()
        shown = version.item() if isinstance(version, np.generic) else version
        raise InputError(
            f"layout_version {shown!r} is not {LAYOUT_VERSION}, the version this inins reads",
            source=str(path),
            key="/layout_version",
        )
    return f


def _get(f, key, path, ndim):
    """A numeric dataset of ``ndim`` dimensions (3 columns when 2-D), read whole; values
    are checked by the rules of the readers, which name the row."""
    if key not in f:
        raise InputError("dataset missing", source=str(path), key=key)
    if not isinstance(f[key], h5py.Dataset):
        raise InputError("not a dataset", source=str(path), key=key)
    value = np.asarray(f[key][()])
    if value.dtype.kind not in "fiu":
        raise InputError(f"holds {value.dtype} values, not real numbers", source=str(path), key=key)
    if value.ndim != ndim or (ndim == 2 and value.shape[1] != 3):
        shape = "(n, 3)" if ndim == 2 else "(n,)"
        raise InputError(f"has shape {value.shape}, expected {shape}", source=str(path), key=key)
    return value.astype(float)


_SOLUTION_NDIM = {"time": 1, "lla": 2, "sigma_ned": 2, "vel_ned": 2, "sigma_vel": 2, "q": 1}


def read_recorded_solution(path):
    """The :class:`~inins.io.solution_files.SolutionFile` of a recorded-solution file:
    every epoch meets the rules of :mod:`inins.io.solution_checks` (the dataset and its
    0-based row named)."""
    with _open(path) as f:
        v = {k: _get(f, f"solution/{k}", path, _SOLUTION_NDIM.get(k, 1)) for k, _, _ in SOLUTION}
    m = v["time"].shape[0]
    for k, value in v.items():
        if value.shape[0] != m:
            raise InputError(
                f"has {value.shape[0]} rows, solution/time has {m}",
                source=str(path),
                key=f"solution/{k}",
            )
    keys = {
        "time": "solution/time",
        "position": "solution/lla",
        "sigma": "solution/sigma_ned",
        "velocity": "solution/vel_ned",
        "sigma_vel": "solution/sigma_vel",
        "q": "solution/q",
    }
    rows = RowNames(str(path), base=0, keys=keys)
    line = v["line"]
    with np.errstate(invalid="ignore"):
        bad = np.flatnonzero(~((line >= 1) & (line < 2**31) & (line % 1 == 0)))
    if bad.size:
        raise InputError(
            f"row {int(bad[0])}: {line[bad[0]]:.6g} is not a line number (an integer >= 1)",
            source=str(path),
            key="solution/line",
        )
    return checked(
        str(path), v["time"], v["lla"], v["sigma_ned"], v["vel_ned"], v["sigma_vel"], v["q"],
        line.astype(np.int64), rows,
    )  # fmt: skip


def read_recorded_imu(path):
    """The :class:`ImuRates` of a recorded-solution file: the rules of
    :mod:`inins.io.imu_checks` (the dataset and its 0-based row named)."""
    with _open(path) as f:
        v = {k: _get(f, f"imu/{k}", path, 1 if k == "time" else 2) for k, _, _ in IMU}
        odo = _get(f, "imu/odometer", path, 1) if "imu/odometer" in f else None
    n = v["time"].shape[0]
    for k, value in (*v.items(), ("odometer", odo)):
        if value is not None and value.shape[0] != n:
            raise InputError(
                f"has {value.shape[0]} rows, imu/time has {n}", source=str(path), key=f"imu/{k}"
            )
    keys = {k: f"imu/{k}" for k in ("time", "gyro", "accel", "odometer")}
    rows = RowNames(str(path), base=0, keys=keys)
    imu = ImuRates(str(path), v["time"], v["gyro"], v["accel"], odo, rows)
    imu_checks.check_rates(imu, rows)
    return imu
