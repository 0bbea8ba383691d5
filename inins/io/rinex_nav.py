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

from inins.core.satellites import satellite_number
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
    """Read a RINEX 2 or 3 GPS navigation file (a RINEX 4 file: its GPS LNAV records,
    through :func:`read_navigation`).

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
    if 4.0 <= version < 5.0 and ftype == "N":  # RINEX 4: message records
        mixed = read_navigation(path)
        gps = mixed.records[mixed.records["prn"] < 100]
        if not len(gps):
            raise InputError("no GPS navigation record", source=str(path), line=len(lines))
        return NavigationFile(
            path=str(path),
            version=version,
            records=gps,
            iono_alpha=mixed.iono_alpha,
            iono_beta=mixed.iono_beta,
        )
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


# ---------------------------------------------------------------------------------------
# All systems: RINEX 2 GPS (N) and GLONASS (G), RINEX 3 mixed, RINEX 4 (message records)

GLONASS_FIELDS = (
    ("sat", "int64", "", "satellite number 100 + slot"),
    ("week", "int64", "week", "GPS week of tb"),
    ("toe", "float64", "s", "tb in GPS seconds of week (UTC epoch + leap seconds)"),
    ("clock_bias", "float64", "s", "-tau_n"),
    ("gamma", "float64", "", "+gamma_n, relative frequency bias"),
    ("pos", "float64", "m", "PZ-90.11 position at tb", 3),
    ("vel", "float64", "m/s", "PZ-90.11 velocity at tb", 3),
    ("acc", "float64", "m/s^2", "lunisolar acceleration", 3),
    ("health", "int64", "", "Bn health (0 healthy)"),
    ("channel", "int64", "", "frequency channel k"),
    ("line", "int64", "", "1-based line of the record"),
)
"""Fields of the GLONASS records of :class:`MixedNavigation` (km of the file -> m)."""

_KEPLER_LINES = {"G": 8, "E": 8, "C": 8, "J": 8, "I": 8}
_OTHER_LINES = {"R": 4, "S": 4}
RINEX4_MESSAGES = {
    "G": {"LNAV": "kepler", "CNAV": None, "CNV2": None},
    "J": {"LNAV": "kepler", "CNAV": None, "CNV2": None},
    "E": {"INAV": "kepler", "FNAV": "kepler"},
    "C": {"D1": "kepler", "D2": "kepler", "CNV1": None, "CNV2": None, "CNV3": None},
    "R": {"FDMA": "glonass", "L1OC": None, "L3OC": None},
    "S": {"SBAS": None},
    "I": {"LNAV": None, "L1NV": None},
}
"""RINEX 4.0x ephemeris message types per system: read ("kepler", "glonass") or known and
skipped (None, counted in :attr:`MixedNavigation.skipped`); any other is refused."""
RINEX4_RECORDS = ("EPH", "STO", "EOP", "ION")
"""RINEX 4 record types (STO, EOP and ION records are skipped)."""


@dataclass(frozen=True)
class MixedNavigation:
    """Broadcast data of all systems read from one file.

    Attributes
    ----------
    path : str
    version : float
    records : ndarray, structured, (n,)
        Keplerian sets (GPS, Galileo, BeiDou, QZSS) with the fields of
        :data:`EPHEMERIS_FIELDS` and ``line``; ``prn`` is the satellite number of
        :mod:`inins.core.satellites`; BeiDou week and times in BDT, Galileo in GST
        (GPS week numbering); ``tgd`` is GPS TGD, Galileo BGD E5b/E1 (I/NAV) or
        E5a/E1 (F/NAV), BeiDou TGD1 (B1I).
    glonass : ndarray, structured, (k,), fields of :data:`GLONASS_FIELDS`
    iono_alpha, iono_beta : ndarray (4,) or None, GPS Klobuchar
    leap_seconds : int or None, from the header (or the caller)
    skipped : dict, record kind -> count of records not read (other systems, RINEX 4
        messages inins does not use)
    """

    path: str
    version: float
    records: np.ndarray
    glonass: np.ndarray
    iono_alpha: np.ndarray | None
    iono_beta: np.ndarray | None
    leap_seconds: int | None
    skipped: dict

    @property
    def systems(self):
        """System letters with at least one record."""
        letters = {"GRECJS"[p // 100] for p in self.records["prn"].tolist()}
        return "".join(s for s in "GRECJS" if s in letters or (s == "R" and len(self.glonass)))


def _leap_seconds(header, path):
    for label, content, line in header:
        if label == "LEAP SECONDS":
            try:
                return int(content[:6])
            except ValueError:
                raise InputError(
                    f"unreadable LEAP SECONDS {content[:6]!r}", source=str(path), line=line
                ) from None
    return None


def _iono_all(header, version, path):
    alpha, beta = _iono(header, min(version, 3.99), path)
    if version >= 4:  # RINEX 4: ION records in the body carry it (not read)
        return None, None
    return alpha, beta


def _values(lines, k, count, first_col, indent, path):
    """Numbers of a record: three (or four) on the epoch line, four per following line."""
    first = lines[k]
    values = [
        parse_float(first[first_col + 19 * i : first_col + 19 * (i + 1)], path, k + 1)
        for i in range(3)
    ]
    for j in range(1, count):
        text = lines[k + j]
        values += [
            parse_float(text[indent + 19 * i : indent + 19 * (i + 1)], path, k + j + 1)
            for i in range(4)
        ]
    return values


def _epoch_any(first, v2, path, line):
    """(system letter, number, calendar, first value column) of an epoch line."""
    try:
        if v2:
            return None, int(first[0:2]), _v2_calendar(first), 22
        cal = [
            int(first[4:8]),
            int(first[9:11]),
            int(first[12:14]),
            int(first[15:17]),
            int(first[18:20]),
            float(first[21:23]),
        ]
        return first[0], int(first[1:3]), cal, 23
    except ValueError:
        raise InputError(
            f"unreadable epoch line {first.rstrip()!r}", source=str(path), line=line
        ) from None


def _v2_calendar(first):
    return [
        int(first[3:5]),
        int(first[6:8]),
        int(first[9:11]),
        int(first[12:14]),
        int(first[15:17]),
        float(first[17:22]),
    ]


def _need(lines, k, count, path):
    if k + count > len(lines) or any(lines[j][:1] == ">" for j in range(k + 1, k + count)):
        raise InputError(
            f"truncated navigation record: fewer than {count} lines",
            source=str(path),
            line=k + 1,
        )


def read_navigation(path, *, leap_seconds=None):
    """Read the broadcast data of every system from a RINEX navigation file.

    RINEX 2.1x GPS (``.n``) and GLONASS (``.g``), RINEX 3.0x of any system or mixed,
    RINEX 4.0x (``> EPH`` message records: GPS/QZSS LNAV, Galileo I/NAV and F/NAV,
    BeiDou D1/D2, GLONASS FDMA read; the first GPS LNAV ``> ION`` record gives the
    Klobuchar coefficients; other known messages and STO/EOP/ION records skipped and
    counted). Plain or gzip-compressed.

    Parameters
    ----------
    path : str or Path
    leap_seconds : int, optional
        GPS - UTC (s) for the GLONASS epochs (UTC) when the header has no LEAP SECONDS;
        the header's value otherwise (a different value given here is refused).

    Returns
    -------
    MixedNavigation

    Raises
    ------
    InputError
        Not a navigation file; a truncated or unreadable record; a RINEX 4 record or
        message of an unknown type; GLONASS records without leap seconds; no record
        of any system (file and line named).
    """
    lines = read_lines(path)
    header, k = split_header(lines, path)
    version, ftype, system = version_line(header, path)
    v2 = version < 3.0
    if not ((v2 and ftype in ("N", "G")) or (3.0 <= version < 5.0 and ftype == "N")):
        raise InputError(
            f"not a RINEX 2, 3 or 4 navigation file (version {version}, type {ftype!r}, "
            f"system {system!r})",
            source=str(path),
            line=1,
        )
    header_leap = _leap_seconds(header, path)
    if leap_seconds is not None and header_leap is not None and leap_seconds != header_leap:
        raise InputError(
            f"leap seconds {leap_seconds} given, the header states {header_leap}",
            source=str(path),
            line=next(line for label, _, line in header if label == "LEAP SECONDS"),
        )
    leap = header_leap if header_leap is not None else leap_seconds
    kepler, glo, skipped, iono4 = [], [], {}, {}
    v2_letter = "R" if ftype == "G" else "G"
    while k < len(lines):
        first = lines[k]
        if not first.strip():
            k += 1
            continue
        if version >= 4:
            k = _rinex4_record(lines, k, path, kepler, glo, skipped, iono4)
            continue
        letter = v2_letter if v2 else first[0]
        count = _KEPLER_LINES.get(letter) or _OTHER_LINES.get(letter)
        if count is None:
            raise InputError(
                f"unknown satellite system {letter!r} of a navigation record",
                source=str(path),
                line=k + 1,
            )
        k = _record(lines, k, letter, count, v2, path, kepler, glo, skipped)
    if glo and leap is None:
        raise InputError(
            "GLONASS record epochs are UTC and the file gives no LEAP SECONDS: mixed time "
            "systems without the offset (give the leap seconds, GPS - UTC, e.g. 17 in 2016)",
            source=str(path),
            line=glo[0][-1],
        )
    if not kepler and not glo:
        raise InputError("no navigation record", source=str(path), line=len(lines))
    alpha, beta = _iono_all(header, version, path)
    if version >= 4 and iono4:
        alpha, beta = iono4["alpha"], iono4["beta"]
    return MixedNavigation(
        path=str(path),
        version=version,
        records=_kepler_records(kepler),
        glonass=_glonass_records(glo, leap or 0),
        iono_alpha=alpha,
        iono_beta=beta,
        leap_seconds=leap,
        skipped=skipped,
    )


def _record(lines, k, letter, count, v2, path, kepler, glo, skipped, indent=None):
    """Parse one RINEX 2/3 record at line ``k`` (or skip it); the next line index."""
    if letter not in "GRECJ":
        skipped[letter] = skipped.get(letter, 0) + 1
        return k + count
    _need(lines, k, count, path)
    _, number, cal, col = _epoch_any(lines[k], v2, path, k + 1)
    if indent is None:
        indent = 3 if v2 else 4
    values = _values(lines, k, count, col, indent, path)
    if letter == "R":
        glo.append((100 + number, cal, values, k + 1))
    else:
        kepler.append((satellite_number(letter, number), cal, values, k + 1))
    return k + count


def _rinex4_record(lines, k, path, kepler, glo, skipped, iono=None):
    """One RINEX 4 record starting '>' at line ``k``; the index of the next record."""
    head = lines[k]
    parts = head[1:].split()
    end = k + 1
    while end < len(lines) and lines[end][:1] != ">":
        end += 1
    if head[:1] != ">" or not parts or parts[0] not in RINEX4_RECORDS:
        raise InputError(
            f"unknown RINEX 4 record type {head.strip()[:24]!r} (expected '> EPH', '> STO', "
            "'> EOP' or '> ION')",
            source=str(path),
            line=k + 1,
        )
    if parts[0] == "ION" and len(parts) >= 3 and parts[1][:1] == "G" and parts[2] == "LNAV":
        if iono is not None and not iono and end - k >= 4:  # the first GPS Klobuchar record
            values = _values(lines, k + 1, 3, 23, 4, path)
            iono["alpha"], iono["beta"] = np.array(values[0:4]), np.array(values[4:8])
            return end
    if parts[0] != "EPH":
        skipped[parts[0]] = skipped.get(parts[0], 0) + 1
        return end
    if len(parts) < 3 or parts[1][:1] not in RINEX4_MESSAGES:
        raise InputError(
            f"unreadable RINEX 4 ephemeris record {head.strip()!r}", source=str(path), line=k + 1
        )
    letter, message = parts[1][0], parts[2]
    kinds = RINEX4_MESSAGES[letter]
    if message not in kinds:
        raise InputError(
            f"unknown RINEX 4 ephemeris message {message!r} of {parts[1]} (known for "
            f"{letter}: {', '.join(kinds)})",
            source=str(path),
            line=k + 1,
        )
    if kinds[message] is None:
        skipped[f"{letter} {message}"] = skipped.get(f"{letter} {message}", 0) + 1
        return end
    count = 8 if kinds[message] == "kepler" else 4
    if end - (k + 1) < count:
        raise InputError(
            f"truncated navigation record: {end - k - 1} of {count} lines",
            source=str(path),
            line=k + 2,
        )
    _record(lines, k + 1, letter, count, False, path, kepler, glo, skipped)
    return end


def _kepler_records(rows):
    dtype = [(name, dt) for name, dt, _, _ in EPHEMERIS_FIELDS] + [("line", "int64")]
    if not rows:
        return np.zeros(0, dtype=dtype)
    out = _records(rows)
    values = np.array([r[2] for r in rows])
    system = out["prn"] // 100
    gal = system == 2
    if gal.any():  # BGD of the message's frequency pair: E5b/E1 for I/NAV (source bit 9)
        sources = values[:, 3 + 17].astype(np.int64)
        e5b = (sources & (1 << 9)) != 0
        out["tgd"] = np.where(gal & e5b, values[:, 3 + 23], out["tgd"])
    out["fit_interval"] = np.where(system == 0, out["fit_interval"], 4.0)
    return out


def _glonass_records(rows, leap_seconds):
    dtype = [(f[0], f[1], f[4]) if len(f) == 5 else (f[0], f[1]) for f in GLONASS_FIELDS]
    out = np.zeros(len(rows), dtype=dtype)
    if not rows:
        return out
    values = np.array([r[2] for r in rows])
    cal = np.array([r[1] for r in rows])
    week, sow = gps_week_sow(*cal.T)
    sow = sow + leap_seconds  # UTC -> GPS time
    carry = np.floor(sow / 604800.0)
    out["week"], out["toe"] = week + carry.astype(np.int64), sow - 604800.0 * carry
    out["sat"] = [r[0] for r in rows]
    out["line"] = [r[3] for r in rows]
    out["clock_bias"], out["gamma"] = values[:, 0], values[:, 1]
    orbit = values[:, 3:15].reshape(-1, 3, 4) * 1e3  # km -> m
    out["pos"], out["vel"], out["acc"] = orbit[:, :, 0], orbit[:, :, 1], orbit[:, :, 2]
    out["health"] = values[:, 6].astype(np.int64)
    out["channel"] = values[:, 10].astype(np.int64)
    return out
