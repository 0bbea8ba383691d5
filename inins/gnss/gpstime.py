"""GPS time as (week, seconds of week): calendar conversion and differences.

GPS time has no leap seconds; its epoch is 1980-01-06 00:00:00. Differences of
seconds of week taken without the week are wrapped into [-302400, 302400) s, the
rule of IS-GPS-200 §20.3.3.4.3 for ``t - toe`` (week rollover).
"""

import numpy as np

WEEK = 604800.0
"""Seconds in a GPS week."""
HALF_WEEK = 302400.0
"""Half a GPS week (s): the wrap limit of a seconds-of-week difference."""
_GPS_EPOCH = np.datetime64("1980-01-06T00:00:00", "ns")


def wrap_week_seconds(dt):
    """A seconds-of-week difference (s) wrapped into [-302400, 302400).

    IS-GPS-200 §20.3.3.4.3: if ``tk > 302400`` subtract 604800, if
    ``tk < -302400`` add 604800.
    """
    dt = np.asarray(dt, dtype=float)
    return dt - WEEK * np.floor((dt + HALF_WEEK) / WEEK)


def time_diff(week_a, sow_a, week_b, sow_b):
    """``(week_a, sow_a) - (week_b, sow_b)`` in seconds, exact for whole weeks."""
    return (np.asarray(week_a) - np.asarray(week_b)) * WEEK + (
        np.asarray(sow_a, dtype=float) - np.asarray(sow_b, dtype=float)
    )


def normalize(week, sow):
    """(week, sow) with ``0 <= sow < 604800``, carrying whole weeks into ``week``."""
    sow = np.asarray(sow, dtype=float)
    carry = np.floor(sow / WEEK)
    return np.asarray(week, dtype=np.int64) + carry.astype(np.int64), sow - carry * WEEK


def from_calendar(year, month, day, hour, minute, second):
    """GPS (week, seconds of week) of calendar dates in GPS time.

    Parameters
    ----------
    year, month, day, hour, minute : array_like of int
        Calendar fields; a two-digit year means 1980-2079 (RINEX 2).
    second : array_like of float
        Seconds of the minute, fractional.

    Returns
    -------
    week : ndarray of int64
    sow : ndarray of float, s
    """
    year = np.asarray(year, dtype=np.int64)
    year = np.where(year < 80, year + 2000, np.where(year < 100, year + 1900, year))
    month, day = np.asarray(month, dtype=np.int64), np.asarray(day, dtype=np.int64)
    # days from civil (proleptic Gregorian), H. Hinnant's algorithm
    y = year - (month <= 2)
    era = np.floor_divide(y, 400)
    yoe = y - era * 400
    doy = (153 * (month + np.where(month > 2, -3, 9)) + 2) // 5 + day - 1
    doe = yoe * 365 + yoe // 4 - yoe // 100 + doy
    days = era * 146097 + doe - 719468 - 3657  # days since 1980-01-06
    week = np.floor_divide(days, 7)
    sow = (days - week * 7) * 86400.0 + np.asarray(hour) * 3600.0 + np.asarray(minute) * 60.0
    return week, sow + np.asarray(second, dtype=float)


def to_datetime64(week, sow):
    """numpy datetime64[ns] of GPS (week, sow) (GPS time scale, no leap seconds)."""
    ns = np.round(np.asarray(sow, dtype=float) * 1e9).astype(np.int64)
    return _GPS_EPOCH + (np.asarray(week, dtype=np.int64) * 604800 * 10**9 + ns).astype(
        "timedelta64[ns]"
    )
