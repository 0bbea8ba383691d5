"""Broadcast navigation data of all systems: Keplerian sets (GPS, Galileo, BeiDou, QZSS)
and GLONASS state vectors, with one selection and one state call for mixed rows."""

from dataclasses import dataclass, field

import numpy as np

from inins.gnss import ephemeris, orbit, systems
from inins.gnss import glonass as glonass_orbit
from inins.gnss.orbit import SatelliteStates


@dataclass(frozen=True)
class Navigation:
    """Navigation data of a mixed file.

    Attributes
    ----------
    kepler : Ephemeris
        GPS, Galileo, BeiDou and QZSS sets (``prn`` holds the satellite number of
        :mod:`inins.gnss.systems`; BeiDou week and times in BDT).
    glonass : inins.gnss.glonass.GlonassEphemeris
    """

    kepler: ephemeris.Ephemeris
    glonass: glonass_orbit.GlonassEphemeris = field(default_factory=glonass_orbit.empty)

    @property
    def systems(self):
        """Sorted system indices with at least one set."""
        s = set(systems.system_of(self.kepler.prn).tolist()) | set(
            systems.system_of(self.glonass.sat).tolist()
        )
        return sorted(s)


def as_navigation(eph):
    """A :class:`Navigation` of an :class:`Ephemeris` (GPS only) or a Navigation."""
    return eph if isinstance(eph, Navigation) else Navigation(kepler=eph)


def select(nav, sat, week, sow, *, max_age_s=7200.0):
    """Set row per (satellite, GPS time): into ``nav.kepler`` or, for GLONASS satellites,
    into ``nav.glonass`` (within its 15 min validity); -1 where none qualifies."""
    sat = np.asarray(sat, np.int64)
    glo = systems.system_of(sat) == systems.GLONASS
    if not glo.any():
        return ephemeris.select(nav.kepler, sat, week, sow, max_age_s=max_age_s)
    week, sow = np.broadcast_arrays(np.asarray(week, np.int64), np.asarray(sow, float))
    out = np.full(sat.shape, -1, np.int64)
    out[~glo] = ephemeris.select(nav.kepler, sat[~glo], week[~glo], sow[~glo], max_age_s=max_age_s)
    out[glo] = glonass_orbit.select(nav.glonass, sat[glo], week[glo], sow[glo])
    return out


def satellite_states(nav, sat, index, week, sow):
    """States of mixed rows (``index`` from :func:`select`, >= 0), shape (m,)."""
    sat = np.asarray(sat, np.int64)
    glo = systems.system_of(sat) == systems.GLONASS
    if not glo.any():
        return orbit.satellite_states(nav.kepler, index, week, sow)
    index = np.asarray(index, np.int64)
    week, sow = np.broadcast_arrays(np.asarray(week, np.int64), np.asarray(sow, float))
    m = len(sat)
    pos, vel, clock, drift = np.empty((m, 3)), np.empty((m, 3)), np.empty(m), np.empty(m)
    for mask, states in (
        (~glo, lambda k: orbit.satellite_states(nav.kepler, index[k], week[k], sow[k])),
        (glo, lambda k: glonass_orbit.satellite_states(nav.glonass, index[k], week[k], sow[k])),
    ):
        if mask.any():
            s = states(mask)
            pos[mask], vel[mask], clock[mask], drift[mask] = s.pos, s.vel, s.clock, s.drift
    return SatelliteStates(pos=pos, vel=vel, clock=clock, drift=drift)


def group_delay(nav, sat, index):
    """Group delay (s) a band-1 single-frequency row subtracts from the clock: GPS TGD,
    Galileo BGD of the message's pair, BeiDou TGD1 (B1I); zero for GLONASS."""
    sat = np.asarray(sat, np.int64)
    glo = systems.system_of(sat) == systems.GLONASS
    k = np.where(glo, 0, index)
    return np.where(glo, 0.0, nav.kepler.tgd[k] if len(nav.kepler) else 0.0)
