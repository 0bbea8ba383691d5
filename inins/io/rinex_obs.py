"""RINEX 2.11 and 3.x observation files of any of GPS, GLONASS, Galileo, BeiDou and
QZSS, plain or gzip-compressed, read into one :class:`ObservationFile`.

Header: observation types (per system in RINEX 3), APPROX POSITION XYZ, INTERVAL,
marker name, GLONASS SLOT / FRQ #. Body: epoch records with flag 0 or 1 kept; event
records (flags 2-5) and cycle-slip records (6) skipped and counted
(:attr:`ObservationFile.events`); a flag above 6 is no RINEX flag: bad input. The
satellites of the systems asked are kept; the records of other systems, and of
letters no RINEX version defines, are counted (:attr:`ObservationFile.skipped`) and
the report says so. An epoch more than :data:`MAX_EPOCH_STEP_S` after the one before
(a year or month field wrong) is refused, as is one before it.

The body is first read by array operations a block of bytes at a time
(:mod:`inins.io.rinex_scan`: every line, epoch and record of a block at once), which
takes only a body in the strict layout; anything else (bad input among it) is read
again here a bounded line at a time (:mod:`inins.io.textlines`), each epoch checked as
it comes, so junk is refused at its first line with the file, line and reason. Both
readers build the same :class:`ObservationFile` (:func:`_build`).

:func:`observable` gives a column under its RINEX 2 name (GPS files; RINEX 3 codes
``C1C`` -> C1, ``C1W``/``C1P``/``C1Y`` -> P1, ``C2W``/``C2P``/``C2Y``/``C2D`` -> P2,
``D1C`` -> D1, ``S1C`` -> S1, ``L1C`` -> L1); :func:`system_observable` the per-system
choice of :data:`RINEX3_SYSTEM_NAMES` for every row of a mixed file.
"""

import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from inins.core.satellites import LETTERS
from inins.exceptions import InputError
from inins.io import rinex_scan
from inins.io.rinex_text import (
    calendar_problem,
    gps_week_sow,
    open_rinex,
    read_header,
    version_line,
)

RINEX3_NAMES = {
    "C1": ("C1C",),
    "P1": ("C1W", "C1P", "C1Y"),
    "P2": ("C2W", "C2P", "C2Y", "C2D"),
    "D1": ("D1C", "D1W", "D1P"),
    "S1": ("S1C", "S1W", "S1P"),
    "L1": ("L1C", "L1W", "L1P"),
}
"""RINEX 3 codes (first found wins) for each RINEX 2 observable name."""
READABLE = LETTERS[:5]
"""Systems whose observations can be read: G R E C J."""
RINEX_LETTERS = "GRECJSI"
"""Satellite system letters of RINEX 2.11 and 3.0x (S SBAS and I IRNSS/NavIC not read)."""
MAX_EPOCH_STEP_S = 7 * 86400.0
"""Largest step between two epochs of one file (s): a week (a wrong year, month or day
field is refused, not folded into the week)."""
MAX_FLAG = 6
"""Largest RINEX epoch flag (6: cycle-slip records)."""


@dataclass(frozen=True)
class ObservationFile:
    """Observations of the systems asked, read from a RINEX 2.11 or 3.0x file.

    Attributes
    ----------
    path : str
    version : float
    marker : str
    approx_pos_e : ndarray, shape (3,), m (APPROX POSITION XYZ; NaN if absent)
    interval : float, s (NaN if absent)
    types : tuple of str
        Observation type of each column of ``values`` (RINEX 2: the header's; RINEX 3:
        the union of the kept systems' codes, NaN on rows of a system without one).
    system_types : dict
        System letter -> its observation codes.
    glonass_channels : dict
        GLONASS SLOT / FRQ # of the header (slot -> channel; empty when absent).
    week : ndarray of int64, shape (n_epochs,)
    time : ndarray, shape (n_epochs,), s
        GPS seconds of week of the epoch (receiver time tag).
    flag : ndarray of int8, shape (n_epochs,), epoch flag (0 ok, 1 power failure)
    start : ndarray of int64, shape (n_epochs + 1,)
        Satellite rows of epoch ``k``: ``start[k]:start[k + 1]``.
    prn : ndarray of int64, shape (m,)
        Satellite number of :mod:`inins.core.satellites` (100 * system + number; GPS
        PRN 1-32 as themselves).
    values : ndarray, shape (m, n_types)
        Observations in the file's units (m, cycles, Hz, dB-Hz); NaN where blank.
    line : ndarray of int64, shape (m,), 1-based line of each satellite record
    skipped : dict
        System letter -> satellite records not read (systems not asked, unknown letters).
    events : dict
        Epoch flag (2-6) -> records skipped.
    """

    path: str
    version: float
    marker: str
    approx_pos_e: np.ndarray
    interval: float
    types: tuple
    system_types: dict
    glonass_channels: dict
    week: np.ndarray
    time: np.ndarray
    flag: np.ndarray
    start: np.ndarray
    prn: np.ndarray
    values: np.ndarray
    line: np.ndarray
    skipped: dict = field(default_factory=dict)
    events: dict = field(default_factory=dict)


def observable(obs, name):
    """Column of observable ``name`` (RINEX 2 name: C1, P1, P2, D1, S1, L1), shape (m,).

    All NaN when the file has no such observable.
    """
    candidates = (name, *RINEX3_NAMES.get(name, ()))
    for code in candidates:
        if code in obs.types:
            return obs.values[:, obs.types.index(code)]
    return np.full(len(obs.prn), np.nan)


def _header_info(header, version, path, keep):
    """(types per kept system, marker, interval, position, GLONASS channels)."""
    types, marker, interval, pos = [], "", np.nan, np.full(3, np.nan)
    system, per_system, channels = "", {}, {}
    for label, content, line in header:
        if label == "# / TYPES OF OBSERV" and version < 3:
            types += content[6:60].split()
        elif label == "SYS / # / OBS TYPES" and version >= 3:
            system = content[0] if content[0] != " " else system
            if system in keep:
                per_system.setdefault(system, []).extend(content[7:60].split())
        elif label == "GLONASS SLOT / FRQ #":
            words = content[4:60].split()
            for slot, k in zip(words[::2], words[1::2], strict=False):
                try:
                    channels[int(slot[1:])] = int(k)
                except ValueError:
                    raise InputError(
                        f"unreadable GLONASS slot/channel {slot!r} {k!r}",
                        source=str(path),
                        line=line,
                    ) from None
        elif label == "MARKER NAME":
            marker = content.strip()
        elif label == "INTERVAL":
            interval = _float(content[:10], path, line)
        elif label == "APPROX POSITION XYZ":
            pos = np.array([_float(content[14 * i : 14 * i + 14], path, line) for i in range(3)])
    if version < 3:
        per_system = dict.fromkeys(keep, types) if types else {}
    if not any(per_system.values()):
        names = "GPS" if keep == "G" else f"the systems {keep!r}"
        raise InputError(f"no observation types of {names} in the header", source=str(path))
    return per_system, marker, interval, pos, channels


def _float(text, path, line):
    try:
        return float(text)
    except ValueError:
        raise InputError(f"not a number: {text!r}", source=str(path), line=line) from None


class _Body:
    """Accumulates epochs and satellite records while scanning."""

    def __init__(self, keep):
        self.keep = keep
        self.cal, self.flag, self.count, self.epoch_line = [], [], [], []
        self.prn, self.text, self.line = [], [], []
        self.skipped, self.events = {}, {}
        self.count_all = 0

    def skip(self, letter):
        """Count a record of a system not asked (or of no RINEX system)."""
        name = letter if letter in RINEX_LETTERS else f"unknown system {letter!r}"
        self.skipped[name] = self.skipped.get(name, 0) + 1

    def epoch(self, cal, flag, kept, line):
        self.cal.append(cal)
        self.flag.append(flag)
        self.count.append(kept)
        self.epoch_line.append(line)


def _take(reader, count, path, what, start_line):
    """``count`` lines from the reader; the end of the file first is a truncated record."""
    out = reader.take(count)
    if len(out) < count:
        raise InputError(f"truncated epoch record: {what}", source=str(path), line=start_line)
    return out


_V2_EPOCH = re.compile(r"^ [ \d]\d [ \d]\d [ \d]\d [ \d]\d [ \d]\d [ \d]\d\.\d{7}  [0-9][ \d]{2}\d")
"""A RINEX 2 epoch line (`` 15  1  8  0  0  0.0000000  0 12G01...``)."""


def _epoch_fields(line, path, n, v3):
    """(calendar, flag, satellite count) of an epoch line; bad input if unreadable."""
    try:
        if v3:
            cal = (int(line[2:6]), int(line[7:9]), int(line[10:12]), int(line[13:15]),
                   int(line[16:18]), float(line[18:29]))  # fmt: skip
            flag, nsat = int(line[31:32] or 0), int(line[32:35])
        else:
            cal = (int(line[1:3]), int(line[4:6]), int(line[7:9]), int(line[10:12]),
                   int(line[13:15]), float(line[15:26]))  # fmt: skip
            flag, nsat = int(line[26:29] or 0), int(line[29:32])
    except ValueError:
        raise InputError(
            f"unreadable epoch line {line.rstrip()[:80]!r}", source=str(path), line=n
        ) from None
    if not 0 <= flag <= MAX_FLAG:
        raise InputError(
            f"epoch flag {flag} is not a RINEX flag (0-{MAX_FLAG})", source=str(path), line=n
        )
    problem = calendar_problem(*cal)
    if problem:
        raise InputError(f"epoch line with an impossible {problem}", source=str(path), line=n)
    return cal, flag, nsat


def _scan_v2(reader, n_types, path, keep):
    """RINEX 2 body: records of ceil(n_types / 5) lines of 80 columns per satellite."""
    per = (n_types + 4) // 5
    body = _Body(keep)
    while (line := reader.next()) is not None:
        if not line.strip():
            continue
        epoch_line = reader.number
        cal, flag, nsat = _epoch_fields(line, path, epoch_line, v3=False)
        if flag > 1:  # event record: nsat special lines follow
            _take(reader, nsat, path, f"{nsat} event lines expected", epoch_line)
            body.events[flag] = body.events.get(flag, 0) + 1
            continue
        extra = (nsat - 1) // 12 if nsat > 0 else 0
        more = _take(reader, extra, path, "satellite list continues past the end", epoch_line)
        ids = line[32:68] + "".join(x[32:68] for x in more)
        _check_satellite_list(ids, nsat, path, epoch_line)
        first = reader.number + 1
        block = _take(reader, nsat * per, path, f"{nsat} satellites x {per} lines expected", first)
        kept = 0
        for i in range(nsat):
            rec = block[i * per : (i + 1) * per]
            if _V2_EPOCH.match(rec[0]):
                raise InputError(
                    f"the epoch line {epoch_line} counts {nsat} satellites but only {i} "
                    "records follow before this epoch line",
                    source=str(path),
                    line=first + i * per,
                )
            sid = ids[3 * i : 3 * i + 3]
            if sid[0] in keep:
                body.prn.append(sid)
                body.text.append("".join(x.ljust(80)[:80] for x in rec))
                body.line.append(first + i * per)
                kept += 1
            else:
                body.skip(sid[0])
        body.epoch(cal, flag, kept, epoch_line)
    offsets = [(j // 5) * 80 + (j % 5) * 16 for j in range(n_types)]
    return body, per * 80, offsets


def _check_satellite_list(ids, nsat, path, line):
    """The satellite list of a RINEX 2 epoch line must hold as many satellites as it counts."""
    listed = [ids[3 * i : 3 * i + 3] for i in range(len(ids) // 3)]
    given = sum(1 for sid in listed if sid.strip())
    if given != nsat or any(not sid.strip() for sid in listed[:nsat]):
        raise InputError(
            f"the epoch line counts {nsat} satellites but lists {given}",
            source=str(path),
            line=line,
        )


def _scan_v3(reader, n_types, path, keep):
    """RINEX 3 body: '>' epoch lines, one line per satellite ('G01' + 16-column fields)."""
    width = 16 * n_types
    body = _Body(keep)
    while (line := reader.next()) is not None:
        if not line.strip():
            continue
        if line[0] != ">":
            after = (
                f" (the epoch line {body.epoch_line[-1]} counts {body.count_all} satellites: "
                "more records follow than it counts)"
                if body.epoch_line
                else ""
            )
            raise InputError(
                f"expected an epoch line starting '>', found {line[:20]!r}{after}",
                source=str(path),
                line=reader.number,
            )
        epoch_line = reader.number
        cal, flag, nsat = _epoch_fields(line, path, epoch_line, v3=True)
        if flag > 1:
            _take(reader, nsat, path, f"{nsat} event lines expected", epoch_line)
            body.events[flag] = body.events.get(flag, 0) + 1
            continue
        block = reader.take(nsat)
        short = next((j for j, x in enumerate(block) if x[:1] == ">"), None)
        if short is not None:
            raise InputError(
                f"the epoch line {epoch_line} counts {nsat} satellites but only {short} "
                "records follow before the next epoch line",
                source=str(path),
                line=epoch_line + 1 + short,
            )
        if len(block) < nsat:
            raise InputError(
                f"truncated epoch record: {nsat} satellite lines expected",
                source=str(path),
                line=epoch_line + 1,
            )
        kept = 0
        for j, rec in enumerate(block):
            if rec[:1] in keep:
                body.prn.append(rec[:3])
                body.text.append(rec[3:].ljust(width)[:width])
                body.line.append(epoch_line + 1 + j)
                kept += 1
            else:
                body.skip(rec[:1])
        body.count_all = nsat
        body.epoch(cal, flag, kept, epoch_line)
    return body, width, [16 * j for j in range(n_types)]


def _numbers(body, width, offsets, path):
    """(m, n_types) floats of all records at once; blanks are NaN."""
    m = len(body.text)
    if m == 0:
        return np.zeros((0, len(offsets)))
    raw = np.frombuffer("".join(body.text).encode("ascii", "replace"), np.uint8)
    raw = raw.reshape(m, width)
    cols = np.asarray(offsets)[:, None] + np.arange(14)
    fields = np.ascontiguousarray(raw[:, cols])  # (m, n_types, 14)
    blank = (fields == 32).all(axis=2)
    fields[blank] = np.frombuffer(b"           nan", np.uint8)
    try:
        return fields.view("S14")[..., 0].astype(float)
    except ValueError:
        for i in range(m):  # find the line to name
            try:
                fields[i].view("S14")[..., 0].astype(float)
            except ValueError:
                raise InputError(
                    "unreadable observation value", source=str(path), line=body.line[i]
                ) from None
        raise


def _check_epoch_times(t, epoch_line, path):
    """Epochs follow each other in time, at most :data:`MAX_EPOCH_STEP_S` apart."""
    step = np.diff(t)
    back = np.flatnonzero(step <= 0.0)
    if back.size:
        i = int(back[0]) + 1
        said = "repeats" if step[i - 1] == 0 else "comes before"
        raise InputError(
            f"this epoch {said} the epoch at line {int(epoch_line[i - 1])}: epochs duplicated "
            "or out of order",
            source=str(path),
            line=int(epoch_line[i]),
        )
    jump = np.flatnonzero(step > MAX_EPOCH_STEP_S)
    if jump.size:
        i = int(jump[0]) + 1
        raise InputError(
            f"this epoch is {step[i - 1] / 86400.0:.6g} days after the epoch at line "
            f"{int(epoch_line[i - 1])}: a year, month or day field wrong (epochs of one file "
            f"are at most {MAX_EPOCH_STEP_S / 86400.0:g} days apart)",
            source=str(path),
            line=int(epoch_line[i]),
        )


def read_obs(path, systems="G"):
    """Read the satellites of ``systems`` from a RINEX 2.11 or 3.0x observation file.

    Parameters
    ----------
    path : str or Path
        ``.YYo``, ``.rnx`` or either gzip-compressed.
    systems : str
        RINEX letters of the systems to keep (any of G R E C J); ``"G"``, the default,
        reads GPS under its RINEX 2 names (:func:`observable`).

    Returns
    -------
    ObservationFile

    Raises
    ------
    InputError
        Another version or file type; a single-system file of a system not asked for;
        no observation type of the systems asked; a truncated or unreadable record, an
        impossible epoch or one a week after the last (file and line named).
    """
    unknown = set(systems) - set(READABLE)
    if unknown or not systems:
        raise InputError(f"unknown satellite systems {sorted(unknown)}", source=str(path))
    with open_rinex(path) as reader:
        header = read_header(reader)
        version, ftype, system = version_line(header, path)
        single = "G" if system == " " else system
        if ftype != "O" or not (2.0 <= version < 4.0) or (single != "M" and single not in systems):
            raise InputError(
                f"not an observation file of RINEX 2 or 3 with the systems {systems!r} "
                f"(version {version}, type {ftype!r}, system {system!r})",
                source=str(path),
                line=1,
            )
        per_system, marker, interval, pos, channels = _header_info(header, version, path, systems)
        header_lines = reader.number
    if version < 3:
        keep = systems + (" " if "G" in systems else "")
        types = per_system[next(iter(per_system))]
        n_types, union, columns = len(types), tuple(types), None
    else:
        keep = "".join(per_system)
        n_types = max(len(t) for t in per_system.values())
        union = tuple(dict.fromkeys(c for t in per_system.values() for c in t))
        columns = {s: [union.index(c) for c in t] for s, t in per_system.items()}
    body = rinex_scan.scan(path, header_lines, version, n_types, keep, RINEX_LETTERS)
    if body is None:  # not in the strict layout: line by line, bad input named
        body = _read_lines(path, version, n_types, keep)
    about = (version, marker, pos, interval, per_system, channels)
    return _build(path, about, body, union, columns)


def _read_lines(path, version, n_types, keep):
    """The :class:`~inins.io.rinex_scan.Scanned` body read a line at a time (the reader
    of any body the fast path gave up on; refuses bad input with its line)."""
    with open_rinex(path) as reader:
        read_header(reader)
        scan = _scan_v2 if version < 3 else _scan_v3
        body, width, offsets = scan(reader, n_types, path, keep)
        end = reader.number
    if not body.cal:
        raise InputError(
            "no observation epoch after the header (a header-only file?)",
            source=str(path),
            line=end,
        )
    return rinex_scan.Scanned(
        cal=np.array(body.cal, dtype=float).reshape(-1, 6),
        flag=np.array(body.flag, np.int64),
        count=np.array(body.count, np.int64),
        epoch_line=np.array(body.epoch_line, np.int64),
        ids=np.array(body.prn, dtype="S3"),
        values=_numbers(body, width, offsets, path),
        line=np.array(body.line, np.int64),
        skipped=dict(body.skipped),
        events=dict(body.events),
    )


def _build(path, about, body, union, columns):
    """The :class:`ObservationFile` of a scanned body (the one builder of both versions
    and of both readers)."""
    version, marker, pos, interval, per_system, channels = about
    parsed = body.values
    raw = body.ids.view(np.uint8).reshape(-1, 3)
    tens, ones = raw[:, 1], raw[:, 2]
    digits = ((tens == 32) | (tens - np.uint8(48) < 10)) & (ones - np.uint8(48) < 10)
    if not digits.all():
        i = int(np.flatnonzero(~digits)[0])
        where = {"source": str(path), "line": int(body.line[i])}
        raise InputError(f"unreadable satellite {body.ids[i].decode()!r}", **where)
    number = np.where(tens == 32, 0, tens.astype(np.int64) - 48) * 10 + ones - 48
    letters = np.where(raw[:, 0] == 32, ord("G"), raw[:, 0])  # RINEX 2: blank is GPS
    index = np.zeros(256, np.int64)
    index[[ord(letter) for letter in LETTERS]] = np.arange(len(LETTERS))
    code = index[letters]
    if columns is None:
        values = parsed
    else:
        values = np.full((len(number), len(union)), np.nan)
        for s, cols in columns.items():
            rows = np.flatnonzero(letters == ord(s))
            values[np.ix_(rows, cols)] = parsed[rows][:, : len(cols)]
    cal = body.cal
    week, sow = gps_week_sow(*cal[:, :5].astype(np.int64).T, cal[:, 5])
    _check_epoch_times(np.asarray(week, float) * 604800.0 + sow, body.epoch_line, path)
    return ObservationFile(
        path=str(path),
        version=version,
        marker=marker,
        approx_pos_e=pos,
        interval=interval,
        types=union,
        system_types={s: tuple(t) for s, t in per_system.items()},
        glonass_channels=channels,
        week=np.asarray(week, np.int64),
        time=np.asarray(sow, float),
        flag=np.array(body.flag, np.int8),
        start=np.concatenate([[0], np.cumsum(body.count, dtype=np.int64)]),
        prn=code * 100 + number % 100,
        values=values,
        line=np.asarray(body.line, np.int64),
        skipped=dict(body.skipped),
        events=dict(body.events),
    )


RINEX3_SYSTEM_NAMES = {
    "G": RINEX3_NAMES,
    "J": RINEX3_NAMES,
    "R": {
        "C1": ("C1C",),
        "P1": ("C1P",),
        "P2": ("C2P",),
        "D1": ("D1C", "D1P"),
        "S1": ("S1C", "S1P"),
        "L1": ("L1C", "L1P"),
    },
    "E": {
        "C1": ("C1C", "C1X", "C1B"),
        "P1": ("C1C", "C1X", "C1B"),
        "P2": ("C5Q", "C5X", "C5I"),
        "D1": ("D1C", "D1X", "D1B"),
        "S1": ("S1C", "S1X", "S1B"),
        "L1": ("L1C", "L1X", "L1B"),
    },
    "C": {
        "C1": ("C2I", "C1I", "C2X"),
        "P1": ("C2I", "C1I", "C2X"),
        "P2": ("C6I", "C6Q", "C6X"),
        "D1": ("D2I", "D1I", "D2X"),
        "S1": ("S2I", "S1I", "S2X"),
        "L1": ("L2I", "L1I", "L2X"),
    },
}
"""Priority list per system: RINEX 3 codes (first the file has wins) for each RINEX 2
name. Band 1 is GPS/QZSS L1 C/A, GLONASS G1 C/A (P1, P2: the P code on G1, G2),
Galileo E1 (C, X, B: pilot, combined, data), BeiDou B1I (``2I`` since RINEX 3.02,
``1I`` in 3.01). P1/P2 name the dual-frequency pair: for Galileo E1 and E5a
(``C5Q/X/I``, the pair of the F/NAV clock), for BeiDou B1I and B3I (``C6I/Q/X``, B3I
being the reference of the broadcast clock); where both are observed the
ionosphere-free combination is formed (:func:`inins.gnss.measurements.code_pseudorange`)."""


def system_observable(obs, name):
    """Column of RINEX 2 observable ``name`` for every row of a mixed file, shape (m,):
    per system the first code of :data:`RINEX3_SYSTEM_NAMES` the system's header lists
    (RINEX 2: the name itself). NaN on rows of systems without it."""
    out = np.full(len(obs.prn), np.nan)
    system = obs.prn // 100
    for letter, types in obs.system_types.items():
        rows = system == LETTERS.index(letter)
        if not rows.any():
            continue
        names = RINEX3_SYSTEM_NAMES.get(letter, {}).get(name, ()) if obs.version >= 3 else ()
        for code in (name, *names) if obs.version < 3 else names:
            if code in types:
                out[rows] = obs.values[rows, obs.types.index(code)]
                break
    return out


def write_obs_v3(path, week, time, start, prn, columns, *, marker="INININS"):
    """Write a RINEX 3.04 observation file (the body and the header lines a reader needs).

    Parameters
    ----------
    path : str or Path
    week, time, start : epoch GPS week, seconds of week (s) and row offsets
    prn : ndarray of int64, (m,), satellite numbers of :mod:`inins.core.satellites`
    columns : dict
        System letter -> (codes tuple, values (m, n_codes) array; rows of other systems
        ignored, NaN written blank).
    """
    header = [f"{'3.04':>9}{'':11}{'OBSERVATION DATA':20}{'M':20}RINEX VERSION / TYPE"]
    header.append(f"{marker:60}MARKER NAME")
    for letter, (codes, _) in columns.items():
        for i in range(0, len(codes), 13):
            lead = f"{letter}  {len(codes):3d}" if i == 0 else " " * 6
            chunk = "".join(f" {c}" for c in codes[i : i + 13])
            header.append(f"{lead}{chunk:54}SYS / # / OBS TYPES")
    header.append(f"{'':60}END OF HEADER")
    system = np.asarray(prn) // 100
    text = {}
    for letter, (_, values) in columns.items():
        rows = np.flatnonzero(system == LETTERS.index(letter))
        body = np.char.mod("%14.3f  ", values[rows])
        body[~np.isfinite(values[rows])] = " " * 16
        for r, line in zip(rows, ["".join(b).rstrip() for b in body], strict=True):
            text[r] = f"{letter}{prn[r] % 100:02d}{line}"
    cal = np.datetime64("1980-01-06T00:00:00", "ns") + (
        np.asarray(week, np.int64) * 604800 * 10**9
        + np.round(np.asarray(time) * 1e9).astype(np.int64)
    ).astype("timedelta64[ns]")
    out = list(header)
    for k, stamp in enumerate(cal):
        rows = [r for r in range(start[k], start[k + 1]) if r in text]
        iso = str(stamp)
        sec = float(iso[17:])
        out.append(
            f"> {iso[:4]} {iso[5:7]} {iso[8:10]} {iso[11:13]} {iso[14:16]}"
            f"{sec:11.7f}  0{len(rows):3d}"
        )
        out += [text[r] for r in rows]
    Path(path).write_text("\n".join(out) + "\n")
