"""The PSINS tightly coupled MATLAB file (``insgpseo_tc.mat``): IMU, raw GPS, ephemerides.

Arrays (read with :func:`scipy.io.loadmat`):

- ``imu`` (n, 7): [dtheta x y z (rad), dv x y z (m/s), t (s)].
- ``obss`` (m, 6): [receive time (GPS sow), PRN, C/A pseudorange (m), carrier
  phase (m, arbitrary offset), measurement sigma (m), NEGATIVE range rate (m/s;
  range rate = -column 6, not a Doppler in Hz)].
- ``ephs`` (32, >= 28): row k = PRN k in the PSINS ``ggpsvars`` layout
  (1-based columns): 1 PRN, 2 toc, 3-5 af0 af1 af2, 6 IODE, 7 Crs, 8 dn, 9 M0,
  10 Cuc, 11 e, 12 Cus, 13 sqrtA, 14 toe, 15 Cic, 16 Omega0, 17 Cis, 18 i0,
  19 Crc, 20 omega, 21 Omega_dot, 22 idot, 23 L2 codes, 24 week, 25 L2P flag,
  26 URA, 27 health (255 = empty row), 28 TGD.
- ``t0`` (1, 1): GPS seconds of week of IMU t = 0.

The result is a :class:`~inins.io.flight_layout.RecordedFlight`, the same
structure :func:`~inins.io.flight_layout.read_flight` returns.
"""

from pathlib import Path

import numpy as np

from inins.exceptions import InputError
from inins.io.flight_layout import EPHEMERIS_FIELDS, GnssRecord, ImuRecord, RecordedFlight

EPHS_COLUMNS = {
    "prn": 1,
    "toc": 2,
    "af0": 3,
    "af1": 4,
    "af2": 5,
    "iode": 6,
    "crs": 7,
    "delta_n": 8,
    "m0": 9,
    "cuc": 10,
    "e": 11,
    "cus": 12,
    "sqrt_a": 13,
    "toe": 14,
    "cic": 15,
    "omega0": 16,
    "cis": 17,
    "i0": 18,
    "crc": 19,
    "omega": 20,
    "omega_dot": 21,
    "idot": 22,
    "week": 24,
    "ura": 26,
    "health": 27,
    "tgd": 28,
}
"""1-based column of each ephemeris field in ``ephs`` (PSINS ``ggpsvars``)."""
EMPTY_HEALTH = 255


def _array(mat, name, columns, path, finite=None):
    if name not in mat:
        raise InputError(
            f"array {name!r} missing (expected imu, obss, ephs, t0)", source=str(path), key=name
        )
    try:
        value = np.asarray(mat[name], dtype=float)
    except (TypeError, ValueError):
        raise InputError(
            f"array {name!r} holds {np.asarray(mat[name]).dtype} values, expected numbers",
            source=str(path),
            key=name,
        ) from None
    if value.ndim == 2 and value.shape[0] == columns and value.shape[1] > columns:
        raise InputError(
            f"array {name!r} has shape {value.shape}, expected (n, {columns}): transposed?",
            source=str(path),
            key=name,
        )
    if value.ndim != 2 or value.shape[1] < columns:
        raise InputError(
            f"array {name!r} has shape {value.shape}, expected (n, {columns})",
            source=str(path),
            key=name,
        )
    if finite is not None and not np.isfinite(value[:, finite]).all():
        row = int(np.flatnonzero(~np.isfinite(value[:, finite]).all(axis=1))[0])
        raise InputError(
            f"row {row}: not a finite number where one is needed", source=str(path), key=name
        )
    return value


def _ephemeris(ephs):
    rows = ephs[ephs[:, EPHS_COLUMNS["health"] - 1] != EMPTY_HEALTH]
    out = np.zeros(len(rows), dtype=[(n, dt) for n, dt, _, _ in EPHEMERIS_FIELDS])
    for name, col in EPHS_COLUMNS.items():
        out[name] = (
            rows[:, col - 1]
            if name != "ura"
            else np.where(np.isfinite(rows[:, col - 1]), rows[:, col - 1], np.nan)
        )
    out["fit_interval"] = 4.0
    return out


def _gnss(obss, week, path):
    """Rows grouped into epochs by their receive time, which must not decrease (a row
    whose time is NaN is its own epoch, dropped by the edge checks)."""
    t = obss[:, 0]
    finite = np.flatnonzero(np.isfinite(t))
    back = np.flatnonzero(np.diff(t[finite]) < 0.0)
    if back.size:
        i = int(finite[back[0] + 1])
        raise InputError(
            f"row {i}: receive time {t[i]:.3f} s comes before row {int(finite[back[0]])} "
            f"({t[finite[back[0]]]:.3f} s): epochs out of order",
            source=str(path),
            key="obss",
        )
    new = np.ones(len(t), bool)
    new[1:] = ~(t[1:] == t[:-1])
    first = np.flatnonzero(new)
    m = len(obss)
    return GnssRecord(
        week=np.full(len(first), week, np.int64),
        time=t[first],
        start=np.append(first, m).astype(np.int64),
        prn=obss[:, 1],
        pseudorange=obss[:, 2],
        signal=np.ones(m, np.int8),
        range_rate=-obss[:, 5],
        sigma=obss[:, 4],
        snr=np.full(m, np.nan),
        carrier=obss[:, 3],
    )


def read_psins_tc(path):
    """Read the PSINS tc file into the recorded-flight structure.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    RecordedFlight
        ``gnss`` with range rate = -obss[:, 5] (m/s), signal L1 (C/A);
        ``imu`` with ``time`` = imu[:, 6]; ``imu_t0_sow`` = t0; the week from ``ephs``.

    Raises
    ------
    InputError
        Not a MATLAB file, an array missing, of the wrong shape or not numbers (named),
        or data breaking the rules of :mod:`inins.io.flight_checks` (row named).
    """
    import scipy.io  # scipy.io (and scipy.sparse under it) only where a .mat is read

    from inins.io.flight_checks import checked_flight

    path = Path(path)
    try:
        mat = scipy.io.loadmat(path)
    except (
        OSError,
        ValueError,
        TypeError,
        NotImplementedError,
        scipy.io.matlab.MatReadError,
    ) as exc:
        raise InputError(f"not a readable MATLAB v5 file: {exc}", source=str(path)) from exc
    imu = _array(mat, "imu", 7, path)
    obss = _array(mat, "obss", 6, path)
    # URA (column 26) may be NaN or inf in a valid row
    ephs = _array(mat, "ephs", 28, path, [c - 1 for c in EPHS_COLUMNS.values() if c != 26])
    t0 = _array(mat, "t0", 1, path, [0])
    if t0.size == 0:
        raise InputError("array 't0' is empty", source=str(path), key="t0")
    eph = _ephemeris(ephs)
    if len(eph) == 0:
        raise InputError("no ephemeris row (every health is 255)", source=str(path), key="ephs")
    if np.any(eph["week"] < 0):
        raise InputError("a GPS week (column 24) is negative", source=str(path), key="ephs")
    week = int(np.bincount(eph["week"]).argmax())
    flight = RecordedFlight(
        gnss=_gnss(obss, week, path),
        ephemeris=eph,
        imu=ImuRecord(time=imu[:, 6].copy(), dtheta=imu[:, 0:3].copy(), dv=imu[:, 3:6].copy()),
        source=f"PSINS tc file {path.name}",
        imu_t0_week=week,
        imu_t0_sow=float(t0[0, 0]),
        reference_pos_e=np.full(3, np.nan),
    )
    return checked_flight(flight, path)
