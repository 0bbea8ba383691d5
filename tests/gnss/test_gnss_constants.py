"""The constants of the GNSS layer by exact value, from the documents that define them
(a constant can only be wrong by a digit or a sign, and no tolerance should hide
either): carrier frequencies and wavelengths (the ICDs), the GLONASS FDMA channels,
the time-system offsets, the Doppler sign (spec §6a), the satellite numbering."""

import numpy as np

from inins.gnss import gpstime, measurements, systems, timescales
from inins.gnss.propagation import LAMBDA_L1


def test_carrier_frequencies_are_the_icd_values():
    assert systems.C == 299792458.0  # m/s, exact by definition
    assert systems.F_L1 == 1575.42e6 and systems.F_L2 == 1227.60e6  # IS-GPS-200 §3.3.1.1
    assert systems.F_B1I == 1561.098e6 and systems.F_B3I == 1268.52e6  # BDS-SIS-ICD-B1I
    assert systems.F_E5A == 1176.45e6  # Galileo OS SIS ICD §2.4
    assert LAMBDA_L1 == systems.C / 1575.42e6
    assert round(LAMBDA_L1, 10) == 0.1902936728  # spec §6a


def test_glonass_channel_k_is_1602_plus_0_5625_k_mhz():
    """GLONASS ICD 2008 §3.3.1.1: f_k1 = 1602 + 0.5625 k MHz, f_k2 = 1246 + 0.4375 k MHz,
    k = -7 ... +6; channel 0 at the centre, the positive channels above it."""
    for k in range(-7, 7):
        sat = np.array([109])
        want = systems.C / ((1602.0 + 0.5625 * k) * 1e6)
        assert systems.l1_wavelength(sat, np.array([float(k)]))[0] == want
        assert systems.F_G2 + k * systems.DF_G2 == (1246.0 + 0.4375 * k) * 1e6
    assert systems.F_G1 + 6 * systems.DF_G1 == 1605.375e6
    assert systems.F_G1 - 7 * systems.DF_G1 == 1598.0625e6
    # without a channel a GLONASS wavelength is unknown, never a GPS one
    assert np.isnan(systems.l1_wavelength(np.array([109]))[0])


def test_band_one_wavelength_of_each_system():
    sats = np.array([5, 211, 312, 401])  # GPS G05, Galileo E11, BeiDou C12, QZSS J01
    got = systems.l1_wavelength(sats)
    want = systems.C / np.array([1575.42e6, 1575.42e6, 1561.098e6, 1575.42e6])
    np.testing.assert_array_equal(got, want)
    assert systems.iono_scale(np.array([312]))[0] == (1575.42e6 / 1561.098e6) ** 2


def test_doppler_is_minus_the_range_rate_over_the_wavelength():
    """spec §6a: a growing range (moving apart) has a negative Doppler."""
    assert measurements.range_rate_from_doppler(-1000.0) == 1000.0 * LAMBDA_L1
    assert measurements.range_rate_from_doppler(np.array([5.0]))[0] < 0.0


def test_time_system_offsets():
    """BDT = GPST - 14 s, BDT week 0 = GPS week 1356; GLONASST = UTC(SU) + 3 h; the
    week wrap at +-302400 s (spec §10, §6a)."""
    assert timescales.gps_from_bdt(0, 0.0) == (1356, 14.0)
    assert timescales.bdt_from_gps(1356, 14.0) == (0, 0.0)
    week, sow = timescales.gps_from_glonasst(2000, 3 * 3600.0, 18)
    assert (week, sow) == (2000, 18.0)
    assert gpstime.wrap_week_seconds(604800.0 - 1.0) == -1.0
    assert gpstime.wrap_week_seconds(-302401.0) == 604800.0 - 302401.0
    assert gpstime.WEEK == 604800.0 and gpstime.HALF_WEEK == 302400.0


def test_satellite_numbers():
    assert systems.rinex_name(109) == "R09" and systems.rinex_name(312) == "C12"
    assert systems.satellite_id("E11") == 211 and systems.satellite_id("G05") == 5
    assert systems.system_of(np.array([5, 109, 211, 312]))[2] == systems.GALILEO
