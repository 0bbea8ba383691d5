"""RINEX 2.x and 3.x GPS navigation files (broadcast ephemerides).

Reads RINEX 2.10/2.11 GPS navigation (type N) and RINEX 3.0x navigation of
system G or M (GPS records kept, others skipped), plain or gzip-compressed.
Returns the LNAV parameters of every record as a structured array whose field
names, dtypes and units are those of :data:`EPHEMERIS_FIELDS` (the same names
as :data:`inins.gnss.ephemeris.FIELDS`; a test keeps them equal), plus the
Klobuchar coefficients when the header carries them.

Record layout (RINEX 2.11 Table A4 / RINEX 3.04 Table A6): epoch line with
PRN, time of clock and af0, af1, af2; seven broadcast-orbit lines of four
D19.12 numbers (3 or 4 leading blanks).
"""

from dataclasses import dataclass

import numpy as np

from inins.exceptions import InputError
from inins.io.flight_layout import EPHEMERIS_FIELDS
from inins.io.rinex_text import gps_week_sow, parse_float, read_lines, split_header, version_line

# position of each parameter among the 29 numbers of orbit lines 1-7 (after af0-af2)
_ORBIT = (
    "iode",
    "crs",
    "delta_n",
    "m0",
    "cuc",
    "e",
    "cus",
    "sqrt_a",
    "toe",
    "cic",
    "omega0",
    "cis",
    "i0",
    "crc",
    "omega",
    "omega_dot",
    "idot",
    None,
    "week",
    None,
    "ura",
    "health",
    "tgd",
    None,
    None,
    "fit_interval",
)


@dataclass(frozen=True)
class NavigationFile:
    """Broadcast ephemerides read from a file.

    Attributes
    ----------
    path : str
    version : float
    records : ndarray, structured, shape (n_sets,)
        One row per record, fields of :data:`EPHEMERIS_FIELDS` (SI units, rad,
        GPS seconds of week, week of toe); ``line`` holds the 1-based line of the record.
    iono_alpha, iono_beta : ndarray, shape (4,), or None
        Klobuchar coefficients (s, s/semicircle^k) if the header has them.
    """

    path: str
    version: float
    records: np.ndarray
    iono_alpha: np.ndarray | None
    iono_beta: np.ndarray | None


def _iono(header, version, path):
    alpha = beta = None
    for label, content, line in header:
        if version < 3 and label in ("ION ALPHA", "ION BETA"):
            vals = np.array(
                [parse_float(content[2 + 12 * i : 14 + 12 * i], path, line) for i in range(4)]
            )
            alpha, beta = (vals, beta) if label == "ION ALPHA" else (alpha, vals)
        elif version >= 3 and label == "IONOSPHERIC CORR" and content[:4] in ("GPSA", "GPSB"):
            vals = np.array(
                [parse_float(content[5 + 12 * i : 17 + 12 * i], path, line) for i in range(4)]
            )
            alpha, beta = (vals, beta) if content[:4] == "GPSA" else (alpha, vals)
    return alpha, beta


def _epoch(first, version, path, line):
    """PRN, calendar fields and the position of af0 on the epoch line."""
    try:
        if version < 3:
            prn = int(first[0:2])
            cal = [
                int(first[3:5]),
                int(first[6:8]),
                int(first[9:11]),
                int(first[12:14]),
                int(first[15:17]),
                float(first[17:22]),
            ]
            return prn, cal, 22
        prn = int(first[1:3])
        cal = [
            int(first[4:8]),
            int(first[9:11]),
            int(first[12:14]),
            int(first[15:17]),
            int(first[18:20]),
            float(first[21:23]),
        ]
        return prn, cal, 23
    except ValueError:
        raise InputError(
            f"unreadable epoch line {first.rstrip()!r}", source=str(path), line=line
        ) from None


def read_nav(path):
    """Read a RINEX 2 or 3 GPS navigation file.

    Parameters
    ----------
    path : str or Path
        ``.YYn``, ``.rnx`` or either gzip-compressed.

    Returns
    -------
    NavigationFile

    Raises
    ------
    InputError
        Another version, file type or system; a truncated or unreadable record
        (file and line named); no GPS record at all.
    """
    lines = read_lines(path)
    header, k = split_header(lines, path)
    version, ftype, system = version_line(header, path)
    if not (
        (2.0 <= version < 3.0 and ftype == "N")
        or (3.0 <= version < 4.0 and ftype == "N" and system in ("G", "M"))
    ):
        raise InputError(
            f"not a GPS navigation file of RINEX 2 or 3 (version {version}, "
            f"type {ftype!r}, system {system!r})",
            source=str(path),
            line=1,
        )
    indent = 4 if version >= 3 else 3
    rows = []
    while k < len(lines):
        first = lines[k]
        if not first.strip():
            k += 1
            continue
        if version >= 3 and first[0] != "G":  # another system: its record length
            k += {"R": 4, "S": 4, "E": 8, "J": 8, "C": 8, "I": 8}.get(first[0], 1)
            continue
        if k + 8 > len(lines):
            raise InputError(
                f"truncated navigation record: {len(lines) - k} of 8 lines",
                source=str(path),
                line=k + 1,
            )
        prn, cal, col = _epoch(first, version, path, k + 1)
        values = [
            parse_float(first[col + 19 * i : col + 19 * (i + 1)], path, k + 1) for i in range(3)
        ]
        for j in range(1, 8):
            text = lines[k + j]
            values += [
                parse_float(text[indent + 19 * i : indent + 19 * (i + 1)], path, k + j + 1)
                for i in range(4)
            ]
        rows.append((prn, cal, values, k + 1))
        k += 8
    if not rows:
        raise InputError("no GPS navigation record", source=str(path), line=len(lines))
    alpha, beta = _iono(header, version, path)
    return NavigationFile(
        path=str(path), version=version, records=_records(rows), iono_alpha=alpha, iono_beta=beta
    )


def _records(rows):
    """Structured array of :data:`EPHEMERIS_FIELDS` (plus ``line``) from parsed records."""
    dtype = [(name, dt) for name, dt, _, _ in EPHEMERIS_FIELDS] + [("line", "int64")]
    out = np.zeros(len(rows), dtype=dtype)
    values = np.array([r[2] for r in rows])
    cal = np.array([r[1] for r in rows])
    week, sow = gps_week_sow(*cal.T)
    out["prn"] = [r[0] for r in rows]
    out["line"] = [r[3] for r in rows]
    out["toc"] = sow
    out["af0"], out["af1"], out["af2"] = values[:, 0], values[:, 1], values[:, 2]
    for j, name in enumerate(_ORBIT):
        if name is not None:
            out[name] = values[:, 3 + j]
    fit = out["fit_interval"]
    out["fit_interval"] = np.where(fit > 0, fit, 4.0)  # 0 or blank: the 4 h fit
    # toc is a calendar date: its week may differ from that of toe across a week boundary
    del week
    return out
