"""Galileo, BeiDou and GLONASS satellite states at the epochs of the smartLoc mixed RINEX 3
navigation file, against computations written here from the ICDs (a code path that does
not call inins.gnss.orbit or inins.gnss.glonass), and the time systems."""

import math
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from inins.exceptions import InputError
from inins.gnss import broadcast, glonass, gpstime, orbit, systems, timescales
from inins.io.rinex_nav import read_navigation

DATA = Path(__file__).resolve().parents[2] / "data" / "smartloc"
MIXED = DATA / "BRDC00WRD_U_20161580000_01D_MN.rnx.gz"


@pytest.fixture(scope="module")
def mixed():
    return read_navigation(MIXED, leap_seconds=17)


@pytest.fixture(scope="module")
def nav(mixed):
    return broadcast.from_records(mixed.records, mixed.glonass)


def test_time_systems():
    # BDT started 2006-01-01 00:00:00 UTC (a Sunday), when GPS - UTC was 14 s
    assert tuple(map(float, timescales.gps_from_bdt(0, 0.0))) == (1356.0, 14.0)
    week, sow = timescales.bdt_from_gps(1356, 10.0)  # 4 s before BDT week 0
    assert (int(week), float(sow)) == (-1, 604796.0)
    # GLONASS time is UTC(SU) + 3 h: 03:00 GLONASST on a Monday is 00:00 UTC, + 17 leap s
    w, s = gpstime.from_calendar(2016, 6, 6, 3, 0, 0.0)
    gw, gs = timescales.gps_from_glonasst(w, s, 17)
    assert int(gw) == 1900 and float(gs) == 86400.0 + 17.0
    # the GLONASS .g records: tb 00:15:00 UTC of Monday 2016-06-06 -> GPS 86400 + 900 + 17 s
    g = read_navigation(DATA / "brdc1580.16g.gz")
    assert g.leap_seconds == 17 and g.glonass["toe"][0] == 86400.0 + 900.0 + 17.0


def test_the_mixed_file_holds_four_systems(mixed):
    system = mixed.records["prn"] // 100
    counts = {s: int((system == k).sum()) for s, k in (("G", 0), ("E", 2), ("C", 3))}
    assert counts == {"G": 295, "E": 126, "C": 32} and len(mixed.glonass) == 588
    assert mixed.systems == "GREC"
    assert set(np.unique(mixed.glonass["channel"])) <= set(range(-7, 7))


def test_mixed_time_systems_without_the_offset_name_the_line():
    with pytest.raises(InputError, match="LEAP SECONDS") as err:
        read_navigation(MIXED)
    assert err.value.line == 29  # the first GLONASS record (R09)
    with pytest.raises(InputError, match="leap seconds 18 given, the header states 17"):
        read_navigation(DATA / "brdc1580.16g.gz", leap_seconds=18)


def _kepler_icd(rec, t_sys, gm, omega_e, geo):
    """One satellite position (ECEF, m) from the ICD tables, plain Python.

    Galileo OS SIS ICD 2.0 Table 58 / BDS-SIS-ICD-B1I 3.0 Table 5-11 (IGSO/MEO) and the
    GEO branch of the same table (R_Z(omega_e tk) R_X(-5 deg)).
    """
    a = rec["sqrt_a"] ** 2
    tk = t_sys - rec["toe"]
    if tk > 302400.0:
        tk -= 604800.0
    elif tk < -302400.0:
        tk += 604800.0
    n = math.sqrt(gm / a**3) + rec["delta_n"]
    m = rec["m0"] + n * tk
    e = rec["e"]
    ecc = m
    for _ in range(30):
        ecc = m + e * math.sin(ecc)  # fixed-point iteration, not Newton
    nu = math.atan2(math.sqrt(1 - e * e) * math.sin(ecc), math.cos(ecc) - e)
    phi = nu + rec["omega"]
    du = rec["cus"] * math.sin(2 * phi) + rec["cuc"] * math.cos(2 * phi)
    dr = rec["crs"] * math.sin(2 * phi) + rec["crc"] * math.cos(2 * phi)
    di = rec["cis"] * math.sin(2 * phi) + rec["cic"] * math.cos(2 * phi)
    u, r = phi + du, a * (1 - e * math.cos(ecc)) + dr
    i = rec["i0"] + rec["idot"] * tk + di
    xp, yp = r * math.cos(u), r * math.sin(u)
    if geo:
        node = rec["omega0"] + rec["omega_dot"] * tk - omega_e * rec["toe"]
    else:
        node = rec["omega0"] + (rec["omega_dot"] - omega_e) * tk - omega_e * rec["toe"]
    g = np.array(
        [
            xp * math.cos(node) - yp * math.cos(i) * math.sin(node),
            xp * math.sin(node) + yp * math.cos(i) * math.cos(node),
            yp * math.sin(i),
        ]
    )
    if not geo:
        return g
    f = math.radians(-5.0)
    rx = np.array([[1, 0, 0], [0, math.cos(f), math.sin(f)], [0, -math.sin(f), math.cos(f)]])
    z = omega_e * tk
    rz = np.array([[math.cos(z), math.sin(z), 0], [-math.sin(z), math.cos(z), 0], [0, 0, 1]])
    return rz @ rx @ g


@pytest.mark.parametrize(
    ("letter", "gm", "omega_e"),
    [("E", 3.986004418e14, 7.2921151467e-5), ("C", 3.986004418e14, 7.292115e-5)],
)
def test_galileo_and_beidou_positions_against_the_icd(mixed, nav, letter, gm, omega_e):
    """Every Galileo / BeiDou record at its toc and +-1 h (requested in GPS time: BeiDou
    sets are in BDT, 14 s behind): within 1 cm of the ICD computation (measured: Galileo
    0.14 mm, BeiDou 2e-8 m)."""
    recs = mixed.records[mixed.records["prn"] // 100 == systems.SYSTEMS[letter]]
    kep = nav.kepler
    worst, geo_seen = 0.0, 0
    for rec in recs:
        row = int(np.flatnonzero((kep.prn == rec["prn"]) & (kep.toe == rec["toe"]))[0])
        geo = letter == "C" and rec["prn"] % 100 in (1, 2, 3, 4, 5)
        geo_seen += geo
        for dt in (-3600.0, 0.0, 3600.0):
            t_sys = rec["toc"] + dt
            shift = 14.0 if letter == "C" else 0.0
            week_gps = rec["week"] + (1356 if letter == "C" else 0)
            w, s = gpstime.normalize(week_gps, t_sys + shift)
            ours = orbit.satellite_states(kep, np.array([row]), w, np.array([s])).pos[0]
            theirs = _kepler_icd(rec, t_sys, gm, omega_e, geo)
            worst = max(worst, float(np.linalg.norm(ours - theirs)))
    assert worst < 0.01
    if letter == "C":
        assert geo_seen >= 9  # C01-C05 in the file: the GEO rotation is exercised


def test_the_beidou_geo_rotation_matters(mixed, nav):
    """Without the -5 deg rotation a GEO position is off by ~3,700 km: the test above can fail."""
    rec = mixed.records[mixed.records["prn"] == 301][0]
    plain = _kepler_icd(rec, rec["toe"], 3.986004418e14, 7.292115e-5, geo=False)
    rotated = _kepler_icd(rec, rec["toe"], 3.986004418e14, 7.292115e-5, geo=True)
    assert np.linalg.norm(plain - rotated) > 1e6


def test_keplerian_velocity_is_the_derivative_of_position(nav):
    kep = nav.kepler
    rows = np.flatnonzero(np.isin(kep.prn // 100, [2, 3]))
    week = np.where(kep.prn[rows] // 100 == 3, kep.week[rows] + 1356, kep.week[rows])
    t = kep.toe[rows] + 600.0 + np.where(kep.prn[rows] // 100 == 3, 14.0, 0.0)
    h = 0.01
    mid = orbit.satellite_states(kep, rows, week, t)
    plus = orbit.satellite_states(kep, rows, week, t + h)
    minus = orbit.satellite_states(kep, rows, week, t - h)
    fd = (plus.pos - minus.pos) / (2 * h)
    assert np.abs(fd - mid.vel).max() < 1e-4  # m/s (GEO included)
    assert np.abs((plus.clock - minus.clock) / (2 * h) - mid.drift).max() < 1e-6


def _glonass_rhs(_, x, acc):
    """GLONASS ICD 2016 Appendix J equations of motion (PZ-90.11, rotating frame)."""
    gm, ae, j2, w = 398600.4418e9, 6378136.0, 1082625.75e-9, 7.292115e-5
    r = np.linalg.norm(x[:3])
    c = 1.5 * j2 * gm * ae**2 / r**5
    zz = 5.0 * x[2] ** 2 / r**2
    ax = -gm / r**3 * x[0] - c * x[0] * (1 - zz) + w**2 * x[0] + 2 * w * x[4] + acc[0]
    ay = -gm / r**3 * x[1] - c * x[1] * (1 - zz) + w**2 * x[1] - 2 * w * x[3] + acc[1]
    az = -gm / r**3 * x[2] - c * x[2] * (3 - zz) + acc[2]
    return np.concatenate([x[3:], [ax, ay, az]])


def test_glonass_rk4_against_dop853_over_15_minutes(mixed, nav):
    """The broadcast states of 24 records propagated +-15 min by RK4 (60 s steps) and by
    scipy's DOP853 at rtol 1e-12: within 1 m (they agree to 1.6 mm)."""
    g = nav.glonass
    rows = np.arange(0, len(g), max(len(g) // 24, 1))[:24]
    worst = 0.0
    for dt in (-900.0, -450.0, 900.0):
        ours = glonass.satellite_states(g, rows, g.week[rows], g.toe[rows] + dt)
        for k, row in enumerate(rows):
            x0 = np.concatenate([g.pos[row], g.vel[row]])
            sol = solve_ivp(
                _glonass_rhs, (0.0, dt), x0, method="DOP853", rtol=1e-12, atol=1e-6,
                args=(g.acc[row],),
            )  # fmt: skip
            worst = max(worst, float(np.linalg.norm(sol.y[:3, -1] - ours.pos[k])))
    assert worst < 1.0
    assert worst < 0.05  # measured 1.6 mm: RK4 at 60 s is far inside the 1 m requirement


def test_glonass_consecutive_sets_meet(nav):
    """A set propagated 15 min forward and the next propagated 15 min back meet within
    ~10 m (the broadcast's own fit; a sign error in J2 or the Coriolis terms gives km)."""
    g = nav.glonass
    same = (g.sat[1:] == g.sat[:-1]) & (np.diff(g.toe + 604800.0 * g.week) == 1800.0)
    a = np.flatnonzero(same)[:40]
    t = g.toe[a] + 900.0
    fwd = glonass.satellite_states(g, a, g.week[a], t)
    back = glonass.satellite_states(g, a + 1, g.week[a], t)
    gap = np.linalg.norm(fwd.pos - back.pos, axis=1)
    assert np.median(gap) < 10.0 and gap.max() < 50.0


def test_mixed_selection_routes_each_system(nav):
    week, sow = 1900, 86400.0 + 22 * 3600.0
    gps = nav.kepler.prn[(nav.kepler.prn < 100) & (np.abs(nav.kepler.toe - sow) < 3600.0)][0]
    sat = np.array([gps, 109, 211, 312])
    index = broadcast.select(nav, sat, week, sow)
    assert (index >= 0).all()
    states = broadcast.satellite_states(nav, sat, index, week, np.full(4, sow))
    radius = np.linalg.norm(states.pos, axis=1)
    assert 2.6e7 < radius[0] < 2.7e7  # GPS MEO
    assert 2.5e7 < radius[1] < 2.6e7  # GLONASS 25,500 km
    assert 2.9e7 < radius[2] < 3.0e7  # Galileo 29,600 km
    assert 2.7e7 < radius[3] < 2.8e7  # BeiDou MEO (C12)
