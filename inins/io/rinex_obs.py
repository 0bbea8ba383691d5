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


def _header_info(header, version, path):
    types, marker, interval, pos = [], "", np.nan, np.full(3, np.nan)
    system = ""
    for label, content, line in header:
        if label == "# / TYPES OF OBSERV" and version < 3:
            types += content[6:60].split()
        elif label == "SYS / # / OBS TYPES" and version >= 3:
            system = content[0] if content[0] != " " else system
            if system == "G":
                types += content[7:60].split()
        elif label == "MARKER NAME":
            marker = content.strip()
        elif label == "INTERVAL":
            interval = _float(content[:10], path, line)
        elif label == "APPROX POSITION XYZ":
            pos = np.array([_float(content[14 * i : 14 * i + 14], path, line) for i in range(3)])
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


def _scan_v2(lines, k, n_types, path):
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
            if sid[0] in "G ":
                body.prn.append(sid[1:3])
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


def _scan_v3(lines, k, n_types, path):
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
            if lines[j][0] == "G":
                body.prn.append(lines[j][1:3])
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


def read_obs(path):
    """Read a RINEX 2.11 or 3.x GPS observation file (GPS satellites only).

    Parameters
    ----------
    path : str or Path
        ``.YYo``, ``.rnx`` or either gzip-compressed.

    Returns
    -------
    ObservationFile

    Raises
    ------
    InputError
        Another version or file type, a file without GPS, a truncated epoch
        record or an unreadable number (file and line named).
    """
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
    try:
        prn = np.array(body.prn, dtype="U2").astype(np.int64)
    except ValueError:
        raise InputError("unreadable satellite number", source=str(path)) from None
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
