"""The rules every GNSS solution epoch meets, checked once as it is read.

:func:`check_rows` is called by every reader of solution epochs (RTKLIB ``.pos``,
the named-column CSV, a ``.mat`` array, the recorded-solution layout), so that
``import-flight format: solution`` and ``run-ekf post:`` accept and refuse the same
files: import-flight never writes an epoch run-ekf would refuse (spec §10a).

A row that cannot be a position of a vehicle near the Earth is bad input
(:class:`~inins.exceptions.InputError`), naming the file and its line (text files),
its row (``.mat``: 1-based, as MATLAB counts) or the dataset and row (HDF5: 0-based, as
h5py counts). No row is dropped silently and none is repaired. The rules:

- time: finite and strictly increasing (a repeated or earlier epoch is refused);
- latitude within ±90 deg, longitude within -180..360 deg, ellipsoidal height within
  :data:`HEIGHT_M` (-1 km to 100 km), all finite;
- position 1-sigma finite, > 0 and at most :data:`SIGMA_M` (10 km) on each axis;
- velocity either absent (NaN on all three axes) or finite with every component within
  :data:`SPEED_MPS` (10 km/s, above any speed near the Earth); its 1-sigma, where the
  velocity is given with one, finite, > 0 and at most :data:`SIGMA_VEL_MPS`;
- quality flag an integer 0-7 (RTKLIB: 0 none, 1 fix, 2 float, 3 SBAS, 4 DGPS,
  5 single, 6 PPP, 7 dead reckoning).

The column roles of a CSV or .mat solution follow one rule too (:func:`role_problem`),
checked by the scenario and again by the readers.
"""

import numpy as np

from inins.exceptions import InputError

LAT_DEG = 90.0
"""Largest absolute latitude (deg)."""
LON_DEG = (-180.0, 360.0)
"""Longitude range accepted (deg): both the -180..180 and 0..360 conventions."""
HEIGHT_M = (-1000.0, 100e3)
"""Ellipsoidal height range (m): below the lowest land and geoid, up to 100 km."""
SIGMA_M = 1e4
"""Largest position 1-sigma (m): beyond it an epoch says nothing about a position."""
SPEED_MPS = 1e4
"""Largest velocity component (m/s): above the orbital speed, nothing near the Earth."""
SIGMA_VEL_MPS = 1e3
"""Largest velocity 1-sigma (m/s)."""
Q_FLAGS = (0, 7)
"""Quality flags of RTKLIB (0 none ... 7 dead reckoning)."""


class RowNames:
    """How a reader names row ``i`` in a message: a text file's line, or a row of an
    array (a .mat variable, an HDF5 dataset).

    Parameters
    ----------
    source : str
        The file.
    line : ndarray of int, (m,), optional
        1-based line of each row in a text file.
    base : int
        Number of the first row of an array: 1 for .mat (as MATLAB counts), 0 for HDF5
        (as h5py counts).
    keys : dict, optional
        Rule (``time``, ``position``, ``sigma``, ``velocity``, ``sigma_vel``, ``q``) ->
        the column, variable or dataset named with the row.
    """

    def __init__(self, source, line=None, base=0, keys=None):
        self.source, self.line, self.base = str(source), line, base
        self.keys = keys or {}

    def error(self, i, message, rule):
        """An :class:`InputError` about row ``i`` (0-based index into the arrays)."""
        i, key = int(i), self.keys.get(rule, rule)
        if self.line is not None:
            return InputError(message, source=self.source, line=int(self.line[i]), key=key)
        return InputError(f"row {i + self.base}: {message}", source=self.source, key=key)


def _what(value):
    if np.isnan(value):
        return "NaN"
    if np.isinf(value):
        return "infinity" if value > 0 else "-infinity"
    return f"{value:.10g}"


def _first(bad, rows, message, rule):
    index = np.flatnonzero(bad)
    if index.size:
        more = f" ({index.size - 1} more rows like it)" if index.size > 1 else ""
        raise rows.error(index[0], message(index[0]) + more, rule)


MIN_EPOCHS = 2
"""Fewest epochs of a solution file (one epoch cannot aid a drive)."""


def check_time(time, rows):
    """Time finite and strictly increasing, at least :data:`MIN_EPOCHS` epochs."""
    if time.size < MIN_EPOCHS:
        raise InputError(
            f"{time.size} solution epochs, at least {MIN_EPOCHS} needed",
            source=rows.source,
            key=rows.keys.get("time"),
        )
    _first(~np.isfinite(time), rows, lambda i: f"time is {_what(time[i])}", "time")
    step = np.diff(time)
    back = np.flatnonzero(step <= 0.0)
    if back.size:
        i = int(back[0]) + 1
        raise rows.error(
            i,
            f"time {time[i]:.3f} s does not increase (previous epoch {time[i - 1]:.3f} s): "
            "epochs duplicated or out of order",
            "time",
        )


def _radians_hint(deg):
    """A hint when degrees were read as radians (the value over 57.3 is a latitude)."""
    return " (degrees read as radians? angle_unit)" if np.abs(np.radians(deg)) <= 90.0 else ""


def check_position(lla, rows):
    """Latitude, longitude (rad) and height (m) of each row within the rules."""
    lat, lon, h = np.degrees(lla[:, 0]), np.degrees(lla[:, 1]), lla[:, 2]
    with np.errstate(invalid="ignore"):
        _first(
            ~(np.abs(lat) <= LAT_DEG),
            rows,
            lambda i: (
                f"latitude {_what(lat[i])} deg is not within ±{LAT_DEG:g} deg"
                + _radians_hint(lat[i])
            ),
            "position",
        )
        _first(
            ~((lon >= LON_DEG[0]) & (lon <= LON_DEG[1])),
            rows,
            lambda i: (
                f"longitude {_what(lon[i])} deg is not within {LON_DEG[0]:g}..{LON_DEG[1]:g} deg"
            ),
            "position",
        )
        _first(
            ~((h >= HEIGHT_M[0]) & (h <= HEIGHT_M[1])),
            rows,
            lambda i: (
                f"height {_what(h[i])} m is not within {HEIGHT_M[0]:g}..{HEIGHT_M[1]:g} m "
                "(ellipsoidal)"
            ),
            "position",
        )


def _sigma(values, rows, what, limit, unit, rule):
    with np.errstate(invalid="ignore"):
        ok = (values > 0.0) & (values <= limit)
    _first(
        ~ok.all(axis=1),
        rows,
        lambda i: (
            f"{what} sigma must be > 0 and at most {limit:g} {unit}: reads "
            f"{_what(values[i][~ok[i]][0])} {unit}"
        ),
        rule,
    )


def check_rows(sol, rows):
    """Every rule of the module docstring on the arrays of a solution (``time``, ``lla``,
    ``sigma_ned``, ``vel_ned``, ``sigma_vel``, ``q``, as
    :class:`~inins.io.solution_files.SolutionFile` holds them, ``q`` still as read);
    raises :class:`InputError` naming the first bad row."""
    check_time(np.asarray(sol.time, float), rows)
    check_position(np.asarray(sol.lla, float), rows)
    _sigma(np.asarray(sol.sigma_ned, float), rows, "position", SIGMA_M, "m", "sigma")
    vel, svel = np.asarray(sol.vel_ned, float), np.asarray(sol.sigma_vel, float)
    absent = np.isnan(vel).all(axis=1)
    with np.errstate(invalid="ignore"):
        wrong = ~absent & ~(np.abs(vel) <= SPEED_MPS).all(axis=1)
    _first(
        wrong,
        rows,
        lambda i: (
            f"velocity {', '.join(_what(v) for v in vel[i])} m/s: a component is not "
            f"finite or beyond {SPEED_MPS:g} m/s (absent: NaN on all three axes)"
        ),
        "velocity",
    )
    given = ~absent & ~np.isnan(svel).all(axis=1)
    if given.any():
        svel = np.where(given[:, None], svel, 1.0)
        _sigma(svel, rows, "velocity", SIGMA_VEL_MPS, "m/s", "sigma_vel")
    q = np.asarray(sol.q, float)
    with np.errstate(invalid="ignore"):
        bad_q = ~((q >= Q_FLAGS[0]) & (q <= Q_FLAGS[1]) & (q % 1 == 0))
    _first(
        bad_q,
        rows,
        lambda i: (
            f"quality flag {_what(q[i])} is not an integer {Q_FLAGS[0]}-{Q_FLAGS[1]} "
            "(RTKLIB Q: 1 fix, 2 float, 3 SBAS, 4 DGPS, 5 single, 6 PPP, 7 dead reckoning)"
        ),
        "q",
    )


CSV_ROLES = (
    "vel_u",
    "time",
    "lat",
    "lon",
    "height",
    "x",
    "y",
    "z",
    "sigma_n",
    "sigma_e",
    "sigma_d",
    "vel_n",
    "vel_e",
    "vel_d",
    "sigma_vn",
    "sigma_ve",
    "sigma_vd",
    "q",
)
"""Roles a CSV column can take (the scenario maps role -> column name)."""


def role_problem(columns, need_sigma):
    """What is wrong with a role -> column mapping, or None (one rule for the CSV and
    .mat readers and the scenario): known roles; ``time``; ``lat lon height`` or
    ``x y z``, complete and not both; ``sigma_n sigma_e sigma_d`` complete (required
    when ``need_sigma``); velocity ``vel_n vel_e`` with one of ``vel_d``/``vel_u``, or
    none; velocity sigmas complete and only with a velocity.

    Returns
    -------
    (role, message) or None
    """
    have = set(columns)
    for role in sorted(have):
        if role not in CSV_ROLES:
            return role, f"unknown role {role!r} (known: {', '.join(CSV_ROLES)})"
    if "time" not in have:
        return "time", "the time column is required"
    groups = (
        ("position", ("lat", "lon", "height"), ("x", "y", "z")),
        ("sigma", ("sigma_n", "sigma_e", "sigma_d"), None),
        ("velocity sigma", ("sigma_vn", "sigma_ve", "sigma_vd"), None),
    )
    for name, first, other in groups:
        for group in (first, other):
            if group and have & set(group) and not set(group) <= have:
                missing = sorted(set(group) - have)
                return missing[0], f"{name} columns incomplete: {', '.join(missing)} missing"
    if not ({"lat", "lon", "height"} <= have or {"x", "y", "z"} <= have):
        return "lat", "need lat, lon, height (or x, y, z ECEF) columns"
    if {"lat", "x"} <= have:
        return "x", "give lat, lon, height or x, y, z, not both"
    if need_sigma and "sigma_n" not in have:
        return "sigma_n", "the sigma_n, sigma_e, sigma_d columns are required"
    vel = have & {"vel_n", "vel_e", "vel_d", "vel_u"}
    if vel:
        if {"vel_d", "vel_u"} <= vel:
            return "vel_u", "give vel_d or vel_u, not both"
        missing = sorted({"vel_n", "vel_e"} - vel) or (
            [] if vel & {"vel_d", "vel_u"} else ["vel_d (or vel_u)"]
        )
        if missing:
            return missing[0], f"velocity columns incomplete: {', '.join(missing)} missing"
    elif "sigma_vn" in have:
        return "sigma_vn", "velocity sigma columns without velocity columns"
    return None
