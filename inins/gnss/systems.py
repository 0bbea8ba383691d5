"""Satellite systems: one integer per satellite, and the constants each system's ICD states.

A satellite is one integer ``sat = 100 * system + number`` (:data:`SYSTEMS` gives
the system index): GPS PRN 1-32 are 1-32 (so a GPS-only file reads exactly as
before), GLONASS slot 9 is 109, Galileo E11 is 211, BeiDou C12 is 312, QZSS J01
is 401, SBAS S20 (PRN 120) is 520. :func:`satellite_id` and :func:`rinex_name`
convert to and from the RINEX three-character name.

The per-system constants (docs/gnss.md, "per-system differences"):

=========  =================  ===================  ==========================
system     GM (m^3/s^2)       Earth rate (rad/s)   source
=========  =================  ===================  ==========================
GPS        3.986005e14        7.2921151467e-5      IS-GPS-200 Table 20-IV
GLONASS    3.9860044418e14    7.292115e-5          GLONASS ICD 2016 (PZ-90.11)
Galileo    3.986004418e14     7.2921151467e-5      Galileo OS SIS ICD §5.1.1
BeiDou     3.986004418e14     7.292115e-5          BDS-SIS-ICD-B1I 3.0 §5.2.4
QZSS       3.986005e14        7.2921151467e-5      IS-QZSS-PNT (as GPS)
=========  =================  ===================  ==========================
"""

import numpy as np

from inins.core.satellites import LETTERS, satellite_number
from inins.exceptions import InputError

GPS, GLONASS, GALILEO, BEIDOU, QZSS, SBAS = 0, 1, 2, 3, 4, 5
"""System indices (``sat // 100``)."""
SYSTEMS = {letter: k for k, letter in enumerate(LETTERS)}
"""RINEX letter -> system index."""
NAMES = {GPS: "GPS", GLONASS: "GLONASS", GALILEO: "Galileo", BEIDOU: "BeiDou",
         QZSS: "QZSS", SBAS: "SBAS"}  # fmt: skip
"""Readable name of each system index."""

C = 299792458.0
"""Speed of light (m/s)."""

GM = np.array(
    [3.986005e14, 3.9860044418e14, 3.986004418e14, 3.986004418e14, 3.986005e14, 3.986005e14]
)
"""Earth gravitational constant of each system's orbit model (m^3/s^2), by system index."""
OMEGA_E = np.array(
    [7.2921151467e-5, 7.292115e-5, 7.2921151467e-5, 7.292115e-5, 7.2921151467e-5, 7.2921151467e-5]
)
"""Earth rotation rate of each system's orbit model (rad/s), by system index."""
F_REL = np.array([-4.442807633e-10, 0.0, -4.442807309e-10, -4.442807309e-10, -4.442807633e-10, 0.0])
"""Relativistic clock constant ``-2 sqrt(GM) / c^2`` (s/m^0.5) as each ICD states it
(GLONASS and SBAS broadcast clocks include the term)."""

F_L1 = 1575.42e6
"""GPS L1, Galileo E1, QZSS L1 carrier (Hz)."""
F_L2 = 1227.60e6
"""GPS L2 (Hz)."""
F_B1I = 1561.098e6
"""BeiDou B1I carrier (Hz)."""
F_E5A = 1176.45e6
"""Galileo E5a (and GPS L5) carrier (Hz)."""
F_B3I = 1268.52e6
"""BeiDou B3I carrier (Hz), the reference of the broadcast BeiDou clock."""
F_G1 = 1602.0e6
"""GLONASS G1 centre (Hz); channel k: ``F_G1 + k * DF_G1``."""
DF_G1 = 0.5625e6
"""GLONASS G1 channel spacing (Hz)."""
F_G2 = 1246.0e6
"""GLONASS G2 centre (Hz); channel k: ``F_G2 + k * DF_G2``."""
DF_G2 = 0.4375e6
"""GLONASS G2 channel spacing (Hz)."""

BEIDOU_GEO = frozenset((1, 2, 3, 4, 5, 59, 60, 61, 62, 63))
"""BeiDou PRNs in geostationary orbit (BDS-2 C01-C05, BDS-3 C59-C63)."""


GAMMA_DUAL = np.array(
    [
        (F_L1 / F_L2) ** 2,
        (9.0 / 7.0) ** 2,
        (F_L1 / F_E5A) ** 2,
        (F_B1I / F_B3I) ** 2,
        (F_L1 / F_L2) ** 2,
        (F_L1 / F_L2) ** 2,
    ]
)
"""``(f1 / f2)^2`` of each system's dual-frequency code pair, by system index: GPS and
QZSS L1/L2 P(Y), GLONASS G1/G2 (9/7, every channel), Galileo E1/E5a, BeiDou B1I/B3I
(SBAS: unused)."""


def dual_group_delay_factor(sat):
    """Factor on the broadcast group delay (``tgd``, the band-1 one) that an ionosphere-free
    pseudorange of each satellite carries, relative to the broadcast clock (1 (m,)):
    0 where the clock refers to that combination (GPS and QZSS P1/P2, Galileo E1/E5a
    with an F/NAV clock; GLONASS has no group delay), BeiDou ``gamma / (gamma - 1)``
    with ``gamma = (f_B1I / f_B3I)^2`` (2.94): the clock refers to B3I, and B1I is
    late by TGD1, so ``(gamma B1I - B3I) / (gamma - 1)`` is late by that many TGD1
    (BDS-SIS-ICD-B1I 3.0 §5.2.4.10)."""
    g = GAMMA_DUAL[BEIDOU]
    return np.where(system_of(sat) == BEIDOU, g / (g - 1.0), 0.0)


def system_of(sat):
    """System index of satellite numbers (array or scalar)."""
    return np.asarray(sat) // 100


def number_of(sat):
    """PRN (GPS, Galileo, BeiDou, QZSS), slot (GLONASS) or PRN - 100 (SBAS) of ``sat``."""
    return np.asarray(sat) % 100


def satellite_id(name, source=None, line=None):
    """Satellite number of a RINEX name ('G01', 'R20', 'E11', ' 5' meaning GPS 5).

    Raises
    ------
    InputError
        An unknown system letter or an unreadable number (file and line named).
    """
    try:
        return satellite_number(name[0], name[1:])
    except ValueError:
        raise InputError(f"unknown satellite {name!r}", source=source, line=line) from None


def rinex_name(sat):
    """RINEX three-character name of a satellite number (109 -> 'R09')."""
    return f"{LETTERS[int(sat) // 100]}{int(sat) % 100:02d}"


def l1_wavelength(sat, channel=None):
    """Carrier wavelength (m) of the band-1 signal of each satellite (GPS L1, GLONASS G1
    of its channel, Galileo E1, BeiDou B1I, QZSS L1, SBAS L1).

    Parameters
    ----------
    sat : array_like of int, shape (m,)
    channel : array_like of float, shape (m,), optional
        GLONASS frequency channel per row (NaN elsewhere); needed for GLONASS rows.

    Returns
    -------
    ndarray, shape (m,), m (NaN on GLONASS rows without a channel)
    """
    system = system_of(sat)
    freq = np.where(system == BEIDOU, F_B1I, F_L1)
    if channel is not None:
        freq = np.where(system == GLONASS, F_G1 + np.asarray(channel, float) * DF_G1, freq)
    else:
        freq = np.where(system == GLONASS, np.nan, freq)
    return C / freq


def iono_scale(sat):
    """``(f_L1 / f)^2`` of each satellite's band-1 signal: scales a Klobuchar delay
    (computed for GPS L1) to the signal (GLONASS at the G1 centre, BeiDou B1I)."""
    system = system_of(sat)
    freq = np.where(system == BEIDOU, F_B1I, np.where(system == GLONASS, F_G1, F_L1))
    return (F_L1 / freq) ** 2
