"""Shared helpers of the RINEX readers: files read a bounded line at a time (plain or
gzip), header lines, calendar fields to GPS time."""

import numpy as np

from inins.exceptions import InputError
from inins.io.textlines import LineReader, lines

MAX_HEADER_LINES = 5000
"""Most header lines read looking for END OF HEADER (a real header has tens)."""


def open_rinex(path):
    """A :class:`~inins.io.textlines.LineReader` of a RINEX file (plain or gzip), each
    line bounded: a file is read a line at a time, never whole."""
    return LineReader(path, what="a RINEX file")


def read_header(reader):
    """Header lines as (label, content, line number) up to END OF HEADER, read from a
    :class:`~inins.io.textlines.LineReader` (which then stands at the first data line).

    Raises
    ------
    InputError
        No END OF HEADER (end of file, or not within :data:`MAX_HEADER_LINES` lines).
    """
    header = []
    while (line := reader.next()) is not None:
        label = line[60:].strip()
        header.append((label, line[:60], reader.number))
        if label == "END OF HEADER":
            return header
        if len(header) >= MAX_HEADER_LINES:
            break
    raise InputError(
        "no END OF HEADER line: not a RINEX file or truncated header",
        source=reader.path,
        line=max(reader.number, 1),
    )


def version_line(header, path):
    """(version, file type letter, satellite system letter) of the first header line."""
    if not header or header[0][0] != "RINEX VERSION / TYPE":
        raise InputError("first line is not 'RINEX VERSION / TYPE'", source=str(path), line=1)
    content = header[0][1]
    try:
        version = float(content[:9])
    except ValueError:
        raise InputError(
            f"unreadable RINEX version {content[:9]!r}", source=str(path), line=1
        ) from None
    return version, content[20:21].upper(), content[40:41].upper() or "G"


MAX_NUMBER = 1e12
"""Largest magnitude of a number in a navigation record (the largest real ones, GLONASS
positions in km and seconds of week, are below 1e6)."""


def parse_float(text, path, line):
    """A RINEX number (Fortran D exponent allowed; blank is 0.0); NaN, infinity and
    magnitudes from :data:`MAX_NUMBER` on are no RINEX numbers (bad input, line named)."""
    text = text.strip().replace("D", "E").replace("d", "E")
    if not text:
        return 0.0
    try:
        value = float(text)
    except ValueError:
        raise InputError(f"not a number: {text!r}", source=str(path), line=line) from None
    if not abs(value) < MAX_NUMBER:
        raise InputError(f"not a RINEX number: {text!r}", source=str(path), line=line)
    return value


_GPS_EPOCH = np.datetime64("1980-01-06", "D")


def calendar_problem(year, month, day, hour, minute, second):
    """What is wrong with the calendar fields of an epoch line, or None (the day checked
    against its month: 2015-02-30 is no date; 24:00:00, the end of the day some
    navigation files write, is accepted)."""
    import calendar

    full = year + 2000 if year < 80 else year + 1900 if year < 100 else year
    if not 1 <= month <= 12:
        return f"month {month}"
    if not 1 <= day <= calendar.monthrange(full, month)[1]:
        return f"day {day} of month {month}"
    midnight = hour == 24 and minute == 0 and second == 0.0
    if not (0 <= hour <= 23 and 0 <= minute <= 59 and 0.0 <= second < 61.0) and not midnight:
        return f"time {hour:02d}:{minute:02d}:{second:g}"
    return None


def gps_week_sow(year, month, day, hour, minute, second):
    """GPS (week, seconds of week) of calendar fields in GPS time (arrays or scalars).

    A two-digit year (RINEX 2) means 1980-2079.
    """
    year = np.asarray(year, dtype=np.int64)
    year = np.where(year < 80, year + 2000, np.where(year < 100, year + 1900, year))
    months = (year - 1970) * 12 + np.asarray(month, dtype=np.int64) - 1
    dates = months.astype("datetime64[M]").astype("datetime64[D]") + (
        np.asarray(day, dtype=np.int64) - 1
    )
    days = (dates - _GPS_EPOCH).astype(np.int64)
    week = days // 7
    sow = (days - 7 * week) * 86400.0 + np.asarray(hour) * 3600.0 + np.asarray(minute) * 60.0
    return week, sow + np.asarray(second, dtype=float)


def read_track(path):
    """A reference trajectory text file: rows ``[label] time X Y Z ...`` (s, ECEF m), such
    as the smartLoc ``*_GT.txt`` (label ``point3``). Returns (time (n,), pos (n, 3)).

    Raises
    ------
    InputError
        Unreadable rows, fewer than two rows, or time not increasing (file and line named).
    """
    rows = []
    for n, line in lines(path, what="a reference trajectory file"):
        words = line.split()
        if not words or words[0].startswith("#"):
            continue
        if not words[0].lstrip("+-").replace(".", "", 1).replace("e", "", 1).isdigit():
            words = words[1:]
        try:
            rows.append([float(w) for w in words[:4]])
        except ValueError:
            raise InputError("unreadable reference row", source=str(path), line=n) from None
        if len(rows[-1]) < 4:
            raise InputError("a reference row needs time X Y Z", source=str(path), line=n)
    data = np.array(rows).reshape(-1, 4)
    if len(data) < 2:
        raise InputError("fewer than two reference rows", source=str(path))
    bad = np.flatnonzero(np.diff(data[:, 0]) <= 0)
    if bad.size:
        raise InputError("reference time not increasing", source=str(path), line=int(bad[0]) + 2)
    return data[:, 0], data[:, 1:4]
