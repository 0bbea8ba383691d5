"""GPS - UTC by date (inins.gnss.timescales.LEAP_SECONDS, IERS Bulletin C): the values
at the dates of the packaged data and around the leap seconds, exactly."""

import numpy as np
import pytest

from inins.gnss import gpstime, timescales


@pytest.mark.parametrize(
    ("date", "expected"),
    [
        ((1980, 1, 6, 0, 0, 1.0), 0),
        ((1981, 6, 30, 23, 0, 0.0), 0),
        ((1981, 7, 1, 0, 0, 30.0), 1),
        ((2015, 1, 8, 0, 0, 0.0), 16),  # ABPO, data/abpo0080.15o.gz
        ((2015, 7, 1, 0, 1, 0.0), 17),
        ((2016, 6, 6, 11, 10, 41.7), 17),  # smartLoc, data/smartloc
        ((2016, 12, 31, 23, 0, 0.0), 17),
        ((2017, 1, 1, 0, 1, 0.0), 18),
        ((2025, 7, 8, 19, 34, 18.5), 18),  # the lc-drive, data/lc-drive
    ],
)
def test_gps_minus_utc_by_date(date, expected):
    week, sow = gpstime.from_calendar(*date)
    assert timescales.leap_seconds_at(week, sow) == expected


def test_one_second_at_a_time_and_unknown_after_the_table():
    values = [v for _, v in timescales.LEAP_SECONDS]
    assert values == list(range(1, 19))
    dates = np.array([d for d, _ in timescales.LEAP_SECONDS], dtype="datetime64[D]")
    assert (np.diff(dates) > np.timedelta64(0, "D")).all()
    week, sow = gpstime.from_calendar(2031, 1, 1, 0, 0, 0.0)
    assert timescales.leap_seconds_at(week, sow) is None


def test_leap_seconds_of_utc_by_date():
    """UTC instants counted from 1980-01-06 on the GPS grid: 17 s on 2016-12-31T23:59:59,
    18 s from 2017-01-01T00:00:00 UTC (the table's own dates, exact at the step), 0 at
    the GPS epoch, NaN before it and after the table's known date."""

    def utc(*cal):
        week, sow = gpstime.from_calendar(*cal)
        return week * 604800.0 + sow

    got = timescales.leap_seconds_of_utc(
        [
            utc(2016, 12, 31, 23, 59, 59),
            utc(2017, 1, 1, 0, 0, 0),
            0.0,
            -1.0,
            utc(2030, 1, 1, 0, 0, 0),
        ]
    )
    assert got[:3].tolist() == [17.0, 18.0, 0.0]
    assert np.isnan(got[3]) and np.isnan(got[4])
