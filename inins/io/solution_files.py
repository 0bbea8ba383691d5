"""GNSS solution files for the loosely coupled filter: RTKLIB ``.pos`` and a named-column CSV.

Both readers return a :class:`SolutionFile` in SI units: time as GPS seconds since
the GPS epoch (1980-01-06, no leap seconds), geodetic position (rad, rad, m), NED
1-sigma (m), NED velocity (m/s) and its 1-sigma where the file has them, the
quality flag. Every problem is an :class:`inins.exceptions.InputError` naming the
file and the line (or column).

RTKLIB ``.pos`` (``rnx2rtkp``/``rtkpost`` output): ``%`` comment lines, the last of
which names the columns. Time is ``GPST`` as ``yyyy/mm/dd hh:mm:ss.sss`` or as
``week  seconds``; position as ``latitude(deg) longitude(deg) height(m)`` (or
``latitude(d'")`` is refused) or ``x-ecef(m) y-ecef(m) z-ecef(m)``; then ``Q`` (1 fix,
2 float, 3 SBAS, 4 DGPS, 5 single, 6 PPP), ``ns``, the sigmas ``sdn sde sdu`` (or
``sdx sdy sdz``) and their cross terms, ``age``, ``ratio``, and optionally
``vn ve vu`` (m/s) with ``sdvn sdve sdvu`` and cross terms. ECEF sigmas are rotated
to NED keeping the diagonal; the cross terms (``sdne`` ...) are not used.
"""

import csv
import datetime
import gzip
import io
import math
from dataclasses import dataclass

import numpy as np

from inins.core import earth
from inins.exceptions import InputError

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
    """A GNSS solution file in SI units (module docstring); ``line`` (m,) 1-based lines."""

    path: str
    time: np.ndarray
    lla: np.ndarray
    sigma_ned: np.ndarray
    vel_ned: np.ndarray
    sigma_vel: np.ndarray
    q: np.ndarray
    line: np.ndarray

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
        )


def _open_text(path):
    """A text stream of ``path`` (gzip when it ends in .gz)."""
    if str(path).endswith(".gz"):
        return io.TextIOWrapper(gzip.open(path, "rb"), encoding="utf-8", errors="replace")
    return open(path, encoding="utf-8", errors="replace", newline="")


def _ned_sigma(lla, sig_xyz):
    """Diagonal of ``M^T diag(s^2) M`` (``M`` = mat_en), (m, 3)."""
    m_en = earth.mat_en(lla[:, 0], lla[:, 1])
    return np.sqrt(np.einsum("kji,kj->ki", m_en**2, sig_xyz**2))


def _check(path, time, sig, svel, vel, line):
    bad = np.flatnonzero(np.diff(time) <= 0.0)
    if bad.size:
        i = bad[0] + 1
        raise InputError(
            f"time {time[i]:.3f} s does not increase (previous {time[i - 1]:.3f} s)",
            source=path,
            line=int(line[i]),
        )
    bad = np.flatnonzero(~(sig > 0.0).all(1))
    if bad.size:
        raise InputError(
            "position sigma must be > 0", source=path, line=int(line[bad[0]]), key="sdn/sde/sdu"
        )
    has = np.isfinite(vel).all(1) & np.isfinite(svel).all(1)
    bad = np.flatnonzero(has & ~(svel > 0.0).all(1))
    if bad.size:
        raise InputError(
            "velocity sigma must be > 0", source=path, line=int(line[bad[0]]), key="sdvn/sdve/sdvu"
        )


def read_rtklib_pos(path):
    """Read an RTKLIB ``.pos`` solution file (module docstring) -> :class:`SolutionFile`."""
    path = str(path)
    header, rows, lines = None, [], []
    try:
        with _open_text(path) as f:
            for n, text in enumerate(f, 1):
                s = text.strip()
                if not s:
                    continue
                if s.startswith("%"):
                    if "GPST" in s or "UTC" in s or "JST" in s:
                        header = (n, s[1:].split())
                    continue
                if header is None:
                    raise InputError("data before the column header line", source=path, line=n)
                rows.append(s.split())
                lines.append(n)
    except (OSError, EOFError) as exc:
        raise InputError(f"cannot read: {exc}", source=path) from exc
    if header is None:
        raise InputError("no column header line (% GPST ...)", source=path)
    hline, names = header
    if names[0] != "GPST":
        raise InputError(
            f"time system {names[0]!r}: only GPST is supported", source=path, line=hline
        )
    cols = names[1:]
    for c in cols:
        if c not in _KNOWN:
            raise InputError(f"unknown column {c!r}", source=path, line=hline, key=c)
    if not rows:
        raise InputError("no solution epochs", source=path)
    calendar = "/" in rows[0][0]
    nt = 2  # date + time, or week + seconds
    width = nt + len(cols)
    for r, n in zip(rows, lines, strict=True):
        if len(r) != width:
            raise InputError(f"expected {width} fields, got {len(r)}", source=path, line=n)
    try:
        values = np.array([[float(v) for v in r[nt:]] for r in rows])
    except ValueError as exc:
        bad = next(i for i, r in enumerate(rows) if not _floats(r[nt:]))
        raise InputError(f"not a number: {exc}", source=path, line=lines[bad]) from exc
    time = np.empty(len(rows))
    for i, r in enumerate(rows):
        try:
            if calendar:
                y, mo, d = (int(v) for v in r[0].split("/"))
                hh, mm, ss = r[1].split(":")
                days = (datetime.date(y, mo, d) - _GPS_EPOCH).days
                time[i] = days * 86400.0 + int(hh) * 3600.0 + int(mm) * 60.0 + float(ss)
            else:
                time[i] = int(r[0]) * WEEK + float(r[1])
        except ValueError as exc:
            raise InputError(f"bad time {r[0]} {r[1]}", source=path, line=lines[i]) from exc
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
        lla = earth.llh_from_ecef(need(*_XYZ))
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
    q = need("Q")[:, 0].astype(np.int64)
    line = np.asarray(lines, np.int64)
    _check(path, time, sig, svel, vel, line)
    vel[~np.isfinite(svel).all(1)] = np.nan  # a velocity without its sigma is not used
    return SolutionFile(path, time, lla, sig, vel, svel, q, line)


def _floats(values):
    try:
        [float(v) for v in values]
    except ValueError:
        return False
    return True


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


def read_solution_csv(path, columns, angle_unit="deg", time_scale=1.0, time_offset=0.0):
    """Read a CSV with a header row of column names.

    Parameters
    ----------
    path : str or Path
    columns : dict
        Role (:data:`CSV_ROLES`) -> column name. Needs ``time``, either ``lat lon
        height`` or ``x y z`` (ECEF, m), ``sigma_n sigma_e sigma_d`` (m); velocity and
        ``q`` optional (``q`` absent: every epoch 1).
    angle_unit : "deg" or "rad"
    time_scale, time_offset : float
        GPS seconds since the GPS epoch = ``time_offset + time_scale * value``.
    """
    path = str(path)
    for role in columns:
        if role not in CSV_ROLES:
            raise InputError(
                f"unknown role {role!r} (known: {', '.join(CSV_ROLES)})", key=f"columns.{role}"
            )
    if angle_unit not in ("deg", "rad"):
        raise InputError("angle unit must be deg or rad", key="angle_unit")
    try:
        with _open_text(path) as f:
            reader = csv.reader(f)
            head = [h.strip() for h in next(reader)]
            rows = [(n, r) for n, r in enumerate(reader, 2) if r and any(x.strip() for x in r)]
    except (OSError, EOFError, StopIteration) as exc:
        raise InputError(f"cannot read a header row: {exc}", source=path) from exc
    for role, name in columns.items():
        if name not in head:
            raise InputError(
                f"column {name!r} (for {role}) not in the header {head}",
                source=path,
                line=1,
                key=f"columns.{role}",
            )
    index = {role: head.index(name) for role, name in columns.items()}
    data = np.full((len(rows), len(CSV_ROLES)), np.nan)
    for i, (n, r) in enumerate(rows):
        if len(r) != len(head):
            raise InputError(f"expected {len(head)} fields, got {len(r)}", source=path, line=n)
        for role, j in index.items():
            try:
                data[i, CSV_ROLES.index(role)] = float(r[j])
            except ValueError as exc:
                raise InputError(
                    f"not a number {r[j]!r} in column {head[j]!r}", source=path, line=n
                ) from exc
    if not rows:
        raise InputError("no data rows", source=path)
    get = {role: data[:, CSV_ROLES.index(role)] for role in CSV_ROLES}
    for role in ("time", "sigma_n", "sigma_e", "sigma_d"):
        if role not in columns:
            raise InputError(f"the {role} column is required", key=f"columns.{role}")
    line = np.array([n for n, _ in rows], np.int64)
    time = time_offset + time_scale * get["time"]
    if all(r in columns for r in ("lat", "lon", "height")):
        k = math.pi / 180.0 if angle_unit == "deg" else 1.0
        lla = np.column_stack([get["lat"] * k, get["lon"] * k, get["height"]])
    elif all(r in columns for r in ("x", "y", "z")):
        lla = earth.llh_from_ecef(np.column_stack([get["x"], get["y"], get["z"]]))
    else:
        raise InputError("need lat, lon, height or x, y, z columns", key="columns")
    sig = np.column_stack([get["sigma_n"], get["sigma_e"], get["sigma_d"]])
    vel_d = -get["vel_u"] if "vel_u" in columns else get["vel_d"]
    vel = np.column_stack([get["vel_n"], get["vel_e"], vel_d])
    svel = np.column_stack([get["sigma_vn"], get["sigma_ve"], get["sigma_vd"]])
    q = np.ones(time.size, np.int64) if "q" not in columns else get["q"].astype(np.int64)
    _check(path, time, sig, svel, vel, line)
    vel[~np.isfinite(svel).all(1)] = np.nan  # a velocity without its sigma is not used
    return SolutionFile(path, time, lla, sig, vel, svel, q, line)


@dataclass(frozen=True, eq=False)
class ImuRates:
    """An IMU log of rates: ``time`` (n,) s on the log's own axis, ``gyro`` (n, 3) rad/s,
    ``accel`` (n, 3) m/s^2, in body axes (forward, right, down) after the axis map."""

    path: str
    time: np.ndarray
    gyro: np.ndarray
    accel: np.ndarray
    odometer: np.ndarray | None = None


_AXIS = {
    "x": (0, 1.0),
    "-x": (0, -1.0),
    "y": (1, 1.0),
    "-y": (1, -1.0),
    "z": (2, 1.0),
    "-z": (2, -1.0),
}
G0 = 9.80665


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
    """Read a header-less numeric CSV of IMU rates (one sample a row).

    ``axes``: for body x, y, z the IMU axis (``"-x"``: minus IMU x). Rows with the
    wrong number of fields or non-numbers are bad input (line named); so is time not
    increasing.
    """
    path = str(path)
    rows, lines = [], []
    width = None
    try:
        with _open_text(path) as f:
            for n, text in enumerate(f, 1):
                s = text.strip()
                if not s:
                    continue
                parts = s.split(",")
                width = width or len(parts)
                if len(parts) != width:
                    raise InputError(
                        f"expected {width} fields, got {len(parts)}", source=path, line=n
                    )
                try:
                    rows.append([float(v) for v in parts])
                except ValueError as exc:
                    raise InputError(f"not a number: {exc}", source=path, line=n) from exc
                lines.append(n)
    except (OSError, EOFError) as exc:
        raise InputError(f"cannot read: {exc}", source=path) from exc
    if len(rows) < 2:
        raise InputError("fewer than 2 IMU rows", source=path)
    a = np.asarray(rows)
    for key, cols in (("accel_columns", accel_columns), ("gyro_columns", gyro_columns)):
        if max(cols) >= a.shape[1]:
            raise InputError(f"column {max(cols)} beyond the {a.shape[1]} fields", key=key)
    if time_column >= a.shape[1]:
        raise InputError(f"column {time_column} beyond the {a.shape[1]} fields", key="time_column")
    time = a[:, time_column] * time_scale
    bad = np.flatnonzero(np.diff(time) <= 0)
    if bad.size:
        i = bad[0] + 1
        raise InputError(
            f"time {time[i]:.6f} s does not increase (previous {time[i - 1]:.6f} s)",
            source=path,
            line=lines[i],
        )
    acc = a[:, list(accel_columns)] * (G0 if accel_unit == "g" else 1.0)
    gyro = a[:, list(gyro_columns)] * (math.pi / 180.0 if gyro_unit == "dps" else 1.0)
    index = [_AXIS[x][0] for x in axes]
    sign = np.array([_AXIS[x][1] for x in axes])
    if sorted(index) != [0, 1, 2]:
        raise InputError(f"axes {list(axes)} do not name x, y and z once each", key="axes")
    odo = None
    if odometer_column is not None:
        if odometer_column >= a.shape[1]:
            raise InputError(
                f"column {odometer_column} beyond the {a.shape[1]} fields", key="odometer_column"
            )
        odo = a[:, odometer_column] * odometer_scale
    return ImuRates(path, time, gyro[:, index] * sign, acc[:, index] * sign, odo)


def _mat_array(path, variable, key):
    import scipy.io  # only for a .mat input

    try:
        mat = scipy.io.loadmat(path)
    except (OSError, ValueError) as exc:
        raise InputError(f"cannot read the .mat file: {exc}", source=str(path)) from exc
    if variable not in mat:
        names = sorted(k for k in mat if not k.startswith("__"))
        raise InputError(f"no variable {variable!r} (has {names})", source=str(path), key=key)
    a = np.asarray(mat[variable], float)
    if a.ndim != 2:
        raise InputError(f"{variable!r} is not a 2-D array", source=str(path), key=key)
    return a


def read_solution_mat(path, variable, columns, angle_unit="rad", sigma=None, sigma_vel=None):
    """Solutions from a 2-D array in a .mat file: ``columns`` role -> 0-based column index
    (roles as :data:`CSV_ROLES`); constant ``sigma`` (m) / ``sigma_vel`` (m/s) where the
    array has no sigma columns. Rows are reported as lines (1-based)."""
    path = str(path)
    a = _mat_array(path, variable, "post.gnss.mat_variable")
    for role, col in columns.items():
        if role not in CSV_ROLES:
            raise InputError(f"unknown role {role!r}", key=f"columns.{role}")
        if not 0 <= int(col) < a.shape[1]:
            raise InputError(f"column {col} beyond the {a.shape[1]} columns", key=f"columns.{role}")
    get = {r: a[:, int(c)] for r, c in columns.items()}
    n = a.shape[0]
    line = np.arange(1, n + 1)
    k = math.pi / 180.0 if angle_unit == "deg" else 1.0
    lla = np.column_stack([get["lat"] * k, get["lon"] * k, get["height"]])
    if "sigma_n" in get:
        sig = np.column_stack([get["sigma_n"], get["sigma_e"], get["sigma_d"]])
    elif sigma is not None:
        sig = np.full((n, 3), float(sigma))
    else:
        raise InputError("no sigma columns and no constant sigma given", key="post.gnss.sigma_m")
    vel = np.full((n, 3), np.nan)
    svel = np.full((n, 3), np.nan)
    if "vel_n" in get:
        vd = -get["vel_u"] if "vel_u" in get else get["vel_d"]
        vel = np.column_stack([get["vel_n"], get["vel_e"], vd])
        if sigma_vel is not None:
            svel = np.full((n, 3), float(sigma_vel))
    time = get["time"]
    q = np.ones(n, np.int64)
    _check(path, time, sig, svel, vel, line)
    vel[~np.isfinite(svel).all(1)] = np.nan
    return SolutionFile(path, time, lla, sig, vel, svel, q, line)


def read_mat_columns(path, variable, cols, key):
    """Columns ``cols`` (0-based) of a 2-D array in a .mat file, (n, len(cols))."""
    a = _mat_array(str(path), variable, key)
    if max(cols) >= a.shape[1]:
        raise InputError(f"column {max(cols)} beyond the {a.shape[1]} columns", key=key)
    return a[:, list(cols)]


def read_imu_increments_mat(path, variable, gyro_columns, accel_columns, time_column, axes):
    """IMU increments (rad, m/s over each interval ending at its time tag) from a .mat
    array, as rates at the interval midpoints (:class:`ImuRates`)."""
    path = str(path)
    a = _mat_array(path, variable, "post.imu.mat_variable")
    t = a[:, time_column]
    if np.any(np.diff(t) <= 0):
        i = int(np.flatnonzero(np.diff(t) <= 0)[0]) + 1
        raise InputError(f"time {t[i]} s does not increase", source=path, line=i + 1)
    dt = np.diff(t, prepend=t[0] - np.median(np.diff(t)))
    index = [_AXIS[x][0] for x in axes]
    sign = np.array([_AXIS[x][1] for x in axes])
    if sorted(index) != [0, 1, 2]:
        raise InputError(f"axes {list(axes)} do not name x, y and z once each", key="axes")
    gyro = a[:, list(gyro_columns)] / dt[:, None]
    acc = a[:, list(accel_columns)] / dt[:, None]
    return ImuRates(path, t - 0.5 * dt, gyro[:, index] * sign, acc[:, index] * sign)
