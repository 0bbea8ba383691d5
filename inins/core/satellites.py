"""Satellite numbering shared by the GNSS layer and the RINEX readers (io may not import
the GNSS layer): one integer per satellite, ``sat = 100 * system + number``.

System indices follow :data:`LETTERS` (G GPS 0, R GLONASS 1, E Galileo 2, C BeiDou 3,
J QZSS 4, S SBAS 5): GPS PRN 5 is 5 (a GPS-only file reads as it always did), GLONASS
slot 9 is 109, Galileo E11 211, BeiDou C12 312, SBAS S20 (PRN 120) 520.
"""

import numpy as np

LETTERS = "GRECJS"
"""RINEX system letter of each system index."""


def satellite_number(letter, number):
    """``100 * system + number % 100`` of a RINEX system letter (blank = GPS) and number."""
    return LETTERS.index("G" if letter == " " else letter) * 100 + int(number) % 100


NUMBER_RANGE = {0: (1, 32), 1: (1, 27), 2: (1, 36), 3: (1, 63), 4: (1, 10), 5: (20, 58)}
"""Valid numbers within each system (GPS PRN, GLONASS slot, Galileo PRN, BeiDou PRN,
QZSS PRN, SBAS PRN - 100)."""
SPAN = 600
"""Satellite numbers are below this (a per-epoch key ``epoch * SPAN + sat`` is unique)."""


def is_valid(sat):
    """True where ``sat`` (array of int-valued floats or ints) is a satellite number of a
    known system in its range (GPS 1-32, GLONASS 101-127, Galileo 201-236, ...)."""
    sat = np.asarray(sat, float)
    whole = np.isfinite(sat) & (sat % 1 == 0) & (sat >= 0) & (sat < SPAN)
    s = np.where(whole, sat, 0).astype(np.int64)
    system, number = s // 100, s % 100
    lo = np.array([NUMBER_RANGE.get(k, (1, 0))[0] for k in range(6)])
    hi = np.array([NUMBER_RANGE.get(k, (1, 0))[1] for k in range(6)])
    known = system < 6
    k = np.where(known, system, 0)
    return whole & known & (number >= lo[k]) & (number <= hi[k])
