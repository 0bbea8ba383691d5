"""Time systems of the four constellations and their conversion to GPS time (one module).

inins computes in GPS time, (week, seconds of week) (spec §6a). The others:

- GST (Galileo System Time): steered to GPS time within tens of ns (the GGTO,
  broadcast, is not applied: below 1 m and absorbed by the receiver's
  inter-system bias); the RINEX navigation file gives the Galileo week in GPS
  week numbering (RINEX 3.04 §6.8), so GST (week, sow) = GPST (week, sow).
- BDT (BeiDou Time): started 2006-01-01 00:00:00 UTC, no leap seconds:
  ``GPST = BDT + 14 s`` and BDT week 0 is GPS week 1356.
- GLONASST: UTC(SU) + 3 h, with leap seconds. RINEX states GLONASS record
  epochs in UTC (RINEX 2.11 §8, RINEX 3.04 Table A10), so
  ``GPST = UTC + leap seconds`` with the leap seconds of the file header (17 s
  from 2015-07-01 to 2016-12-31, 18 s after).
"""

import numpy as np

from inins.gnss import gpstime
from inins.gnss.systems import BEIDOU, GLONASS

BDT_GPS_WEEK = 1356
"""GPS week of BDT week 0."""
BDT_GPS_SECONDS = 14.0
"""GPST - BDT (s)."""
MOSCOW_HOURS = 3
"""GLONASST - UTC(SU) (h)."""


def gps_from_bdt(week, sow):
    """GPS (week, sow) of BDT (week, sow)."""
    return gpstime.normalize(np.asarray(week) + BDT_GPS_WEEK, np.asarray(sow, float) + 14.0)


def bdt_from_gps(week, sow):
    """BDT (week, sow) of GPS (week, sow)."""
    return gpstime.normalize(np.asarray(week) - BDT_GPS_WEEK, np.asarray(sow, float) - 14.0)


def gps_from_utc(week, sow, leap_seconds):
    """GPS (week, sow) of a UTC instant written as (week, sow) on the GPS week grid
    (what a calendar date in UTC gives through :func:`inins.gnss.gpstime.from_calendar`)."""
    return gpstime.normalize(week, np.asarray(sow, float) + leap_seconds)


def gps_from_glonasst(week, sow, leap_seconds):
    """GPS (week, sow) of a GLONASS time instant (UTC(SU) + 3 h) on the GPS week grid."""
    return gps_from_utc(week, np.asarray(sow, float) - 3600.0 * MOSCOW_HOURS, leap_seconds)


def system_from_gps(system, week, sow):
    """(week, sow) in each row's own system time (BDT for BeiDou rows, GPST otherwise;
    GLONASS ephemerides are kept in GPS time, converted when read).

    Parameters
    ----------
    system : array_like of int, system index per row
    week, sow : array_like, GPS time, broadcastable to ``system``
    """
    system, week, sow = np.broadcast_arrays(system, np.asarray(week, np.int64), sow)
    bds = system == BEIDOU
    if not bds.any():
        return week, np.asarray(sow, float)
    bw, bs = bdt_from_gps(week, sow)
    return np.where(bds, bw, week), np.where(bds, bs, sow)


def needs_leap_seconds(system):
    """True for the systems whose RINEX epochs are UTC (GLONASS)."""
    return np.asarray(system) == GLONASS


LEAP_SECONDS = (
    ("1981-07-01", 1),
    ("1982-07-01", 2),
    ("1983-07-01", 3),
    ("1985-07-01", 4),
    ("1988-01-01", 5),
    ("1990-01-01", 6),
    ("1991-01-01", 7),
    ("1992-07-01", 8),
    ("1993-07-01", 9),
    ("1994-07-01", 10),
    ("1996-01-01", 11),
    ("1997-07-01", 12),
    ("1999-01-01", 13),
    ("2006-01-01", 14),
    ("2009-01-01", 15),
    ("2012-07-01", 16),
    ("2015-07-01", 17),
    ("2017-01-01", 18),
)
"""GPS - UTC (s) from each UTC date on (IERS Bulletin C; 0 from 1980-01-06)."""
LEAP_KNOWN_UNTIL = "2026-06-30"
"""Last date the table is known for: IERS Bulletin C 70 (July 2025) announced no leap
second at the end of December 2025; later dates are not checked."""


def leap_seconds_at(week, sow):
    """GPS - UTC (s) at GPS (week, sow) by :data:`LEAP_SECONDS`, or None after
    :data:`LEAP_KNOWN_UNTIL` (not known here) or before the GPS epoch.

    The instant is taken on the GPS scale; within the 18 s before a leap second the
    answer can be the old value (irrelevant for a day's file).
    """
    when = gpstime.to_datetime64(week, sow)
    if when < np.datetime64("1980-01-06") or when > np.datetime64(LEAP_KNOWN_UNTIL):
        return None
    dates = np.array([d for d, _ in LEAP_SECONDS], dtype="datetime64[ns]")
    k = int(np.searchsorted(dates, when, side="right"))
    return 0 if k == 0 else LEAP_SECONDS[k - 1][1]


UNIX_GPS_EPOCH_S = 315964800.0
"""Unix time (UTC seconds since 1970-01-01, no leap seconds) of the GPS epoch 1980-01-06."""


def leap_seconds_of_utc(utc_seconds):
    """GPS - UTC (s) of UTC instants counted in seconds since 1980-01-06 00:00 UTC (a
    UTC day 86,400 s): :data:`LEAP_SECONDS` at each instant's UTC date, NaN before the
    GPS epoch or after :data:`LEAP_KNOWN_UNTIL` (not known here).

    Parameters
    ----------
    utc_seconds : array_like (m,)

    Returns
    -------
    ndarray (m,) float
    """
    t = np.asarray(utc_seconds, float)
    epoch = np.datetime64("1980-01-06", "s")
    dates = np.array([d for d, _ in LEAP_SECONDS], "datetime64[s]")
    starts = (dates - epoch).astype(float)
    values = np.array([0.0] + [float(v) for _, v in LEAP_SECONDS])
    leap = values[np.searchsorted(starts, t, side="right")]
    until = float(
        (np.datetime64(LEAP_KNOWN_UNTIL, "s") + np.timedelta64(1, "D") - epoch).astype(float)
    )
    leap[~((t >= 0.0) & (t < until))] = np.nan
    return leap
