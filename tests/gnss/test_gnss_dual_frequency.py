"""Dual-frequency Galileo (E1/E5a) and BeiDou (B1I/B3I) code: the ionosphere-free
combination with each pair's frequencies, and the BeiDou group delay it carries (the
broadcast BeiDou clock refers to B3I; BDS-SIS-ICD-B1I 3.0 §5.2.4.10)."""

from pathlib import Path

import numpy as np
import pytest

from inins.gnss import broadcast, measurements, systems
from inins.gnss.measurements import Signal
from inins.io.rinex_nav import read_navigation
from inins.io.rinex_obs import read_obs, system_observable, write_obs_v3

MIXED = Path(__file__).resolve().parents[2] / "data" / "smartloc"
MIXED = MIXED / "BRDC00WRD_U_20161580000_01D_MN.rnx.gz"
C = systems.C
RANGE, IONO = 2.3e7, 7.0  # m: a range and the band-1 ionospheric delay


@pytest.fixture(scope="module")
def nav():
    mixed = read_navigation(MIXED, leap_seconds=17)
    return broadcast.from_records(mixed.records, mixed.glonass)


def test_galileo_e1_e5a_removes_the_ionosphere():
    """E1 = R + I, E5a = R + I (f_E1 / f_E5a)^2: the combination gives R; with GPS's
    L1/L2 ratio 1.6 m of the 7 m would stay."""
    p1 = np.array([RANGE + IONO])
    p2 = np.array([RANGE + IONO * (systems.F_L1 / systems.F_E5A) ** 2])
    pr, signal = measurements.code_pseudorange(p1, p2, [np.nan], np.array([211]))
    assert abs(pr[0] - RANGE) < 1e-6 and signal[0] == Signal.IONO_FREE
    as_gps, _ = measurements.code_pseudorange(p1, p2, [np.nan])
    assert abs(as_gps[0] - RANGE) > 1.0


def _beidou_row(nav, signal, pseudorange):
    """A one-row observation of the first BeiDou MEO/IGSO set with TGD1 != 0, at its toe
    (GPS time: BDT + 14 s, BDT week 0 = GPS week 1356)."""
    k = int(np.flatnonzero((nav.kepler.prn // 100 == 3) & (nav.kepler.tgd != 0.0))[0])
    week = int(nav.kepler.week[k]) + 1356
    obs = measurements.make_observations(
        week,
        np.array([nav.kepler.toe[k] + 14.0 + 0.1]),
        np.array([0, 1]),
        nav.kepler.prn[k : k + 1],
        np.array([pseudorange]),
        signal=signal,
    )
    return measurements.attach_satellites(obs, nav), k


def test_beidou_b1i_b3i_carries_2_94_tgd1(nav):
    """B1I = R + c TGD1 + I, B3I = R + I (f_B1I / f_B3I)^2 (the clock refers to B3I):
    the combination removes I and is late by gamma / (gamma - 1) = 2.944 TGD1; the
    satellite clock of an ionosphere-free BeiDou row takes that off, of a B1I row TGD1."""
    _, k = _beidou_row(nav, Signal.L1, RANGE)
    tgd1 = float(nav.kepler.tgd[k])
    gamma = (systems.F_B1I / systems.F_B3I) ** 2
    p1 = np.array([RANGE + C * tgd1 + IONO])
    p2 = np.array([RANGE + IONO * gamma])
    pr, signal = measurements.code_pseudorange(p1, p2, [np.nan], np.array([312]))
    factor = gamma / (gamma - 1.0)
    assert factor == pytest.approx(2.944, abs=1e-3)
    assert abs(pr[0] - (RANGE + factor * C * tgd1)) < 1e-6 and signal[0] == Signal.IONO_FREE
    single, _ = _beidou_row(nav, Signal.L1, RANGE)
    dual, _ = _beidou_row(nav, Signal.IONO_FREE, RANGE)
    assert single.eph_index[0] == dual.eph_index[0]
    tgd = C * float(nav.kepler.tgd[single.eph_index[0]])
    assert abs(tgd) > 1.0  # metres: the term matters
    # the same transmit time to a few ns: the clocks differ by the group delays alone
    diff = single.sat_clock[0] - dual.sat_clock[0]
    assert diff == pytest.approx((factor - 1.0) * tgd, abs=1e-4)


def test_the_rinex_3_reader_pairs_e1_e5a_and_b1i_b3i(tmp_path):
    """A RINEX 3 file with C1C/C5Q (Galileo) and C2I/C6I (BeiDou): P1/P2 are those
    codes, and the pseudorange of each row is its pair's combination."""
    prn = np.array([211, 312])
    e1, e5a = RANGE + IONO, RANGE + IONO * (systems.F_L1 / systems.F_E5A) ** 2
    b1, b3 = RANGE + IONO, RANGE + IONO * (systems.F_B1I / systems.F_B3I) ** 2
    path = tmp_path / "dual.rnx"
    columns = {
        "E": (("C1C", "C5Q"), np.array([[e1, e5a], [np.nan, np.nan]])),
        "C": (("C2I", "C6I"), np.array([[np.nan, np.nan], [b1, b3]])),
    }
    write_obs_v3(path, np.array([1900]), np.array([100.0]), np.array([0, 2]), prn, columns)
    obs = read_obs(path, "EC")
    p1, p2 = system_observable(obs, "P1"), system_observable(obs, "P2")
    np.testing.assert_allclose(p1, [e1, b1], atol=1e-3)
    np.testing.assert_allclose(p2, [e5a, b3], atol=1e-3)
    pr, signal = measurements.code_pseudorange(p1, p2, system_observable(obs, "C1"), obs.prn)
    np.testing.assert_allclose(pr, RANGE, atol=5e-3)  # the file's 1 mm resolution, amplified
    assert (signal == Signal.IONO_FREE).all()
