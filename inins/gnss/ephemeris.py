"""GPS broadcast ephemerides: one container, one row per ephemeris set, and the
choice of the set valid at a time.

The fields are those of the GPS LNAV message (IS-GPS-200 Tables 20-I, 20-III),
in SI units and radians (RINEX carries angles in semicircles only in the raw
message; the RINEX navigation file is already in radians). :data:`FIELDS`
(declared in :mod:`inins.core.ephemeris_fields`, where :mod:`inins.io` readers and
the recorded-flight layout take it too) gives names, units and descriptions.
"""

from dataclasses import dataclass, fields, replace

import numpy as np

from inins.core.ephemeris_fields import FIELDS
from inins.gnss import gpstime, systems, timescales


@dataclass(frozen=True)
class Ephemeris:
    """Broadcast ephemeris sets; every field is an array of shape (n_sets,).

    Units and meaning per :data:`FIELDS` (SI, radians, seconds of week).
    Build it with :func:`from_columns`, which checks shapes and dtypes.
    """

    prn: np.ndarray
    week: np.ndarray
    toc: np.ndarray
    af0: np.ndarray
    af1: np.ndarray
    af2: np.ndarray
    iode: np.ndarray
    crs: np.ndarray
    delta_n: np.ndarray
    m0: np.ndarray
    cuc: np.ndarray
    e: np.ndarray
    cus: np.ndarray
    sqrt_a: np.ndarray
    toe: np.ndarray
    cic: np.ndarray
    omega0: np.ndarray
    cis: np.ndarray
    i0: np.ndarray
    crc: np.ndarray
    omega: np.ndarray
    omega_dot: np.ndarray
    idot: np.ndarray
    health: np.ndarray
    tgd: np.ndarray
    ura: np.ndarray
    fit_interval: np.ndarray

    def __len__(self):
        return len(self.prn)

    def take(self, index):
        """The sets at ``index`` (int array or boolean mask) as a new Ephemeris."""
        return Ephemeris(**{f.name: getattr(self, f.name)[index] for f in fields(self)})


def from_columns(columns):
    """An :class:`Ephemeris` from named columns: a mapping name -> array, or a
    structured array (as the :mod:`inins.io` readers return) with those fields.

    Every name of :data:`FIELDS` is needed except ``ura`` and ``fit_interval``
    (NaN and 4 h when absent); other names are ignored. Rows are sorted by PRN
    and then by time of ephemeris.
    """
    names = columns.dtype.names if isinstance(columns, np.ndarray) else tuple(columns)
    n = len(np.atleast_1d(columns["prn"]))
    defaults = {"ura": np.full(n, np.nan), "fit_interval": np.full(n, 4.0)}
    arrays = {}
    for name, dtype, _, _ in FIELDS:
        value = columns[name] if name in names else defaults[name]
        arrays[name] = np.atleast_1d(np.asarray(value)).astype(dtype, copy=True)
        if arrays[name].shape != (n,):
            raise ValueError(f"ephemeris field {name}: shape {arrays[name].shape}, expected ({n},)")
    order = np.lexsort((arrays["toe"] + gpstime.WEEK * arrays["week"], arrays["prn"]))
    return Ephemeris(**{k: v[order] for k, v in arrays.items()})


def with_week(eph, week):
    """The same sets referred to another GPS week (toe, toc and orbits unchanged).

    The broadcast orbit is expressed relative to the start of its week
    (``Omega0``, ``toe``), so the satellites stand at the same ECEF place at the
    same seconds of week of any week: a navigation file of one day gives a
    real constellation for a simulation on another date.
    """
    return replace(eph, week=np.full(len(eph), week, dtype=np.int64))


def concatenate(parts):
    """One :class:`Ephemeris` holding the rows of all ``parts`` (sorted again)."""
    return from_columns(
        {name: np.concatenate([getattr(p, name) for p in parts]) for name, *_ in FIELDS}
    )


def select(eph, prn, week, sow, *, max_age_s=7200.0, healthy_only=True):
    """Index of the ephemeris set to use for each (satellite, time).

    The set of that PRN with the nearest toe, within ``max_age_s`` of the time
    (half the 4 h fit interval, IS-GPS-200 §20.3.4.4), healthy unless
    ``healthy_only`` is False. Ties go to the later set (a fresh upload).

    Parameters
    ----------
    eph : Ephemeris
    prn : array_like of int, shape (n,)
    week : array_like of int, shape (n,) or scalar
        GPS week of the times (converted to BDT for BeiDou satellites, whose sets are
        kept in their own time, :mod:`inins.gnss.timescales`).
    sow : array_like of float, shape (n,), s
        GPS seconds of week.
    max_age_s : float, s
    healthy_only : bool

    Returns
    -------
    ndarray of int64, shape (n,)
        Row of ``eph``, or -1 where no set qualifies.
    """
    prn, week, sow = np.broadcast_arrays(
        np.asarray(prn, dtype=np.int64),
        np.asarray(week, dtype=np.int64),
        np.asarray(sow, dtype=float),
    )
    system = systems.system_of(prn)
    if np.any(system == systems.BEIDOU):  # BeiDou sets are in BDT
        week, sow = timescales.system_from_gps(system, week, sow)
    rows = np.flatnonzero(eph.health == 0) if healthy_only else np.arange(len(eph))
    if rows.size == 0:
        return np.full(prn.shape, -1, dtype=np.int64)
    ref = int(week.min()) if week.size else 0
    # one sorted key for (PRN, time): PRN * 1e8 s + time since the reference week; exact
    # distances are taken again below, the key only orders (0.5 us resolution)
    toe = gpstime.time_diff(eph.week[rows], eph.toe[rows], ref, 0.0)
    key = eph.prn[rows] * _PRN_SPAN + toe
    order = np.argsort(key, kind="stable")
    rows, key, toe = rows[order], key[order], toe[order]
    t = gpstime.time_diff(week, sow, ref, 0.0)
    q = prn * _PRN_SPAN + t
    hi = np.clip(np.searchsorted(key, q, side="right"), 0, len(rows) - 1)
    lo = np.clip(hi - 1, 0, None)
    d_lo = np.where(eph.prn[rows[lo]] == prn, np.abs(t - toe[lo]), np.inf)
    d_hi = np.where(eph.prn[rows[hi]] == prn, np.abs(t - toe[hi]), np.inf)
    best = np.where(d_lo < d_hi, lo, hi)
    dist = np.minimum(d_lo, d_hi)
    return np.where(dist <= max_age_s, rows[best], -1)


_PRN_SPAN = 1e8
"""Seconds per PRN in the sort key of :func:`select` (> 3 years of toe span)."""
