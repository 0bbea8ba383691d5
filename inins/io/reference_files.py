"""A reference trajectory (run-ekf ``post.reference``): RTKLIB ``.pos``, a CSV with named
columns, or a 2-D array in a ``.mat`` file, read into SI.

The position and velocity columns follow the solution files' readers and rules
(:mod:`inins.io.solution_files`, :mod:`inins.io.solution_checks`: time finite and
strictly increasing, latitude, longitude and height in range, velocity finite within
10 km/s); the sigmas and quality flags a reference does not need. Attitude columns
(``roll``, ``pitch``, ``heading``; or ``heading`` alone) must be finite, roll and
heading within ±360 deg, pitch within ±90 deg. Every problem names the file and the
line (text) or 1-based row (``.mat``), with the column.

Time stays in the file's time system here (``time_system`` of the returned
:class:`~inins.io.solution_files.SolutionFile`: ``gps`` or ``utc`` on the GPS grid,
Unix time moved to that grid), ``time_offset_s`` added; the leap seconds of UTC tags
are added by :func:`inins.ekf.gnss_time.solution_on_gps_time`.
"""

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from inins.exceptions import InputError
from inins.io import solution_files as sf
from inins.io.solution_checks import RowNames

ATTITUDE = ("roll", "pitch", "heading")
_BOUND_DEG = {"roll": 360.0, "pitch": 90.0, "heading": 360.0}
"""Largest absolute attitude angle accepted (deg)."""
_KEY = "post.reference"


@dataclass(frozen=True, eq=False)
class ReferenceFile:
    """A reference trajectory: ``solution`` the positions and velocities
    (:class:`~inins.io.solution_files.SolutionFile`, velocity NaN where absent, sigma
    and flags not used); ``euler`` (m, 3) rad roll, pitch, heading (NaN where absent),
    or None."""

    solution: sf.SolutionFile
    euler: np.ndarray | None


def _check_attitude(euler, rows, names):
    """Finite attitude within :data:`_BOUND_DEG` on every row (columns ``names``)."""
    for j, role in enumerate(ATTITUDE):
        if role not in names:
            continue
        v = np.degrees(euler[:, j])
        with np.errstate(invalid="ignore"):
            bad = np.flatnonzero(~(np.abs(v) <= _BOUND_DEG[role]))
        if bad.size:
            i = int(bad[0])
            raise InputError(
                f"{role} {v[i]:.6g} deg is not finite within ±{_BOUND_DEG[role]:g} deg",
                source=rows.source,
                line=None if rows.line is None else int(rows.line[i]),
                key=str(names[role]),
            )


def _euler(get, columns, unit, rows):
    """(m, 3) rad from the attitude roles of ``get``; None without them."""
    names = {r: columns[r] for r in ATTITUDE if r in columns}
    if not names:
        return None
    m = get["time"].size
    k = math.pi / 180.0 if unit == "deg" else 1.0
    euler = np.column_stack([get[r] * k if r in get else np.full(m, np.nan) for r in ATTITUDE])
    _check_attitude(euler, rows, names)
    return euler


def _offset(sol, offset):
    return dataclasses.replace(sol, time=sol.time + offset)


def read_reference_csv(path, columns, angle_unit="deg", time_scale=1.0, time_system="gps"):
    """Reference trajectory from a CSV with a header row of column names.

    Parameters
    ----------
    path : str or Path
    columns : dict
        Role -> column name: ``time``; ``lat lon height`` or ``x y z`` (ECEF, m);
        optional ``vel_n vel_e`` with ``vel_d`` or ``vel_u`` (m/s) and ``roll pitch
        heading`` (or ``heading``) in ``angle_unit``.
    angle_unit : "deg" or "rad"
    time_scale : float
        Seconds per unit of the time column.
    time_system : str
        :data:`inins.io.solution_files.TIME_SYSTEMS`.

    Returns
    -------
    ReferenceFile
    """
    path = str(path)
    get, line = sf.named_columns(path, columns, f"{_KEY}.columns")
    get["time"], scale = sf._grid(time_scale * get["time"], time_system)
    rows = RowNames(path, line=line, keys=sf._csv_keys(columns))
    have = set(columns) - set(ATTITUDE)
    sol = sf._solution(path, get, have, angle_unit, rows, line, sigma=1.0, sigma_vel=1.0)
    euler = _euler(get, columns, angle_unit, rows)
    return ReferenceFile(dataclasses.replace(sol, time_system=scale), euler)


def read_reference_mat(
    path, variable, columns, angle_unit="deg", time_scale=1.0, time_system="gps"
):
    """Reference trajectory from a 2-D array in a .mat file; ``columns`` role -> 0-based
    index (roles as :func:`read_reference_csv`); rows named 1-based."""
    path = str(path)
    pos = {r: int(c) for r, c in columns.items() if r not in ATTITUDE}
    sol = sf.read_solution_mat(
        path, variable, pos, angle_unit, 1.0, 1.0, time_system, key=_KEY, time_scale=time_scale
    )
    att = [r for r in ATTITUDE if r in columns]
    if not att:
        return ReferenceFile(sol, None)
    a = sf.read_mat_columns(path, variable, [int(columns[r]) for r in att], f"{_KEY}.columns")
    get = dict(zip(att, a.T, strict=True)) | {"time": sol.time}
    rows = RowNames(path, base=1)
    return ReferenceFile(sol, _euler(get, {r: columns[r] for r in att}, angle_unit, rows))


def read_reference(r):
    """The :class:`ReferenceFile` of a ``post.reference`` section ``r``
    (:class:`inins.scenario.run_ekf_reference.ReferenceTrajectory`), its
    ``time_offset_s`` added to the tags (still in the file's time system)."""
    if r.format == "rtklib":
        sol = sf.read_rtklib_pos(r.file)
        if r.q_flags is not None:
            sol = sol.select(np.isin(sol.q, r.q_flags))
            if len(sol) < 2:
                raise InputError(
                    f"fewer than 2 epochs with quality flags {r.q_flags}",
                    source=str(r.file),
                    key=f"{_KEY}.q_flags",
                )
        ref = ReferenceFile(sol, None)
    elif r.format == "mat":
        ref = read_reference_mat(
            r.file, r.mat_variable, r.columns, r.angle_unit, r.time_scale_s, r.time_system
        )
    else:
        ref = read_reference_csv(r.file, r.columns, r.angle_unit, r.time_scale_s, r.time_system)
    return dataclasses.replace(ref, solution=_offset(ref.solution, r.time_offset_s))
