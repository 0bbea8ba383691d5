"""The rules every recorded flight meets, checked once at the edge.

:func:`checked_flight` is called on every :class:`~inins.io.flight_layout.RecordedFlight`
as it is read, whatever the source (the recorded-flight layout, the PSINS tc file,
RINEX files with an IMU log), so that import-flight and run-ekf accept and refuse the
same data: import-flight never writes what run-ekf would later reject.

Refused (bad input, :class:`~inins.exceptions.InputError`, the dataset and row named):
a missing or wrongly shaped array (an empty or transposed IMU array), NaN or infinity
in the IMU time or increments, IMU time that runs backwards, skips samples or is
scaled wrongly (an interval outside 50 us - 0.1 s, or increments implying rates no IMU
measures: the limits of every IMU reader, :mod:`inins.io.imu_checks`), epoch offsets
out of range, duplicated or swapped epochs, a satellite number that is no GPS PRN 1-32
nor another system's number (:mod:`inins.core.satellites`: GLONASS 101-127, Galileo
201-236, BeiDou 301-363, ...) or twice in one epoch, an IMU record outside every GNSS
epoch.

Dropped and counted (the count is in :attr:`RecordedFlight.dropped`, which the
commands print in their report and warnings): epochs with a non-finite time and their
measurements, measurements with a non-finite or non-positive pseudorange, non-finite
range rates, sigmas, signal strengths and carrier phases (kept as absent, NaN),
ephemeris sets with a non-finite or impossible orbit.
"""

from dataclasses import replace

import numpy as np

from inins.core import satellites
from inins.exceptions import InputError
from inins.io import imu_checks

GPS_PRN = (1, 32)
"""Satellite numbers of GPS; other systems' numbers are those of :mod:`inins.core.satellites`."""
IMU_INTERVAL_S = imu_checks.INTERVAL_S
"""Median IMU interval accepted (20 kHz to 10 Hz, the rule of every IMU reader,
:mod:`inins.io.imu_checks`): outside it the time is scaled wrongly."""
MAX_RATE = {
    "imu/dtheta": (imu_checks.MAX_GYRO_RADPS, "rad/s"),
    "imu/dv": (imu_checks.MAX_ACCEL_MPS2, "m/s^2"),
}
"""Largest increment / interval an IMU can record: beyond it the increments are not
increments (rates, degrees, another unit) or the time is scaled wrongly."""
GAP_INTERVALS = imu_checks.GAP_INTERVALS
"""A step of more than this many median intervals is a gap (lost samples); the PSINS
recording's 2 ms / 8 ms pairs around its 5 ms are jitter, not gaps."""
SECONDS_PER_WEEK = 604800.0
MAX_WEEK = 10_000
"""Largest continuous GPS week accepted (the year 2171)."""


def checked_flight(flight, source):
    """``flight`` checked by the rules above, with dropped rows removed and counted.

    Parameters
    ----------
    flight : RecordedFlight
    source : str
        The file named in the messages.

    Returns
    -------
    RecordedFlight
        The same flight (or a copy without the dropped rows, their counts appended to
        ``dropped``).

    Raises
    ------
    InputError
        A rule above broken (dataset and row named).
    """
    source = str(source)
    notes = list(flight.dropped)
    with np.errstate(invalid="ignore", over="ignore"):  # inf % 1 and the like: refused below
        imu = _checked_imu(flight.imu, source) if flight.imu is not None else None
        gnss = _checked_gnss(flight.gnss, source, notes)
        eph = _checked_ephemeris(flight.ephemeris, source, notes)
    if imu is not None:
        _overlap(imu, flight, gnss, source)
    return replace(flight, gnss=gnss, ephemeris=eph, imu=imu, dropped=tuple(notes))


def _rows(bad):
    """``"row 1000"`` or ``"row 1000 (and 4 more rows)"`` of a boolean row mask."""
    index = np.flatnonzero(bad)
    more = f" (and {index.size - 1} more rows)" if index.size > 1 else ""
    return int(index[0]), more


def _what(value):
    if np.isnan(value):
        return "NaN"
    if np.isinf(value):
        return "infinity" if value > 0 else "-infinity"
    return f"{value:.6g}"


def _array(value, key, source, ndim, columns=None, dtype=float):
    try:
        out = np.asarray(value, dtype=dtype)
    except (TypeError, ValueError):
        raise InputError(
            f"holds values that are not numbers ({np.asarray(value).dtype})",
            source=source,
            key=key,
        ) from None
    if out.ndim != ndim or (columns is not None and out.shape[1] != columns):
        want = "(n,)" if ndim == 1 else f"(n, {columns})"
        raise InputError(
            f"has shape {out.shape}, expected {want}"
            + (" (transposed?)" if out.ndim == 2 and out.shape[0] == columns else ""),
            source=source,
            key=key,
        )
    return out


def _checked_imu(imu, source):
    time = _array(imu.time, "imu/time", source, 1)
    n = len(time)
    arrays = {}
    for key, value in (("imu/dtheta", imu.dtheta), ("imu/dv", imu.dv)):
        a = np.asarray(value)
        if a.ndim == 2 and a.shape == (3, n) and n != 3:
            raise InputError(
                f"has shape {a.shape}, expected ({n}, 3) for the {n} rows of imu/time "
                "(transposed?)",
                source=source,
                key=key,
            )
        arrays[key] = _array(value, key, source, 2, 3)
        if len(arrays[key]) != n:
            raise InputError(
                f"has {len(arrays[key])} rows, imu/time has {n}", source=source, key=key
            )
    if n < 2:
        raise InputError(
            f"the IMU record has {n} samples (empty?); at least 2 needed",
            source=source,
            key="imu/time",
        )
    for key, a in (("imu/time", time[:, None]), *arrays.items()):
        bad = ~np.isfinite(a).all(axis=1)
        if bad.any():
            i, more = _rows(bad)
            value = a[i][~np.isfinite(a[i])][0]
            raise InputError(f"row {i}: {_what(value)}{more}", source=source, key=key)
    step = np.diff(time)
    back = np.flatnonzero(step <= 0.0)
    if back.size:
        i = int(back[0]) + 1
        said = "repeats" if step[i - 1] == 0 else "runs backwards from"
        raise InputError(
            f"row {i}: {time[i]:.6f} s {said} row {i - 1} ({time[i - 1]:.6f} s); "
            "the time must increase",
            source=source,
            key="imu/time",
        )
    dt = float(np.median(step))
    low, high = IMU_INTERVAL_S
    if not low <= dt <= high:
        raise InputError(
            f"median interval {dt:.4g} s ({1.0 / dt:.4g} Hz) is outside {low:g}-{high:g} s: "
            "time scaled wrongly (ms or us instead of s?)",
            source=source,
            key="imu/time",
        )
    gap = np.flatnonzero(step > GAP_INTERVALS * dt)
    if gap.size:
        i = int(gap[0])
        raise InputError(
            f"row {i + 1}: gap of {step[i]:.4g} s after t = {time[i]:.6f} s ({gap.size} gaps; "
            f"nominal interval {dt:.4g} s)",
            source=source,
            key="imu/time",
        )
    for key, a in arrays.items():
        limit, unit = MAX_RATE[key]
        with np.errstate(over="ignore"):
            rate = np.abs(a).max(axis=1) / dt
        bad = rate > limit
        if bad.any():
            i, more = _rows(bad)
            raise InputError(
                f"row {i}: {rate[i]:.4g} {unit} over one interval ({dt:.4g} s), beyond any "
                f"IMU ({limit:g} {unit}): not increments, or the time is scaled wrongly{more}",
                source=source,
                key=key,
            )
    return replace(imu, time=time, dtheta=arrays["imu/dtheta"], dv=arrays["imu/dv"])


_OBS = ("prn", "pseudorange", "signal", "range_rate", "sigma", "snr", "carrier")


def _checked_gnss(g, source, notes):
    time = _array(g.time, "gnss/epoch/time", source, 1)
    n = len(time)
    week = _array(g.week, "gnss/epoch/week", source, 1)
    start = _array(g.start, "gnss/epoch/start", source, 1)
    if n == 0:
        raise InputError("no GNSS epoch in the recording", source=source, key="gnss/epoch/time")
    if len(week) != n:
        raise InputError(
            f"has {len(week)} rows, gnss/epoch/time has {n}", source=source, key="gnss/epoch/week"
        )
    cols = {name: _array(getattr(g, name), f"gnss/obs/{name}", source, 1) for name in _OBS}
    m = len(cols["prn"])
    for name, value in cols.items():
        if len(value) != m:
            raise InputError(
                f"has {len(value)} rows, gnss/obs/prn has {m}",
                source=source,
                key=f"gnss/obs/{name}",
            )
    if len(start) != n + 1 or not np.isfinite(start).all():
        raise InputError(
            f"has {len(start)} rows, expected {n + 1} (one per epoch, and the end)",
            source=source,
            key="gnss/epoch/start",
        )
    bad = _bad_offset(start, m)
    if bad is not None:
        raise InputError(
            f"row {bad}: offset {start[bad]:.6g} out of order or outside the {m} measurement "
            f"rows (start[0] = 0, start[{n}] = {m}, never decreasing)",
            source=source,
            key="gnss/epoch/start",
        )
    start = start.astype(np.int64)
    bad_week = ~np.isfinite(week) | (week < 0) | (week > MAX_WEEK) | (week % 1 != 0)
    if bad_week.any():
        i, more = _rows(bad_week)
        raise InputError(
            f"row {i}: week {_what(week[i])} is not a GPS week number{more}",
            source=source,
            key="gnss/epoch/week",
        )
    week = week.astype(np.int64)
    # epochs without a time: dropped with their measurements
    keep_epoch = np.isfinite(time)
    if not keep_epoch.all():
        lost = int(np.count_nonzero(~keep_epoch))
        notes.append(
            f"gnss/epoch/time: {lost} epochs with a non-finite time dropped "
            f"(first row {int(np.flatnonzero(~keep_epoch)[0])}) with their measurements"
        )
    counts = np.diff(start)
    keep_row = np.repeat(keep_epoch, counts)
    prn = cols["prn"]
    bad_prn = keep_row & ~satellites.is_valid(prn)
    if bad_prn.any():
        i, more = _rows(bad_prn)
        raise InputError(
            f"row {i}: satellite {_what(prn[i])} is not a GPS PRN "
            f"({GPS_PRN[0]}-{GPS_PRN[1]}) nor another system's number (GLONASS 101-127, "
            f"Galileo 201-236, BeiDou 301-363){more}",
            source=source,
            key="gnss/obs/prn",
        )
    pr = cols["pseudorange"]
    bad_pr = keep_row & ~(np.isfinite(pr) & (pr > 0.0))
    if bad_pr.any():
        notes.append(
            f"gnss/obs/pseudorange: {int(bad_pr.sum())} measurements with a non-finite or "
            f"non-positive pseudorange dropped (first row {int(np.flatnonzero(bad_pr)[0])})"
        )
    sig = cols["signal"]
    bad_sig = keep_row & ~bad_pr & ~np.isin(sig, (1, 2))
    if bad_sig.any():
        i, more = _rows(bad_sig)
        raise InputError(
            f"row {i}: signal {_what(sig[i])} (1 = L1, 2 = ionosphere-free){more}",
            source=source,
            key="gnss/obs/signal",
        )
    for name in ("range_rate", "sigma", "snr", "carrier"):
        v = cols[name]
        inf = keep_row & ~bad_pr & np.isinf(v)
        if inf.any():
            notes.append(
                f"gnss/obs/{name}: {int(inf.sum())} infinite values treated as absent "
                f"(first row {int(np.flatnonzero(inf)[0])})"
            )
            cols[name] = np.where(np.isinf(v), np.nan, v)
    keep = keep_row & ~bad_pr
    epoch_of_row = np.repeat(np.arange(n), counts)
    # duplicated and swapped epochs (week and seconds of week together)
    t_abs = week.astype(float) * SECONDS_PER_WEEK + time
    kept_epochs = np.flatnonzero(keep_epoch)
    if kept_epochs.size:
        step = np.diff(t_abs[kept_epochs])
        back = np.flatnonzero(step <= 0.0)
        if back.size:
            j, i = int(kept_epochs[back[0]]), int(kept_epochs[back[0] + 1])
            said = "repeats" if step[back[0]] == 0 else "comes before"
            raise InputError(
                f"row {i}: epoch {time[i]:.3f} s (week {week[i]}) {said} row {j} "
                f"({time[j]:.3f} s): epochs duplicated or out of order",
                source=source,
                key="gnss/epoch/time",
            )
    # one measurement per satellite and epoch
    if m:
        span = satellites.SPAN
        safe = np.clip(np.nan_to_num(prn), 0, span - 1).astype(np.int64)  # bad: dropped epochs
        pairs = epoch_of_row.astype(np.int64) * span + safe
        _, first, counted = np.unique(pairs[keep_row], return_index=True, return_counts=True)
        if np.any(counted > 1):
            row = int(np.flatnonzero(keep_row)[first[np.flatnonzero(counted > 1)[0]]])
            raise InputError(
                f"row {row}: satellite {satellites.LETTERS[int(prn[row]) // 100]}"
                f"{int(prn[row]) % 100:02d} appears twice in epoch "
                f"{int(epoch_of_row[row])}",
                source=source,
                key="gnss/obs/prn",
            )
    if keep_epoch.all() and keep.all():
        return replace(g, week=week, time=time, start=start, **_typed(cols))
    new_counts = np.bincount(epoch_of_row[keep], minlength=n)[keep_epoch]
    new_start = np.concatenate([[0], np.cumsum(new_counts)]).astype(np.int64)
    cols = {k: v[keep] for k, v in _typed(cols).items()}
    return replace(g, week=week[keep_epoch], time=time[keep_epoch], start=new_start, **cols)


def _bad_offset(start, m):
    """First row of the epoch offsets that breaks 0 = start[0] <= ... <= start[-1] = m."""
    wrong = (start < 0) | (start > m) | (start % 1 != 0)
    wrong[1:] |= np.diff(start) < 0
    wrong[0] |= start[0] != 0
    wrong[-1] |= start[-1] != m
    index = np.flatnonzero(wrong)
    return int(index[0]) if index.size else None


def _typed(cols):
    out = dict(cols)
    out["prn"] = np.clip(np.nan_to_num(cols["prn"]), 0, 255).astype(np.int64)
    out["signal"] = np.clip(np.nan_to_num(cols["signal"]), -1, 9).astype(np.int8)
    return out


def _checked_ephemeris(eph, source, notes):
    eph = np.asarray(eph)
    names = eph.dtype.names or ()
    if not names:
        raise InputError("is not a table of ephemeris fields", source=source, key="gnss/ephemeris")
    if len(eph) == 0:
        raise InputError("no broadcast ephemeris set", source=source, key="gnss/ephemeris")
    ok = np.ones(len(eph), bool)
    for name in names:
        if name == "ura":  # may be unknown in a valid set
            continue
        value = eph[name]
        if np.issubdtype(value.dtype, np.floating):
            ok &= np.isfinite(value)
    prn = eph["prn"]
    ok &= satellites.is_valid(prn) & ~np.isin(np.nan_to_num(prn) // 100, (1, 5))  # Keplerian
    if "sqrt_a" in names:
        ok &= np.nan_to_num(eph["sqrt_a"]) > 0.0
    if "e" in names:
        e = np.nan_to_num(eph["e"], nan=-1.0)
        ok &= (e >= 0.0) & (e < 1.0)
    if not ok.all():
        bad = np.flatnonzero(~ok)
        notes.append(
            f"gnss/ephemeris: {bad.size} of {len(eph)} ephemeris sets dropped (non-finite "
            f"field, no GPS, Galileo, BeiDou or QZSS number, or impossible orbit; first row "
            f"{int(bad[0])})"
        )
        eph = eph[ok]
        if len(eph) == 0:
            raise InputError(
                "no usable broadcast ephemeris set (every one dropped)",
                source=source,
                key="gnss/ephemeris",
            )
    return eph


def _overlap(imu, flight, gnss, source):
    t0 = flight.imu_t0_sow
    if not np.isfinite(t0) or not 0.0 <= t0 < SECONDS_PER_WEEK:
        raise InputError(
            f"imu_t0_sow {_what(t0)} is not a GPS second of week (0-604800 s)",
            source=source,
            key="imu_t0_sow",
        )
    t = gnss.time - t0
    if not np.any((t > imu.time[0] - 1.0) & (t < imu.time[-1] + 1.0)):
        raise InputError(
            f"no GNSS epoch during the IMU record (IMU {imu.time[0]:g}-{imu.time[-1]:g} s after "
            f"GPS second {t0:.3f}; epochs {gnss.time[0]:.3f}-{gnss.time[-1]:.3f} s of week)",
            source=source,
            key="imu/time",
        )
