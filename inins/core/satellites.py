"""Satellite numbering shared by the GNSS layer and the RINEX readers (io may not import
the GNSS layer): one integer per satellite, ``sat = 100 * system + number``.

System indices follow :data:`LETTERS` (G GPS 0, R GLONASS 1, E Galileo 2, C BeiDou 3,
J QZSS 4, S SBAS 5): GPS PRN 5 is 5 (a GPS-only file reads as it always did), GLONASS
slot 9 is 109, Galileo E11 211, BeiDou C12 312, SBAS S20 (PRN 120) 520.
"""

LETTERS = "GRECJS"
"""RINEX system letter of each system index."""


def satellite_number(letter, number):
    """``100 * system + number % 100`` of a RINEX system letter (blank = GPS) and number."""
    return LETTERS.index("G" if letter == " " else letter) * 100 + int(number) % 100
