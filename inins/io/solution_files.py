"""GNSS solution files for the loosely coupled filter: RTKLIB ``.pos`` and a named-column CSV.

Every reader (and the ``.mat`` one) returns a :class:`SolutionFile` in SI units: time as
GPS seconds since the GPS epoch (1980-01-06, no leap seconds), geodetic position (rad,
rad, m), NED 1-sigma (m), NED velocity (m/s) and its 1-sigma where the file has them,
the quality flag. Every row meets the rules of :mod:`inins.io.solution_checks`; every
problem is an :class:`inins.exceptions.InputError` naming the file and the line (or
column). Text is read a line at a time, each line parsed as it comes
(:mod:`inins.io.textlines`): junk is refused at its first line.

RTKLIB ``.pos`` (``rnx2rtkp``/``rtkpost`` output): ``%`` comment lines, the last of
which names the columns. Time is ``GPST`` (or ``UTC``: leap seconds added from the
date, :class:`SolutionFile` ``time_system``) as ``yyyy/mm/dd hh:mm:ss.sss`` or as
``week  seconds``; position as ``latitude(deg) longitude(deg) height(m)`` (or
``latitude(d'")`` is refused) or ``x-ecef(m) y-ecef(m) z-ecef(m)``; then ``Q`` (1 fix,
2 float, 3 SBAS, 4 DGPS, 5 single, 6 PPP), ``ns``, the sigmas ``sdn sde sdu`` (or
``sdx sdy sdz``) and their cross terms, ``age``, ``ratio``, and optionally
``vn ve vu`` (m/s) with ``sdvn sdve sdvu`` and cross terms. ECEF sigmas are rotated
to NED keeping the diagonal; the cross terms (``sdne`` ...) are not used.
"""

import array
import csv
import dataclasses
import datetime
import math
from dataclasses import dataclass

import numpy as np

from inins.core import earth
from inins.exceptions import InputError
from inins.io import matfile, solution_checks, textlines
from inins.io.imu_files import (  # noqa: F401 (the IMU readers, re-exported)
    G0,
    ImuRates,
    read_imu_increments_mat,
    read_imu_rates_csv,
)
from inins.io.solution_checks import CSV_ROLES, RowNames, role_problem  # noqa: F401

WEEK = 604800.0
"""Seconds in a GPS week."""
_GPS_EPOCH = datetime.date(1980, 1, 6)

Q_NAMES = {1: "fix", 2: "float", 3: "sbas", 4: "dgps", 5: "single", 6: "ppp"}
"""RTKLIB quality flags."""

_LLH = ("latitude(deg)", "longitude(deg)", "height(m)")
_XYZ = ("x-ecef(m)", "y-ecef(m)", "z-ecef(m)")
_KNOWN = set(_LLH + _XYZ) | {
    "Q",
    "ns",
    "sdn(m)",
    "sde(m)",
    "sdu(m)",
    "sdne(m)",
    "sdeu(m)",
    "sdun(m)",
    "sdx(m)",
    "sdy(m)",
    "sdz(m)",
    "sdxy(m)",
    "sdyz(m)",
    "sdzx(m)",
    "age(s)",
    "ratio",
    "vn(m/s)",
    "ve(m/s)",
    "vu(m/s)",
    "sdvn",
    "sdve",
    "sdvu",
    "sdvne",
    "sdveu",
    "sdvun",
    "vx-ecef(m/s)",
    "vy-ecef(m/s)",
    "vz-ecef(m/s)",
    "sdvx",
    "sdvy",
    "sdvz",
    "sdvxy",
    "sdvyz",
    "sdvzx",
}


@dataclass(frozen=True, eq=False)
class SolutionFile:
    """A GNSS solution file in SI units (module docstring); ``line`` (m,) 1-based lines;
    ``time_system`` ``gps``, or ``utc`` for UTC tags counted on the GPS grid (the leap
    seconds not yet added)."""

    path: str
    time: np.ndarray
    lla: np.ndarray
    sigma_ned: np.ndarray
    vel_ned: np.ndarray
    sigma_vel: np.ndarray
    q: np.ndarray
    line: np.ndarray
    time_system: str = "gps"

    def __len__(self):
        return self.time.size

    def select(self, mask):
        """The epochs where ``mask`` is True."""
        return SolutionFile(
            self.path,
            *(getattr(self, k)[mask] for k in ("time", "lla", "sigma_ned", "vel_ned")),
            self.sigma_vel[mask],
            self.q[mask],
            self.line[mask],
            self.time_system,
        )


def _ned_sigma(lla, sig_xyz):
    """Diagonal of ``M^T diag(s^2) M`` (``M`` = mat_en), (m, 3)."""
    m_en = earth.mat_en(lla[:, 0], lla[:, 1])
    return np.sqrt(np.einsum("kji,kj->ki", m_en**2, sig_xyz**2))


TEXT_KEYS = {
    "time": "time",
    "position": "latitude/longitude/height",
    "sigma": "sdn/sde/sdu",
    "velocity": "vn/ve/vu",
    "sigma_vel": "sdvn/sdve/sdvu",
    "q": "Q",
}
"""What a message about a rule of :mod:`inins.io.solution_checks` names in a text file."""


def checked(path, time, lla, sig, vel, svel, q, line, rows=None):
    """A :class:`SolutionFile` of the arrays after the rules of
    :mod:`inins.io.solution_checks` (``rows`` names a row; default: ``line`` of a text
    file); a velocity without its 1-sigma is kept as absent (NaN)."""
    rows = rows or RowNames(path, line=line, keys=TEXT_KEYS)
    sol = SolutionFile(str(path), time, lla, sig, vel, svel, q, np.asarray(line, np.int64))
    solution_checks.check_rows(sol, rows)
    vel = np.where(np.isfinite(svel).all(1)[:, None], vel, np.nan)
    return SolutionFile(
        sol.path, time, lla, sig, vel, svel, np.asarray(q).astype(np.int64), sol.line
    )


def _pos_time(r, path, n):
    """GPS seconds of a ``.pos`` row's time fields (calendar or week + seconds)."""
    try:
        if "/" in r[0]:
            y, mo, d = (int(v) for v in r[0].split("/"))
            hh, mm, ss = r[1].split(":")
            hh, mm, ss = int(hh), int(mm), float(ss)
            if not (0 <= hh < 24 and 0 <= mm < 60 and 0.0 <= ss < 60.0):
                raise ValueError
            days = (datetime.date(y, mo, d) - _GPS_EPOCH).days
            return days * 86400.0 + hh * 3600.0 + mm * 60.0 + ss
        week, sow = int(r[0]), float(r[1])
        if not (0 <= week and 0.0 <= sow < WEEK):
            raise ValueError
        return week * WEEK + sow
    except ValueError:
        raise InputError(
            f"bad time {r[0]} {r[1]} (yyyy/mm/dd hh:mm:ss.s or week seconds)", source=path, line=n
        ) from None


TIME_SYSTEMS = ("gps", "utc", "unix")
"""Time tags a solution file may have: GPS seconds since the GPS epoch; UTC seconds
counted on that grid (``.pos`` with a ``UTC`` header); Unix time (UTC seconds since
1970-01-01). A reader keeps UTC tags on the GPS grid (:attr:`SolutionFile.time_system`
``utc``); the leap seconds of their date are added by
:func:`inins.ekf.gnss_time.solution_on_gps_time`."""
UNIX_GPS_EPOCH_S = 315964800.0
"""Unix time of the GPS epoch 1980-01-06 00:00 UTC (s)."""


def _grid(time, system):
    """Tags of ``system`` counted from 1980-01-06 (s), and their scale (gps or utc)."""
    if system == "unix":
        return time - UNIX_GPS_EPOCH_S, "utc"
    return time, system


def _pos_header(path, n, names):
    if names[0] not in ("GPST", "UTC"):
        raise InputError(
            f"time system {names[0]!r}: only GPST and UTC are supported", source=path, line=n
        )
    for c in names[1:]:
        if c not in _KNOWN:
            raise InputError(f"unknown column {c!r}", source=path, line=n, key=c)
    return names[1:]


def _floats(parts, path, n):
    try:
        return [float(v) for v in parts]
    except ValueError:
        bad = next(v for v in parts if not _is_float(v))
        raise InputError(f"not a number: {bad[:40]!r}", source=path, line=n) from None


def _is_float(v):
    try:
        float(v)
    except ValueError:
        return False
    return True


def _pos_rows(path):
    """``(header line, columns, values (m, k), time (m,), lines (m,))`` of a .pos file,
    each row parsed as it is read."""
    header, cols, width, n, system = None, None, None, 0, "gps"
    values, times, lines = array.array("d"), array.array("d"), array.array("q")
    for n, text in textlines.lines(path, what="an RTKLIB .pos file"):
        s = text.strip()
        if not s:
            continue
        if s.startswith("%"):
            if header is None and ("GPST" in s or "UTC" in s or "JST" in s):
                header = n
                cols = _pos_header(path, n, s[1:].split())
                system = "utc" if s[1:].split()[0] == "UTC" else "gps"
                width = 2 + len(cols)
            continue
        if header is None:
            raise InputError("data before the column header line", source=path, line=n)
        r = s.split()
        if len(r) != width:
            raise InputError(f"expected {width} fields, got {len(r)}", source=path, line=n)
        times.append(_pos_time(r, path, n))
        values.extend(_floats(r[2:], path, n))
        lines.append(n)
    if header is None:
        raise InputError("no column header line (% GPST ...)", source=path, line=max(n, 1))
    if not times:
        raise InputError("no solution epochs", source=path, line=max(n, 1))
    m = len(times)
    return header, cols, np.frombuffer(values).reshape(m, -1), np.frombuffer(times), lines, system


def read_rtklib_pos(path):
    """Read an RTKLIB ``.pos`` solution file (module docstring) -> :class:`SolutionFile`."""
    path = str(path)
    hline, cols, values, time, lines, system = _pos_rows(path)
    col = {c: values[:, i] for i, c in enumerate(cols)}

    def need(*names_):
        for c in names_:
            if c not in col:
                raise InputError(f"missing column {c!r}", source=path, line=hline, key=c)
        return np.stack([col[c] for c in names_], -1)

    if _LLH[0] in col:
        llh = need(*_LLH)
        lla = np.column_stack([np.radians(llh[:, 0]), np.radians(llh[:, 1]), llh[:, 2]])
        sig = need("sdn(m)", "sde(m)", "sdu(m)")
    elif _XYZ[0] in col:
        lla = _llh_of_ecef(need(*_XYZ), path, lines)
        sig = _ned_sigma(lla, need("sdx(m)", "sdy(m)", "sdz(m)"))
    else:
        raise InputError(
            "no position columns (latitude(deg) or x-ecef(m))", source=path, line=hline
        )
    m = time.size
    vel = np.full((m, 3), np.nan)
    svel = np.full((m, 3), np.nan)
    if "vn(m/s)" in col:
        v = need("vn(m/s)", "ve(m/s)", "vu(m/s)")
        vel = v * np.array([1.0, 1.0, -1.0])
        if "sdvn" in col:
            svel = need("sdvn", "sdve", "sdvu")
    elif "vx-ecef(m/s)" in col:
        m_en = earth.mat_en(lla[:, 0], lla[:, 1])
        vel = np.einsum("kji,kj->ki", m_en, need("vx-ecef(m/s)", "vy-ecef(m/s)", "vz-ecef(m/s)"))
        if "sdvx" in col:
            svel = _ned_sigma(lla, need("sdvx", "sdvy", "sdvz"))
    _other_fields(col, path, np.asarray(lines))
    sol = checked(path, time, lla, sig, vel, svel, need("Q")[:, 0], np.asarray(lines))
    return dataclasses.replace(sol, time_system=system)


_OTHER_FIELDS = {
    "ns": (0.0, 999.0, True),
    "age(s)": (0.0, 1e6, False),
    "ratio": (0.0, 1000.0, False),
}
"""Bounds of the .pos fields the filter does not use: (low, high, integer)."""


def _other_fields(col, path, lines):
    """The .pos fields the filter does not use are still numbers of their kind: ``ns``
    an integer 0-999, ``age`` 0-1e6 s, ``ratio`` 0-1000, cross terms (``sdne`` ...)
    finite within ±:data:`~inins.io.solution_checks.SIGMA_M` (m or m/s)."""
    for name, values in col.items():
        if name in _OTHER_FIELDS:
            lo, hi, integer = _OTHER_FIELDS[name]
        elif name.startswith(("sdne", "sdeu", "sdun", "sdxy", "sdyz", "sdzx", "sdv")):
            lo, hi, integer = -solution_checks.SIGMA_M, solution_checks.SIGMA_M, False
        else:
            continue
        with np.errstate(invalid="ignore"):
            bad = ~((values >= lo) & (values <= hi) & ((values % 1 == 0) | (not integer)))
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            kind = "an integer " if integer else ""
            raise InputError(
                f"{name} {values[i]:.6g} is not {kind}within {lo:g}..{hi:g}",
                source=path,
                line=int(lines[i]),
                key=name,
            )


def _llh_of_ecef(xyz, path, line, rows=None):
    """Geodetic position of ECEF rows; a row that is no point near the Earth (non-finite,
    or within 6,000 km of its centre) is bad input naming its line or row."""
    with np.errstate(invalid="ignore"):
        r = np.linalg.norm(xyz, axis=1)
        bad = np.flatnonzero(~(np.isfinite(xyz).all(1) & (r > 6.0e6) & (r < 6.5e6)))
    if bad.size:
        i = int(bad[0])
        rows = rows or RowNames(path, line=np.asarray(line))
        raise rows.error(
            i,
            f"ECEF position {', '.join(f'{v:.6g}' for v in xyz[i])} m is {r[i] / 1e3:.6g} km "
            "from the Earth's centre: no point between 6,000 and 6,500 km",
            "position",
        )
    return earth.llh_from_ecef(xyz)


def _roles(columns, need_sigma, key):
    problem = role_problem(columns, need_sigma)
    if problem is not None:
        raise InputError(problem[1], key=f"{key}.{problem[0]}")


def _solution(path, get, have, angle_unit, rows, line, sigma=None, sigma_vel=None):
    """A checked :class:`SolutionFile` from role -> column arrays."""
    n = line.size
    if {"lat", "lon", "height"} <= have:
        k = math.pi / 180.0 if angle_unit == "deg" else 1.0
        lla = np.column_stack([get["lat"] * k, get["lon"] * k, get["height"]])
    else:
        xyz = np.column_stack([get["x"], get["y"], get["z"]])
        lla = _llh_of_ecef(xyz, path, line, rows)
    if "sigma_n" in have:
        sig = np.column_stack([get["sigma_n"], get["sigma_e"], get["sigma_d"]])
    else:
        sig = np.full((n, 3), float(sigma))
    vel = np.full((n, 3), np.nan)
    svel = np.full((n, 3), np.nan)
    if "vel_n" in have:
        vd = -get["vel_u"] if "vel_u" in have else get["vel_d"]
        vel = np.column_stack([get["vel_n"], get["vel_e"], vd])
        if "sigma_vn" in have:
            svel = np.column_stack([get["sigma_vn"], get["sigma_ve"], get["sigma_vd"]])
        elif sigma_vel is not None:
            svel = np.full((n, 3), float(sigma_vel))
    q = get["q"] if "q" in have else np.ones(n)
    return checked(path, get["time"], lla, sig, vel, svel, q, line, rows)


def _csv_rows(path, head_index, roles):
    """``(values (m, len(roles)), lines (m,))``: each row parsed as it is read."""
    values, lines = array.array("d"), array.array("q")
    stream = (text for _, text in textlines.lines(path, what="a CSV solution file"))
    reader = csv.reader(stream)
    width = None
    try:
        for r in reader:
            n = reader.line_num
            if width is None:  # the header
                width = len(r)
                continue
            if not r or not any(x.strip() for x in r):
                continue
            if len(r) != width:
                raise InputError(f"expected {width} fields, got {len(r)}", source=path, line=n)
            for j in head_index:
                try:
                    values.append(float(r[j]))
                except ValueError:
                    raise InputError(
                        f"not a number {r[j][:40]!r} in column {roles[j]!r}", source=path, line=n
                    ) from None
            lines.append(n)
    except csv.Error as exc:
        raise InputError(f"not a CSV row: {exc}", source=path, line=reader.line_num) from None
    m = len(lines)
    return np.frombuffer(values).reshape(m, len(head_index)), np.asarray(lines, np.int64)


def named_columns(path, columns, key):
    """The columns ``{role: header name}`` of a CSV file with a header row, as
    ``({role: values (m,)}, line numbers (m,))``; a name not in the header, or no data
    row, is bad input naming the file and the scenario ``key`` (``key.role``)."""
    head = _csv_header(path)
    for role, name in columns.items():
        if name not in head:
            raise InputError(
                f"column {name!r} (for {role}) not in the header {head}",
                source=path,
                line=1,
                key=f"{key}.{role}",
            )
    order = list(columns)
    index = [head.index(columns[r]) for r in order]
    values, line = _csv_rows(path, index, {head.index(columns[r]): columns[r] for r in order})
    if line.size == 0:
        raise InputError("no data rows", source=path, line=2)
    return {r: values[:, k] for k, r in enumerate(order)}, line


def _csv_header(path):
    try:
        for _, text in textlines.lines(path, what="a CSV solution file"):
            return [h.strip() for h in next(csv.reader([text]))]
    except csv.Error as exc:
        raise InputError(f"unreadable header row: {exc}", source=path, line=1) from None
    raise InputError("empty file: no header row", source=path, line=1)


def _csv_keys(columns):
    """Rule -> the CSV column names it reads (in messages)."""
    roles = {
        "time": ("time",),
        "position": ("lat", "lon", "height", "x", "y", "z"),
        "sigma": ("sigma_n", "sigma_e", "sigma_d"),
        "velocity": ("vel_n", "vel_e", "vel_d", "vel_u"),
        "sigma_vel": ("sigma_vn", "sigma_ve", "sigma_vd"),
        "q": ("q",),
    }
    return {
        rule: "/".join(str(columns[r]) for r in names if r in columns) or rule
        for rule, names in roles.items()
    }


def read_solution_csv(
    path, columns, angle_unit="deg", time_scale=1.0, time_offset=0.0, time_system="gps"
):
    """Read a CSV with a header row of column names.

    Parameters
    ----------
    path : str or Path
    columns : dict
        Role (:data:`CSV_ROLES`) -> column name. Needs ``time``, either ``lat lon
        height`` or ``x y z`` (ECEF, m), ``sigma_n sigma_e sigma_d`` (m); velocity and
        ``q`` optional (``q`` absent: every epoch 1); :func:`role_problem`.
    angle_unit : "deg" or "rad"
    time_scale, time_offset : float
        Seconds of ``time_system`` = ``time_offset + time_scale * value``.
    time_system : str
        :data:`TIME_SYSTEMS` (:func:`gps_seconds`).
    """
    path = str(path)
    _roles(columns, True, "columns")
    if angle_unit not in ("deg", "rad"):
        raise InputError("angle unit must be deg or rad", key="angle_unit")
    get, line = named_columns(path, columns, "columns")
    get["time"], scale = _grid(time_offset + time_scale * get["time"], time_system)
    rows = RowNames(path, line=line, keys=_csv_keys(columns))
    sol = _solution(path, get, set(columns), angle_unit, rows, line)
    return dataclasses.replace(sol, time_system=scale)


def read_solution_mat(
    path,
    variable,
    columns,
    angle_unit="rad",
    sigma=None,
    sigma_vel=None,
    time_system="gps",
    *,
    key="post.gnss",
    time_scale=1.0,
):
    """Solutions from a 2-D array in a .mat file: ``columns`` role -> 0-based column index
    (roles and their rule as :data:`CSV_ROLES`, :func:`role_problem`; ECEF ``x y z``
    too); constant ``sigma`` (m) / ``sigma_vel`` (m/s) where the array has no sigma
    columns; seconds = ``time_scale`` times the time column. Rows are named 1-based (as
    MATLAB counts) with the variable; ``key`` the scenario section in messages."""
    path = str(path)
    _roles(columns, sigma is None, f"{key}.columns")
    a = matfile.mat_array(path, variable, f"{key}.mat_variable", min_rows=2)
    order = list(columns)
    values = matfile.columns(a, [columns[r] for r in order], path, variable, f"{key}.columns")
    get = {r: values[:, k] for k, r in enumerate(order)}
    line = np.arange(1, a.shape[0] + 1)
    get["time"], scale = _grid(time_scale * get["time"], time_system)
    rows = RowNames(path, base=1, keys=dict.fromkeys(TEXT_KEYS, variable))
    sol = _solution(path, get, set(order), angle_unit, rows, line, sigma, sigma_vel)
    return dataclasses.replace(sol, time_system=scale)


def read_mat_columns(path, variable, cols, key):
    """Columns ``cols`` (0-based) of a 2-D array in a .mat file, (n, len(cols)): finite
    on every row (a row named 1-based otherwise)."""
    a = matfile.mat_array(str(path), variable, key, min_rows=2)
    out = matfile.columns(a, cols, path, variable, key)
    bad = np.flatnonzero(~np.isfinite(out).all(axis=1))
    if bad.size:
        i = int(bad[0])
        raise InputError(f"row {i + 1}: {out[i].tolist()} not finite", source=str(path), key=key)
    return out
