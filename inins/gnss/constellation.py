"""A nominal 24-satellite Walker constellation as broadcast ephemerides.

Walker delta 55 deg: 24/6/1 (six planes of four satellites, inter-plane phasing
1), semi-major axis 26,559.7 km (half a sidereal day), circular Keplerian
orbits. The orbits are expressed as ordinary :class:`~inins.gnss.ephemeris.Ephemeris`
sets (harmonic corrections, clock and group delay zero), one per satellite
every 2 h, so that the rest of the layer treats a nominal constellation and
a real navigation file the same way.
"""

import numpy as np

from inins.core.units import DEG
from inins.gnss import ephemeris
from inins.gnss.orbit import MU, OMEGA_E

SEMI_MAJOR_AXIS = 26_559_700.0
"""GPS nominal semi-major axis (m)."""
SQRT_A = float(np.sqrt(SEMI_MAJOR_AXIS))
"""Its square root (m^0.5), the broadcast parameter."""


def walker(
    week,
    start_sow,
    duration_s,
    *,
    planes=6,
    per_plane=4,
    phasing=1,
    inclination=55.0 * DEG,
    sqrt_a=SQRT_A,
    raan0=0.0,
    step_s=7200.0,
):
    """Ephemeris sets of a Walker delta constellation i: t/p/f.

    Satellite ``j`` of plane ``k`` (PRN ``k * per_plane + j + 1``) has right
    ascension ``raan0 + 2 pi k / planes`` and argument of latitude at
    ``start_sow`` of ``2 pi j / per_plane + 2 pi phasing k / (planes per_plane)``.

    Parameters
    ----------
    week : int
    start_sow, duration_s : float, s
        Sets are referenced every ``step_s`` from ``start_sow`` to past the end.
    planes, per_plane, phasing : int
    inclination : float, rad
    sqrt_a : float, m^0.5
    raan0 : float, rad (inertial, at ``start_sow``)
    step_s : float, s

    Returns
    -------
    Ephemeris
    """
    n_sat = planes * per_plane
    plane, slot = np.divmod(np.arange(n_sat), per_plane)
    raan = raan0 + 2.0 * np.pi * plane / planes
    u0 = 2.0 * np.pi * slot / per_plane + 2.0 * np.pi * phasing * plane / n_sat
    n_motion = np.sqrt(MU / sqrt_a**6)
    toe = start_sow + step_s * np.arange(int(np.ceil(duration_s / step_s)) + 1)
    prn = np.repeat(np.arange(1, n_sat + 1), len(toe))
    t = np.tile(toe, n_sat)
    dt = t - start_sow
    # longitude of the node at the week start so that Omega(t) = raan - omega_e t (ECEF)
    omega0 = np.repeat(raan, len(toe))
    zero = np.zeros(len(prn))
    cols = {name: zero for name, *_ in ephemeris.FIELDS}
    cols.update(
        prn=prn,
        week=np.full(len(prn), week),
        toc=t,
        toe=t,
        sqrt_a=np.full(len(prn), sqrt_a),
        m0=np.mod(np.repeat(u0, len(toe)) + n_motion * dt, 2.0 * np.pi),
        i0=np.full(len(prn), inclination),
        omega0=omega0 - OMEGA_E * start_sow,
        ura=np.full(len(prn), 2.0),
        fit_interval=np.full(len(prn), 4.0),
        iode=np.tile(np.arange(len(toe)), n_sat),
    )
    return ephemeris.from_columns(cols)
