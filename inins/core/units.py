"""Named conversion constants: multiply a lab-unit value by one to get SI.

``bias_rad_s = bias_dph * DPH``; divide to go back (``bias_rad_s / DPH``).
"""

import math

DEG = math.pi / 180.0
"""One degree in rad."""
ARCMIN = DEG / 60.0
"""One arc minute in rad."""
ARCSEC = DEG / 3600.0
"""One arc second in rad."""
HOUR = 3600.0
"""One hour in s."""
MINUTE = 60.0
"""One minute in s."""
DPH = DEG / HOUR
"""One deg/h in rad/s."""
DPS = DEG
"""One deg/s in rad/s."""
DEG_RTH = DEG / math.sqrt(HOUR)
"""One deg/sqrt(h) (angle random walk) in rad/sqrt(s)."""
G0 = 9.80665
"""Standard gravity in m/s^2, the unit behind ``_ug`` and ``_mg``."""
MG = 1e-3 * G0
"""One milli-g in m/s^2."""
UG = 1e-6 * G0
"""One micro-g in m/s^2."""
UG_S = UG
"""One micro-g second (accelerometer pulse weight) in m/s."""
UG_RTHZ = UG
"""One micro-g/sqrt(Hz) (velocity random walk) in m/s/sqrt(s)."""
MPS_RTH = 1.0 / math.sqrt(HOUR)
"""One (m/s)/sqrt(h) (velocity random walk) in m/s/sqrt(s)."""
PPM = 1e-6
"""One part per million (scale factor)."""
