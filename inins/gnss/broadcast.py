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
    sat, week, sow = np.broadcast_arrays(sat, np.asarray(week, np.int64), np.asarray(sow, float))
    glo = systems.system_of(sat) == systems.GLONASS
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
    sat, index, week, sow = np.broadcast_arrays(
        sat, np.asarray(index, np.int64), np.asarray(week, np.int64), np.asarray(sow, float)
    )
    glo = systems.system_of(sat) == systems.GLONASS
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


def from_records(kepler, glonass=None):
    """A :class:`Navigation` of a reader's structured arrays: Keplerian sets with the
    fields of :data:`inins.gnss.ephemeris.FIELDS` and GLONASS sets with ``sat, week, toe,
    clock_bias, gamma, pos, vel, acc, health, channel`` (:mod:`inins.io.rinex_nav`)."""
    glo = glonass_orbit.empty()
    if glonass is not None and len(glonass):
        glo = glonass_orbit.from_columns(
            *(glonass[name] for name in ("sat", "week", "toe", "clock_bias", "gamma")),
            *(glonass[name] for name in ("pos", "vel", "acc", "health", "channel")),
        )
    return Navigation(kepler=ephemeris.from_columns(kepler), glonass=glo)


def merge(parts):
    """One :class:`Navigation` of several (a GPS file and a GLONASS file, say)."""
    kepler = ephemeris.concatenate([p.kepler for p in parts])
    glo = [p.glonass for p in parts if len(p.glonass)]
    if not glo:
        return Navigation(kepler=kepler)
    names = ("sat", "week", "toe", "clock_bias", "gamma", "pos", "vel", "acc", "health", "channel")
    return Navigation(
        kepler=kepler,
        glonass=glonass_orbit.from_columns(
            *(np.concatenate([getattr(g, n) for g in glo]) for n in names)
        ),
    )


def glonass_channels(nav, sat):
    """Frequency channel of each GLONASS satellite number in ``sat`` from its latest set
    (NaN for other systems and for slots without a set)."""
    sat = np.asarray(sat, np.int64)
    out = np.full(sat.shape, np.nan)
    g = nav.glonass
    if len(g) == 0:
        return out
    table = np.full(200, np.nan)
    table[g.sat] = g.channel  # sorted by time within a slot: the latest set wins
    glo = systems.system_of(sat) == systems.GLONASS
    out[glo] = table[sat[glo]]
    return out
