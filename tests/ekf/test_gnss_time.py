"""Solutions moved from the filter's axis to GNSS time (:mod:`inins.ekf.gnss_time`), and
the absolute start, each against a closed form."""

import numpy as np
import pytest

from inins.core import error_model, rotation
from inins.ekf import gnss_time
from inins.ekf.post import Solution
from inins.gnss import gpstime

LLA0 = np.array([0.6, 2.0, 50.0])


def _circle(t):
    """A vehicle on a circle of 100 m radius at 10 m/s, heading along the track: NED
    position, velocity and attitude at times ``t`` (s)."""
    w = 0.1
    pos = np.stack([100 * np.sin(w * t), 100 * (1 - np.cos(w * t)), 0 * t], -1)
    vel = np.stack([10 * np.cos(w * t), 10 * np.sin(w * t), 0 * t], -1)
    quat = np.array([rotation.quat_from_mat(rotation.mat_from_euler(0, 0, w * a)) for a in t])
    return pos, vel, quat


def test_on_gnss_time_gives_the_state_at_the_labelled_time():
    """A filter whose epoch tagged t holds the vehicle of GNSS time t - 0.12 s (offset
    state 0.12 s) on a 10 m/s turn: moved, the position matches the vehicle at t within
    1 cm (second order: a dt^2 / 2 = 7 mm; measured 7.2 mm), the velocity within
    2 mm/s (0.7 mm/s), the attitude within 0.001 deg (3e-5 deg); unmoved they are 1.2 m,
    0.12 m/s and 0.69 deg off. A sign flip of
    the shift doubles the error."""
    t = np.arange(0.0, 60.0, 0.25)
    dt = 0.12
    pos, vel, quat = _circle(t - dt)
    lla = error_model.lla_offset(np.broadcast_to(LLA0, (t.size, 3)), pos)
    sol = Solution(
        quat, vel, lla, np.zeros((t.size, 6)), np.zeros((t.size, 15)), np.full(t.size, dt)
    )
    moved = gnss_time.on_gnss_time(t, sol)
    want_pos, want_vel, want_q = _circle(t)
    want_lla = error_model.lla_offset(np.broadcast_to(LLA0, (t.size, 3)), want_pos)

    def errors(s):
        dp = error_model.position_error_ned(s.lla, want_lla)
        dv = s.vel - want_vel
        dq = [
            rotation.mat_from_quat(a).T @ rotation.mat_from_quat(b)
            for a, b in zip(s.quat, want_q, strict=True)
        ]
        da = np.degrees([np.arccos(np.clip((np.trace(m) - 1) / 2, -1, 1)) for m in dq])
        inner = slice(1, -1)  # the end differences are one-sided
        return (
            np.abs(dp[inner]).max(),
            np.abs(dv[inner]).max(),
            da[inner].max(),
        )

    p, v, a = errors(moved)
    print("moved", p, v, a, "unmoved", errors(sol))
    assert p < 0.01 and v < 0.002 and a < 0.001
    p0, v0, a0 = errors(sol)
    assert p0 > 1.1 and v0 > 0.1 and a0 > 0.6
    assert gnss_time.on_gnss_time(t, Solution(quat, vel, lla, None, None, None)).lla is lla


def test_absolute_start_in_gps_and_utc():
    """2024-07-08 12:00:00 UTC is GPS 12:00:18 (18 leap seconds): week 2322, Monday."""
    week, sow = gpstime.from_calendar(2024, 7, 8, 12, 0, 18.0)
    start = gnss_time.absolute_start(float(week * 604800 + sow))
    assert (start.week, start.sow) == (2322, pytest.approx(86400 + 43218.0, abs=1e-6))
    assert start.utc == "2024-07-08T12:00:00.000Z"
