"""The fields of a GPS broadcast ephemeris (LNAV, IS-GPS-200 Tables 20-I, 20-III),
in SI units and radians: the one declaration that the GNSS layer
(:class:`inins.gnss.ephemeris.Ephemeris`) and the recorded-flight layout
(:mod:`inins.io.flight_layout`) both use; io may not import the GNSS layer.
"""

FIELDS = (
    ("prn", "int64", "", "satellite PRN number"),
    ("week", "int64", "week", "GPS week of toe (continuous, not mod 1024)"),
    ("toc", "float64", "s", "clock reference time, seconds of week"),
    ("af0", "float64", "s", "clock bias"),
    ("af1", "float64", "s/s", "clock drift"),
    ("af2", "float64", "s/s^2", "clock drift rate"),
    ("iode", "int64", "", "issue of data, ephemeris"),
    ("crs", "float64", "m", "sine harmonic correction to the orbit radius"),
    ("delta_n", "float64", "rad/s", "mean motion difference from the computed value"),
    ("m0", "float64", "rad", "mean anomaly at toe"),
    ("cuc", "float64", "rad", "cosine harmonic correction to the argument of latitude"),
    ("e", "float64", "", "eccentricity"),
    ("cus", "float64", "rad", "sine harmonic correction to the argument of latitude"),
    ("sqrt_a", "float64", "m^0.5", "square root of the semi-major axis"),
    ("toe", "float64", "s", "ephemeris reference time, seconds of week"),
    ("cic", "float64", "rad", "cosine harmonic correction to the inclination"),
    ("omega0", "float64", "rad", "longitude of ascending node at the week start"),
    ("cis", "float64", "rad", "sine harmonic correction to the inclination"),
    ("i0", "float64", "rad", "inclination at toe"),
    ("crc", "float64", "m", "cosine harmonic correction to the orbit radius"),
    ("omega", "float64", "rad", "argument of perigee"),
    ("omega_dot", "float64", "rad/s", "rate of right ascension"),
    ("idot", "float64", "rad/s", "rate of inclination"),
    ("health", "int64", "", "SV health (0 = healthy)"),
    ("tgd", "float64", "s", "group delay differential L1-L2 (P(Y))"),
    ("ura", "float64", "m", "user range accuracy"),
    ("fit_interval", "float64", "h", "curve fit interval (4 h nominal)"),
)
"""(name, dtype, unit, description) of every :class:`Ephemeris` field, in order."""
