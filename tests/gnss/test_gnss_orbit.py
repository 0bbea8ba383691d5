"""Broadcast orbits: self-consistency of real ephemerides, derivatives, closed forms."""

import itertools

import numpy as np
import pytest
from scipy import optimize

from inins.gnss import constellation, ephemeris, gpstime, orbit
from inins.io.rinex_text import gps_week_sow


def _consecutive_pairs(eph):
    """(a, b, gap) for consecutive healthy sets of one PRN within the 2 h fit half-interval."""
    healthy = np.flatnonzero(eph.health == 0)
    full = eph.week * gpstime.WEEK + eph.toe
    for prn in np.unique(eph.prn[healthy]):
        rows = healthy[eph.prn[healthy] == prn]
        for a, b in itertools.pairwise(rows):
            gap = full[b] - full[a]
            if 0 < gap <= 7200.0:
                yield a, b, gap


def test_consecutive_sets_agree_between_their_reference_times(abpo_eph):
    """Positions of two consecutive sets at the same epochs between their toe:
    within 3 m 2 h apart, within 6 m across an upload (other spacing)."""
    worst = {"regular": 0.0, "upload": 0.0}
    count = {"regular": 0, "upload": 0}
    for a, b, gap in _consecutive_pairs(abpo_eph):
        t = abpo_eph.toe[a] + np.linspace(0.0, gap, 61)
        pos_a = orbit.satellite_states(abpo_eph, np.full(61, a), abpo_eph.week[a], t).pos
        pos_b = orbit.satellite_states(abpo_eph, np.full(61, b), abpo_eph.week[a], t).pos
        kind = "regular" if gap == 7200.0 else "upload"
        worst[kind] = max(worst[kind], np.linalg.norm(pos_a - pos_b, axis=1).max())
        count[kind] += 1
    assert count["regular"] >= 60 and count["upload"] >= 20  # 76 and 27 on this day
    assert worst["regular"] <= 3.0  # 1.26 m measured
    assert worst["upload"] <= 6.0  # 5.33 m measured (G21)
    assert worst["regular"] > 0.05  # the sets are different fits, not copies


def test_velocity_and_clock_drift_match_finite_differences(abpo_eph):
    rows = np.flatnonzero(abpo_eph.health == 0)
    t = abpo_eph.toe[rows][:, None] + np.linspace(-7000.0, 7000.0, 15)
    idx = np.broadcast_to(rows[:, None], t.shape)
    week = abpo_eph.week[rows][:, None]
    mid = orbit.satellite_states(abpo_eph, idx, week, t)
    step = 0.5
    ahead = orbit.satellite_states(abpo_eph, idx, week, t + step)
    behind = orbit.satellite_states(abpo_eph, idx, week, t - step)
    fd_vel = (ahead.pos - behind.pos) / (2 * step)
    fd_drift = (ahead.clock - behind.clock) / (2 * step)
    assert np.abs(mid.vel - fd_vel).max() < 1e-3  # m/s
    assert np.abs(mid.drift - fd_drift).max() < 1e-6  # m/s
    speed = np.linalg.norm(mid.vel, axis=-1)
    assert 1500.0 < speed.min() and speed.max() < 4500.0  # ECEF speed of GPS satellites


def test_circular_walker_orbit_radius_and_inertial_speed():
    eph = constellation.walker(1826, 0.0, 86400.0)
    t = np.linspace(0.0, 86400.0, 97)
    idx = ephemeris.select(eph, np.repeat(np.arange(1, 25), 97), 1826, np.tile(t, 24))
    s = orbit.satellite_states(eph, idx, 1826, np.tile(t, 24))
    a = constellation.SEMI_MAJOR_AXIS
    np.testing.assert_allclose(np.linalg.norm(s.pos, axis=1), a, rtol=1e-12)
    vel_i = s.vel + np.cross([0.0, 0.0, orbit.OMEGA_E], s.pos)
    np.testing.assert_allclose(np.linalg.norm(vel_i, axis=1), np.sqrt(orbit.MU / a), rtol=1e-12)
    # sets 2 h apart describe the same orbit: no jump at the switch
    np.testing.assert_allclose(s.clock, 0.0, atol=0.0)


def test_relativistic_clock_term_closed_form(abpo_eph):
    row = int(np.argmax(abpo_eph.e))  # the most eccentric orbit of the day
    e, sqrt_a = abpo_eph.e[row], abpo_eph.sqrt_a[row]
    tk = 3000.0
    n = np.sqrt(orbit.MU / sqrt_a**6) + abpo_eph.delta_n[row]
    m = abpo_eph.m0[row] + n * tk
    ecc = optimize.brentq(lambda x: x - e * np.sin(x) - m, m - 1.0, m + 1.0, xtol=1e-15)
    s = orbit.satellite_states(abpo_eph, row, abpo_eph.week[row], abpo_eph.toe[row] + tk)
    tc = abpo_eph.toe[row] + tk - abpo_eph.toc[row]
    poly = abpo_eph.af0[row] + abpo_eph.af1[row] * tc + abpo_eph.af2[row] * tc**2
    rel = -4.442807633e-10 * e * sqrt_a * np.sin(ecc)
    assert abs(s.clock - orbit.C * (poly + rel)) < 1e-6  # m
    assert abs(orbit.C * rel) > 1.0  # metres of relativistic term for e ~ 0.02
    s_tgd = orbit.satellite_states(
        abpo_eph, row, abpo_eph.week[row], abpo_eph.toe[row] + tk, tgd=True
    )
    assert s.clock - s_tgd.clock == pytest.approx(orbit.C * abpo_eph.tgd[row], abs=1e-9)


def test_select_nearest_healthy_set_within_fit_interval(abpo_eph):
    g08 = abpo_eph.prn == 8
    assert g08.any() and (abpo_eph.health[g08] != 0).all()  # G08 is flagged unhealthy
    t = np.array([345600.0 + 3600.0 * h for h in range(24)])
    assert (ephemeris.select(abpo_eph, 8, 1826, t) == -1).all()
    assert (ephemeris.select(abpo_eph, 8, 1826, t, healthy_only=False) >= 0).any()
    idx = ephemeris.select(abpo_eph, 2, 1826, t)
    ok = idx >= 0
    dt = np.abs(t[ok] - abpo_eph.toe[idx[ok]])
    assert dt.max() <= 7200.0
    rows = np.flatnonzero((abpo_eph.prn == 2) & (abpo_eph.health == 0))
    best = np.min(np.abs(t[ok, None] - abpo_eph.toe[rows][None, :]), axis=1)
    np.testing.assert_array_equal(dt, best)
    assert (ephemeris.select(abpo_eph, 2, 1826, t + 86400.0 * 3) == -1).all()  # too old


def test_gps_time_helpers():
    assert gpstime.from_calendar(2015, 1, 8, 0, 0, 0.0) == (1826, 345600.0)
    assert gpstime.from_calendar(1980, 1, 6, 0, 0, 0.0) == (0, 0.0)
    week, sow = gpstime.from_calendar(21, 11, 12, 3, 31, 32.5)  # two-digit year
    assert (week, sow) == gps_week_sow(21, 11, 12, 3, 31, 32.5)
    np.testing.assert_allclose(
        gpstime.wrap_week_seconds([302399.0, 302400.0, -302401.0, 10.0]),
        [302399.0, -302400.0, 302399.0, 10.0],
    )
    assert gpstime.time_diff(1827, 5.0, 1826, 604795.0) == 10.0
    assert gpstime.normalize(1826, 604800.0 + 3.0) == (1827, 3.0)
    assert str(gpstime.to_datetime64(1826, 345600.0)) == "2015-01-08T00:00:00.000000000"


def test_a_constellation_moved_to_another_week_stands_in_the_same_place(abpo_eph):
    rows = np.flatnonzero(abpo_eph.health == 0)
    sow = abpo_eph.toe[rows] + 600.0
    here = orbit.satellite_states(abpo_eph, rows, abpo_eph.week[rows], sow)
    later = ephemeris.with_week(abpo_eph, 2300)
    there = orbit.satellite_states(later, rows, 2300, sow)
    np.testing.assert_array_equal(there.pos, here.pos)
    assert (ephemeris.select(later, abpo_eph.prn[rows], 2300, sow) >= 0).all()
