"""The post-processor's solutions on GNSS time, as labelled, and the absolute start.

The loosely coupled filter runs on the IMU axis mapped to GNSS time by the clock fit
(:mod:`inins.ekf.timeoffset`); its residual time-offset state ``dt_g`` says that a
solution tagged ``t`` was taken at filter time ``t + dt_g`` (the measurement model of
:func:`inins.ekf.rows.antenna_position_rows`). The filter's epoch tagged ``t``
therefore holds the vehicle of GNSS time ``t - dt_g``, and the vehicle at GNSS time
``t`` is the filter's state at ``t + dt_g``: to first order in ``dt_g``

- position ``lla + v dt_g`` (the shift the filter's own measurement model applies),
- velocity ``v + a dt_g``, ``a`` the central difference of the velocities,
- attitude ``q + q' dt_g`` renormalised, ``q'`` the central difference of the
  quaternions (made sign-continuous first).

The neglected second-order term ``|a| dt_g^2 / 2`` is 5 mm for 1 m/s^2 and 0.1 s. On
the lc-drive car the filter's positions read as labelled were 1.27 m (forward) and
0.87 m (smoothed) RMS off the RTK fixes outside the outages before this shift.

Absolute time: the solutions' times are GNSS seconds from the solution file's first
epoch, which :func:`absolute_start` states as GPS week and seconds of week and as UTC
(leap seconds from the date, :func:`inins.gnss.timescales.leap_seconds_at`).
"""

import dataclasses
import math

import numpy as np

from inins.core import error_model
from inins.exceptions import InputError
from inins.gnss import gpstime, timescales

WEEK = 604800.0
"""Seconds in a GPS week."""


def _continuous(quat):
    """Quaternions (m, 4) with each row's sign chosen to follow the previous one."""
    q = np.array(quat, float)
    flip = np.sign(np.einsum("ij,ij->i", q[1:], q[:-1]))
    flip[flip == 0] = 1.0
    q[1:] *= np.cumprod(flip)[:, None]
    return q


def on_gnss_time(time, solution):
    """``solution`` (:class:`inins.ekf.post.Solution`, epochs ``time`` (m,) s) moved to
    GNSS time (module docstring); unchanged without a time-offset state."""
    offset = solution.offset
    if offset is None or time.size < 2:
        return solution
    dt = np.reshape(offset, (-1, 1))
    lla = error_model.lla_offset(solution.lla, solution.vel * dt)
    vel = solution.vel + np.gradient(solution.vel, time, axis=0) * dt
    q = _continuous(solution.quat)
    q = q + np.gradient(q, time, axis=0) * dt
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    return dataclasses.replace(solution, lla=lla, vel=vel, quat=q)


@dataclasses.dataclass(frozen=True)
class AbsoluteTime:
    """An instant as GPS ``week`` and seconds of week ``sow`` (s), and ``utc`` an ISO
    8601 string (``...Z``, milliseconds), None where the leap seconds are not known."""

    week: int
    sow: float
    utc: str | None


def absolute_start(gps_seconds):
    """:class:`AbsoluteTime` of GPS seconds since the GPS epoch (1980-01-06); None within
    the first GPS week, where a file's times are relative ones (no absolute start)."""
    if not gps_seconds >= WEEK:
        return None
    week = math.floor(gps_seconds / WEEK)
    sow = float(gps_seconds - week * WEEK)
    leap = timescales.leap_seconds_at(week, sow)
    utc = None
    if leap is not None:
        when = gpstime.to_datetime64(week, sow - leap)
        utc = np.datetime_as_string(when, unit="ms") + "Z"
    return AbsoluteTime(week, sow, utc)


def solution_on_gps_time(solution, key="post.gnss.time_system"):
    """A solution file (:class:`inins.io.solution_files.SolutionFile`) whose tags are
    UTC seconds on the GPS grid (``time_system`` ``utc``) moved to GPS time: the leap
    seconds of each tag's date added (:func:`inins.gnss.timescales.leap_seconds_of_utc`);
    bad input naming the file, first line and ``key`` where they are not known. GPS tags
    are returned as they are."""
    if solution.time_system == "gps":
        return solution
    leap = timescales.leap_seconds_of_utc(solution.time)
    bad = np.flatnonzero(~np.isfinite(leap))
    if bad.size:
        raise InputError(
            f"UTC time tag {solution.time[bad[0]]:.3f} s from 1980-01-06 is before that date "
            f"or after {timescales.LEAP_KNOWN_UNTIL}, where the leap seconds are not known here",
            source=str(solution.path),
            line=int(solution.line[bad[0]]),
            key=key,
        )
    return dataclasses.replace(solution, time=solution.time + leap, time_system="gps")
