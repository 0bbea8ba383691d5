"""RINEX 2.11 and 3.x GPS observation files, plain or gzip-compressed.

Header: observation types, APPROX POSITION XYZ, INTERVAL, marker name. Body:
epoch records (flag 0 or 1 kept; event records 2-5 and cycle-slip records 6
skipped), each satellite's values as F14.3 in 16-column fields. Only GPS
satellites are kept (RINEX 2 mixed files: the 'G' and blank entries; RINEX 3:
lines starting 'G'). The epoch scan is one pass in Python; the numbers of all
satellite records are converted in one numpy call (fixed-width fields), which
keeps a 3 MB day file well under half a second.

RINEX 3 observation codes are reported under RINEX 2 names by
:func:`observable`: ``C1C`` -> C1, ``C1W``/``C1P``/``C1Y`` -> P1,
``C2W``/``C2P``/``C2Y``/``C2D`` -> P2, ``D1C`` -> D1, ``S1C`` -> S1, ``L1C`` -> L1.
"""

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from inins.exceptions import InputError
from inins.io.rinex_text import gps_week_sow, read_lines, split_header, version_line

RINEX3_NAMES = {
    "C1": ("C1C",),
    "P1": ("C1W", "C1P", "C1Y"),
    "P2": ("C2W", "C2P", "C2Y", "C2D"),
    "D1": ("D1C", "D1W", "D1P"),
    "S1": ("S1C", "S1W", "S1P"),
    "L1": ("L1C", "L1W", "L1P"),
}
"""RINEX 3 codes (first found wins) for each RINEX 2 observable name."""


@dataclass(frozen=True)
class ObservationFile:
    """GPS observations read from a RINEX file.

    Attributes
    ----------
    path : str
    version : float
    marker : str
    approx_pos_e : ndarray, shape (3,), m (APPROX POSITION XYZ; NaN if absent)
    interval : float, s (NaN if absent)
    types : tuple of str
        Observation type of each column of ``values`` (as in the file).
    week : ndarray of int64, shape (n_epochs,)
    time : ndarray, shape (n_epochs,), s
        GPS seconds of week of the epoch (receiver time tag).
    flag : ndarray of int8, shape (n_epochs,), epoch flag (0 ok, 1 power failure)
    start : ndarray of int64, shape (n_epochs + 1,)
        Satellite rows of epoch ``k``: ``start[k]:start[k + 1]``.
    prn : ndarray of int64, shape (m,)
    values : ndarray, shape (m, n_types)
        Observations in the file's units (m, cycles, Hz, dB-Hz); NaN where blank.
    line : ndarray of int64, shape (m,), 1-based line of each satellite record
    """

    path: str
    version: float
    marker: str
    approx_pos_e: np.ndarray
    interval: float
    types: tuple
    week: np.ndarray
    time: np.ndarray
    flag: np.ndarray
    start: np.ndarray
    prn: np.ndarray
    values: np.ndarray
    line: np.ndarray


def observable(obs, name):
    """Column of observable ``name`` (RINEX 2 name: C1, P1, P2, D1, S1, L1), shape (m,).

    All NaN when the file has no such observable.
    """
    candidates = (name, *RINEX3_NAMES.get(name, ()))
    for code in candidates:
        if code in obs.types:
            return obs.values[:, obs.types.index(code)]
    return np.full(len(obs.prn), np.nan)


def _header_info(header, version, path, keep="G"):
    types, marker, interval, pos = [], "", np.nan, np.full(3, np.nan)
    system, per_system, channels = "", {}, {}
    for label, content, line in header:
        if label == "# / TYPES OF OBSERV" and version < 3:
            types += content[6:60].split()
        elif label == "SYS / # / OBS TYPES" and version >= 3:
            system = content[0] if content[0] != " " else system
            if system in keep:
                per_system.setdefault(system, []).extend(content[7:60].split())
                if system == "G":
                    types += content[7:60].split()
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
    if keep != "G":
        if version < 3:
            per_system = dict.fromkeys(keep, types)
        if not any(per_system.values()):
            raise InputError(
                f"no observation types of the systems {keep!r} in the header", source=str(path)
            )
        return per_system, marker, interval, pos, channels
    if not types:
        raise InputError("no GPS observation types in the header", source=str(path))
    return tuple(types), marker, interval, pos


def _float(text, path, line):
    try:
        return float(text)
    except ValueError:
        raise InputError(f"not a number: {text!r}", source=str(path), line=line) from None


class _Body:
    """Accumulates epochs and satellite records while scanning."""

    def __init__(self):
        self.cal, self.flag, self.count, self.epoch_line = [], [], [], []
        self.prn, self.text, self.line = [], [], []
        self.count_all = []


def _truncated(path, line, what):
    return InputError(f"truncated epoch record: {what}", source=str(path), line=line)


_V2_EPOCH = re.compile(r"^ [ \d]\d [ \d]\d [ \d]\d [ \d]\d [ \d]\d [ \d]\d\.\d{7}  [0-6][ \d]{2}\d")
"""A RINEX 2 epoch line (`` 15  1  8  0  0  0.0000000  0 12G01...``)."""


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


def _epoch_v2(line, path, k):
    try:
        cal = (
            int(line[1:3]),
            int(line[4:6]),
            int(line[7:9]),
            int(line[10:12]),
            int(line[13:15]),
            float(line[15:26]),
        )
        return cal, int(line[26:29] or 0), int(line[29:32])
    except ValueError:
        raise InputError(
            f"unreadable epoch line {line.rstrip()!r}", source=str(path), line=k + 1
        ) from None


def _scan_v2(lines, k, n_types, path, keep="G "):
    """RINEX 2 body: records of ceil(n_types / 5) lines of 80 columns per satellite."""
    per = (n_types + 4) // 5
    body, n = _Body(), len(lines)
    while k < n:
        line = lines[k]
        if not line.strip():
            k += 1
            continue
        cal, flag, nsat = _epoch_v2(line, path, k)
        extra = (nsat - 1) // 12 if flag < 2 else 0
        if k + extra >= n:
            raise _truncated(path, k + 1, "satellite list continues past the end of the file")
        ids = line[32:68] + "".join(lines[k + 1 + j][32:68] for j in range(extra))
        epoch_line = k + 1
        k += 1 + extra
        if flag > 1:  # event record: nsat special lines follow
            k += nsat
            continue
        _check_satellite_list(ids, nsat, path, epoch_line)
        if k + nsat * per > n:
            raise _truncated(
                path,
                k + 1,
                f"{nsat} satellites x {per} lines expected, {n - k} lines left in the file",
            )
        kept = 0
        for i in range(nsat):
            sid = ids[3 * i : 3 * i + 3]
            if _V2_EPOCH.match(lines[k]):
                raise InputError(
                    f"the epoch line {epoch_line} counts {nsat} satellites but only {i} "
                    "records follow before this epoch line",
                    source=str(path),
                    line=k + 1,
                )
            if sid[0] in keep:
                body.prn.append(sid)
                body.text.append("".join(lines[k + j].ljust(80)[:80] for j in range(per)))
                body.line.append(k + 1)
                kept += 1
            k += per
        body.cal.append(cal)
        body.flag.append(flag)
        body.count.append(kept)
        body.epoch_line.append(epoch_line)
    offsets = [(j // 5) * 80 + (j % 5) * 16 for j in range(n_types)]
    return body, per * 80, offsets


def _scan_v3(lines, k, n_types, path, keep="G"):
    """RINEX 3 body: '>' epoch lines, one line per satellite ('G01' + 16-column fields)."""
    width = 16 * n_types
    body, n = _Body(), len(lines)
    while k < n:
        line = lines[k]
        if not line.strip():
            k += 1
            continue
        if line[0] != ">":
            after = (
                f" (the epoch line {body.epoch_line[-1]} counts {body.count_all[-1]} "
                "satellites: more records follow than it counts)"
                if body.epoch_line
                else ""
            )
            raise InputError(
                f"expected an epoch line starting '>', found {line[:20]!r}{after}",
                source=str(path),
                line=k + 1,
            )
        try:
            cal = (
                int(line[2:6]),
                int(line[7:9]),
                int(line[10:12]),
                int(line[13:15]),
                int(line[16:18]),
                float(line[18:29]),
            )
            flag, nsat = int(line[31:32] or 0), int(line[32:35])
        except ValueError:
            raise InputError(
                f"unreadable epoch line {line.rstrip()!r}", source=str(path), line=k + 1
            ) from None
        epoch_line = k + 1
        k += 1
        if flag > 1:
            k += nsat
            continue
        short = next((j for j in range(k, min(k + nsat, n)) if lines[j][:1] == ">"), None)
        if short is not None:
            raise InputError(
                f"the epoch line {epoch_line} counts {nsat} satellites but only "
                f"{short - k} records follow before the next epoch line",
                source=str(path),
                line=short + 1,
            )
        if k + nsat > n:
            raise _truncated(path, k, f"{nsat} satellite lines expected")
        kept = 0
        for j in range(k, k + nsat):
            if lines[j][0] in keep:
                body.prn.append(lines[j][:3])
                body.text.append(lines[j][3:].ljust(width)[:width])
                body.line.append(j + 1)
                kept += 1
        k += nsat
        body.cal.append(cal)
        body.flag.append(flag)
        body.count.append(kept)
        body.count_all.append(nsat)
        body.epoch_line.append(epoch_line)
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


def _satellites(body, path):
    """System letters (S1 array) and numbers of the satellite records."""
    ids = np.array(body.prn, dtype="S3").view("S1").reshape(-1, 3)
    try:
        number = np.ascontiguousarray(ids[:, 1:3]).view("S2").ravel().astype(np.int64)
    except ValueError:
        raise InputError("unreadable satellite number", source=str(path)) from None
    return ids[:, 0], number


def _check_epoch_order(t, epoch_line, path):
    """Epochs must follow each other in time: a repeated or earlier epoch is refused."""
    step = np.diff(t)
    back = np.flatnonzero(step <= 0.0)
    if back.size:
        i = int(back[0]) + 1
        said = "repeats" if step[i - 1] == 0 else "comes before"
        raise InputError(
            f"this epoch {said} the epoch at line {epoch_line[i - 1]}: epochs duplicated "
            "or out of order",
            source=str(path),
            line=epoch_line[i],
        )


def read_obs(path, systems="G"):
    """Read a RINEX 2.11 or 3.x GPS observation file (GPS satellites only).

    Parameters
    ----------
    path : str or Path
        ``.YYo``, ``.rnx`` or either gzip-compressed.
    systems : str
        RINEX letters of the systems to keep: ``"G"`` (the default) reads GPS as it
        always did; ``"GREC"`` (any of G R E C J) reads a mixed file
        (:func:`read_mixed_obs`).

    Returns
    -------
    ObservationFile

    Raises
    ------
    InputError
        Another version or file type, a file without GPS, a truncated epoch
        record or an unreadable number (file and line named).
    """
    if systems != "G":
        return read_mixed_obs(path, systems)
    lines = read_lines(path)
    header, k = split_header(lines, path)
    version, ftype, system = version_line(header, path)
    if ftype != "O" or not (2.0 <= version < 4.0) or system not in ("G", "M", " "):
        raise InputError(
            f"not a GPS observation file of RINEX 2 or 3 (version {version}, "
            f"type {ftype!r}, system {system!r})",
            source=str(path),
            line=1,
        )
    types, marker, interval, pos = _header_info(header, version, path)
    scan = _scan_v2 if version < 3 else _scan_v3
    body, width, offsets = scan(lines, k, len(types), path)
    if not body.cal:
        raise InputError(
            "no observation epoch after the header (a header-only file?)",
            source=str(path),
            line=len(lines),
        )
    values = _numbers(body, width, offsets, path)
    _, prn = _satellites(body, path)
    cal = np.array(body.cal, dtype=float).reshape(-1, 6)
    week, sow = gps_week_sow(*cal[:, :5].astype(np.int64).T, cal[:, 5])
    _check_epoch_order(np.asarray(week, float) * 604800.0 + sow, body.epoch_line, path)
    return ObservationFile(
        path=str(path),
        version=version,
        marker=marker,
        approx_pos_e=pos,
        interval=interval,
        types=types,
        week=np.asarray(week, np.int64),
        time=np.asarray(sow, float),
        flag=np.array(body.flag, np.int8),
        start=np.concatenate([[0], np.cumsum(body.count, dtype=np.int64)]),
        prn=prn,
        values=values,
        line=np.array(body.line, np.int64),
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


@dataclass(frozen=True)
class MixedObservationFile:
    """Observations of several systems read from a RINEX 2.11 or 3.0x file.

    As :class:`ObservationFile`, with ``prn`` the satellite number of
    :mod:`inins.core.satellites` (100 * system + number), ``types`` the union of the
    systems' observation codes (a column is NaN on rows of a system without it),
    ``system_types`` the codes of each system letter and ``glonass_channels`` the
    header's GLONASS SLOT / FRQ # (slot -> channel; empty when absent).
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


def read_mixed_obs(path, systems="GREC"):
    """Read the satellites of ``systems`` (RINEX letters) from a RINEX 2.11 or 3.0x file.

    Raises
    ------
    InputError
        Another version or type; a single-system file of a system not asked for; no
        observation type of the systems asked; truncated or unreadable records.
    """
    from inins.core.satellites import LETTERS

    unknown = set(systems) - set(LETTERS[:5])
    if unknown:
        raise InputError(f"unknown satellite systems {sorted(unknown)}", source=str(path))
    lines = read_lines(path)
    header, k = split_header(lines, path)
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
    keep = systems + (" " if "G" in systems else "")
    if version < 3:
        types = per_system[next(iter(per_system))]
        body, width, offsets = _scan_v2(lines, k, len(types), path, keep)
        union = tuple(types)
        columns = None
    else:
        n_max = max(len(t) for t in per_system.values())
        body, width, offsets = _scan_v3(lines, k, n_max, path, "".join(per_system))
        union = tuple(dict.fromkeys(c for t in per_system.values() for c in t))
        columns = {s: [union.index(c) for c in t] for s, t in per_system.items()}
    if not body.cal:
        raise InputError(
            "no observation epoch after the header (a header-only file?)",
            source=str(path),
            line=len(lines),
        )
    parsed = _numbers(body, width, offsets, path)
    letters, number = _satellites(body, path)
    letters = np.where(letters == b" ", b"G", letters)
    code = np.zeros(len(number), np.int64)
    for i, letter in enumerate(LETTERS):
        code[letters == letter.encode()] = i
    if columns is None:
        values = parsed
    else:
        values = np.full((len(number), len(union)), np.nan)
        for s, cols in columns.items():
            rows = np.flatnonzero(letters == s.encode())
            values[np.ix_(rows, cols)] = parsed[rows][:, : len(cols)]
    cal = np.array(body.cal, dtype=float).reshape(-1, 6)
    week, sow = gps_week_sow(*cal[:, :5].astype(np.int64).T, cal[:, 5])
    _check_epoch_order(np.asarray(week, float) * 604800.0 + sow, body.epoch_line, path)
    return MixedObservationFile(
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
        line=np.array(body.line, np.int64),
    )


def system_observable(obs, name):
    """Column of RINEX 2 observable ``name`` for every row of a mixed file, shape (m,):
    per system the first code of :data:`RINEX3_SYSTEM_NAMES` the system's header lists
    (RINEX 2: the name itself). NaN on rows of systems without it."""
    from inins.core.satellites import LETTERS

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
    from inins.core.satellites import LETTERS

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
