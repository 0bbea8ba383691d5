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
