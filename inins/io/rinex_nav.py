"""RINEX 2.x and 3.x GPS navigation files (broadcast ephemerides).

Reads RINEX 2.10/2.11 GPS navigation (type N) and RINEX 3.0x navigation of
system G or M (GPS records kept, others skipped), plain or gzip-compressed, a bounded
line at a time (:mod:`inins.io.textlines`): a record is parsed as it is read, so junk is
refused at its first line.
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
from inins.io.rinex_text import (
    calendar_problem,
    gps_week_sow,
    open_rinex,
    parse_float,
    read_header,
    version_line,
)

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


def _calendar(cal, path, line):
    problem = calendar_problem(*cal)
    if problem:
        raise InputError(f"epoch line with an impossible {problem}", source=str(path), line=line)
    return cal


def _records23(reader, v2_letter, path):
    """``(letter, line, record lines)`` of each record of a RINEX 2 (``v2_letter``) or 3
    body, read as it comes; an unknown system or a record cut short is bad input."""
    while (first := reader.next()) is not None:
        if not first.strip():
            continue
        n = reader.number
        letter = v2_letter or first[0]
        count = _KEPLER_LINES.get(letter) or _OTHER_LINES.get(letter)
        if count is None:
            raise InputError(
                f"unknown satellite system {letter!r} of a navigation record",
                source=str(path),
                line=n,
            )
        rec = [first]
        while len(rec) < count:
            line = reader.next()
            if line is None or line[:1] == ">":
                raise InputError(
                    f"truncated navigation record: {len(rec)} of {count} lines",
                    source=str(path),
                    line=n,
                )
            rec.append(line)
        yield letter, n, rec


MAX_RECORD_LINES = 20
"""Most lines of a RINEX 4 record (an ephemeris has 5-10): more is not a record."""


def _records4(reader, path):
    """``(line, record lines)`` of each RINEX 4 record (a '>' line and the lines up to the
    next), read as it comes."""
    while (head := reader.next()) is not None:
        if not head.strip():
            continue
        n = reader.number
        rec = [head]
        while (ahead := reader.peek()) is not None and ahead[:1] != ">":
            rec.append(reader.next())
            if len(rec) > MAX_RECORD_LINES:
                raise InputError(
                    f"a record of more than {MAX_RECORD_LINES} lines: not RINEX 4 (junk?)",
                    source=str(path),
                    line=n,
                )
        yield n, rec


def read_nav(path):
    """Read the GPS records of a RINEX 2 or 3 GPS (or mixed) navigation file, or of a
    RINEX 4 file (its LNAV records): :func:`read_navigation` of system G, the records of
    other systems counted and not parsed (so no leap seconds are needed).

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
    with open_rinex(path) as reader:
        version, ftype, system = version_line(read_header(reader), path)
    if not (ftype == "N" and (version < 3.0 or version >= 4.0 or system in ("G", "M"))):
        raise InputError(
            f"not a GPS navigation file of RINEX 2, 3 or 4 (version {version}, "
            f"type {ftype!r}, system {system!r})",
            source=str(path),
            line=1,
        )
    mixed = read_navigation(path, systems="G")
    return NavigationFile(
        path=str(path),
        version=version,
        records=mixed.records,
        iono_alpha=mixed.iono_alpha,
        iono_beta=mixed.iono_beta,
    )


def _whole(values, rows, name, path):
    """``values`` of an integer field; a fraction is bad input naming the record's line."""
    bad = np.flatnonzero(values % 1 != 0)
    if bad.size:
        i = int(bad[0])
        raise InputError(
            f"{name} {values[i]!r} is not a whole number", source=str(path), line=rows[i][3]
        )
    return values


def _records(rows, path=None):
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
            v = values[:, 3 + j]
            out[name] = _whole(v, rows, name, path) if out.dtype[name].kind == "i" else v
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
    leap_line : int or None, the header's LEAP SECONDS line (None: given by the caller)
    """

    path: str
    version: float
    records: np.ndarray
    glonass: np.ndarray
    iono_alpha: np.ndarray | None
    iono_beta: np.ndarray | None
    leap_seconds: int | None
    skipped: dict
    leap_line: int | None = None

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


def _values(rec, n, first_col, indent, path):
    """Numbers of a record (lines ``rec``, the first at line ``n``): three (or four) on
    the epoch line, four per following line."""
    first = rec[0]
    values = [
        parse_float(first[first_col + 19 * i : first_col + 19 * (i + 1)], path, n) for i in range(3)
    ]
    for j, text in enumerate(rec[1:], 1):
        values += [
            parse_float(text[indent + 19 * i : indent + 19 * (i + 1)], path, n + j)
            for i in range(4)
        ]
    return values


def _epoch_any(first, v2, path, line):
    """(system letter, number, calendar, first value column) of an epoch line."""
    try:
        if v2:
            return None, int(first[0:2]), _calendar(_v2_calendar(first), path, line), 22
        cal = [
            int(first[4:8]),
            int(first[9:11]),
            int(first[12:14]),
            int(first[15:17]),
            int(first[18:20]),
            float(first[21:23]),
        ]
        return first[0], int(first[1:3]), _calendar(cal, path, line), 23
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


def read_navigation(path, *, leap_seconds=None, systems=None):
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
    systems : str, optional
        RINEX letters of the systems parsed (default all); records of the others are
        counted in ``skipped``.

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
    with open_rinex(path) as reader:
        header = read_header(reader)
        version, ftype, system = version_line(header, path)
        v2 = version < 3.0
        if not ((v2 and ftype in ("N", "G")) or (3.0 <= version < 5.0 and ftype == "N")):
            raise InputError(
                f"not a RINEX 2, 3 or 4 navigation file (version {version}, type {ftype!r}, "
                f"system {system!r})",
                source=str(path),
                line=1,
            )
        kepler, glo, skipped, iono4 = [], [], {}, {}
        if version >= 4:
            for n, rec in _records4(reader, path):
                _rinex4_record(rec, n, path, (kepler, glo, skipped, systems), iono4)
        else:
            v2_letter = ("R" if ftype == "G" else "G") if v2 else None
            for letter, n, rec in _records23(reader, v2_letter, path):
                _record(rec, n, letter, v2, path, (kepler, glo, skipped, systems))
        end = reader.number
    leap, leap_line = _leap(header, leap_seconds, path)
    if glo and leap is None:
        raise InputError(
            "GLONASS record epochs are UTC and the file gives no LEAP SECONDS: mixed time "
            "systems without the offset (give the leap seconds, GPS - UTC, e.g. 17 in 2016)",
            source=str(path),
            line=glo[0][-1],
        )
    if not kepler and not glo:
        what = "GPS navigation record" if systems == "G" else "navigation record"
        raise InputError(f"no {what}", source=str(path), line=end)
    alpha, beta = _iono_all(header, version, path)
    if version >= 4 and iono4:
        alpha, beta = iono4["alpha"], iono4["beta"]
    return MixedNavigation(
        path=str(path),
        version=version,
        records=_kepler_records(kepler, path),
        glonass=_glonass_records(glo, leap or 0, path),
        iono_alpha=alpha,
        iono_beta=beta,
        leap_seconds=leap,
        skipped=skipped,
        leap_line=leap_line,
    )


def _leap(header, given, path):
    """(leap seconds, header line or None): the header's LEAP SECONDS, else ``given``; a
    different value given beside the header's is refused."""
    header_leap = _leap_seconds(header, path)
    line = next((n for label, _, n in header if label == "LEAP SECONDS"), None)
    if given is not None and header_leap is not None and given != header_leap:
        raise InputError(
            f"leap seconds {given} given, the header states {header_leap}",
            source=str(path),
            line=line,
        )
    return (header_leap, line) if header_leap is not None else (given, None)


def _record(rec, n, letter, v2, path, into):
    """Parse one RINEX 2/3 record (lines ``rec``, the first at line ``n``) or count it;
    ``into``: the lists of Keplerian and GLONASS records, the counts of skipped ones and
    the systems parsed (None: all)."""
    kepler, glo, skipped, systems = into
    if letter not in "GRECJ" or (systems is not None and letter not in systems):
        skipped[letter] = skipped.get(letter, 0) + 1
        return
    _, number, cal, col = _epoch_any(rec[0], v2, path, n)
    values = _values(rec, n, col, 3 if v2 else 4, path)
    if letter == "R":
        glo.append((100 + number, cal, values, n))
    else:
        kepler.append((satellite_number(letter, number), cal, values, n))


def _rinex4_record(rec, n, path, into, iono=None):
    """One RINEX 4 record (a '>' line and its lines, the first at line ``n``); ``into`` as
    :func:`_record`."""
    skipped = into[2]
    head = rec[0]
    parts = head[1:].split()
    if head[:1] != ">" or not parts or parts[0] not in RINEX4_RECORDS:
        raise InputError(
            f"unknown RINEX 4 record type {head.strip()[:24]!r} (expected '> EPH', '> STO', "
            "'> EOP' or '> ION')",
            source=str(path),
            line=n,
        )
    if parts[0] == "ION" and len(parts) >= 3 and parts[1][:1] == "G" and parts[2] == "LNAV":
        if iono is not None and not iono and len(rec) >= 4:  # the first GPS Klobuchar record
            values = _values(rec[1:4], n + 1, 23, 4, path)
            iono["alpha"], iono["beta"] = np.array(values[0:4]), np.array(values[4:8])
            return
    if parts[0] != "EPH":
        skipped[parts[0]] = skipped.get(parts[0], 0) + 1
        return
    if len(parts) < 3 or parts[1][:1] not in RINEX4_MESSAGES:
        raise InputError(
            f"unreadable RINEX 4 ephemeris record {head.strip()!r}", source=str(path), line=n
        )
    letter, message = parts[1][0], parts[2]
    kinds = RINEX4_MESSAGES[letter]
    if message not in kinds:
        raise InputError(
            f"unknown RINEX 4 ephemeris message {message!r} of {parts[1]} (known for "
            f"{letter}: {', '.join(kinds)})",
            source=str(path),
            line=n,
        )
    if kinds[message] is None:
        skipped[f"{letter} {message}"] = skipped.get(f"{letter} {message}", 0) + 1
        return
    count = 8 if kinds[message] == "kepler" else 4
    if len(rec) - 1 < count:
        raise InputError(
            f"truncated navigation record: {len(rec) - 1} of {count} lines",
            source=str(path),
            line=n + 1,
        )
    _record(rec[1 : 1 + count], n + 1, letter, False, path, into)


def _kepler_records(rows, path=None):
    dtype = [(name, dt) for name, dt, _, _ in EPHEMERIS_FIELDS] + [("line", "int64")]
    if not rows:
        return np.zeros(0, dtype=dtype)
    out = _records(rows, path)
    values = np.array([r[2] for r in rows])
    system = out["prn"] // 100
    gal = system == 2
    if gal.any():  # BGD of the message's frequency pair: E5b/E1 for I/NAV (source bit 9)
        sources = _whole(values[:, 3 + 17], rows, "data sources", path).astype(np.int64)
        e5b = (sources & (1 << 9)) != 0
        out["tgd"] = np.where(gal & e5b, values[:, 3 + 23], out["tgd"])
    out["fit_interval"] = np.where(system == 0, out["fit_interval"], 4.0)
    return out


def _glonass_records(rows, leap_seconds, path=None):
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
    out["health"] = _whole(values[:, 6], rows, "health", path).astype(np.int64)
    out["channel"] = _whole(values[:, 10], rows, "frequency channel", path).astype(np.int64)
    return out
