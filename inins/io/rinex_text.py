"""Shared helpers of the RINEX readers: text that may be gzip-compressed, header lines."""

import gzip
from pathlib import Path

import numpy as np

from inins.exceptions import InputError


def read_lines(path):
    """All lines of a text file, gzip-compressed or not (by its magic bytes).

    Raises
    ------
    InputError
        If the file cannot be read or is not text.
    """
    path = Path(path)
    try:
        raw = path.read_bytes()
        if raw[:2] == b"\x1f\x8b":
            raw = gzip.decompress(raw)
    except (OSError, EOFError) as exc:
        raise InputError(f"cannot read: {exc}", source=str(path)) from exc
    return raw.decode("ascii", errors="replace").splitlines()


def split_header(lines, path):
    """(header lines as (label, content, line number), index of the first data line)."""
    header = []
    for k, line in enumerate(lines):
        label = line[60:].strip()
        header.append((label, line[:60], k + 1))
        if label == "END OF HEADER":
            return header, k + 1
    raise InputError(
        "no END OF HEADER line: not a RINEX file or truncated header",
        source=str(path),
        line=len(lines),
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


def parse_float(text, path, line):
    """A RINEX number (Fortran D exponent allowed; blank is 0.0)."""
    text = text.strip().replace("D", "E").replace("d", "E")
    if not text:
        return 0.0
    try:
        return float(text)
    except ValueError:
        raise InputError(f"not a number: {text!r}", source=str(path), line=line) from None


_GPS_EPOCH = np.datetime64("1980-01-06", "D")


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
    for k, line in enumerate(read_lines(path)):
        words = line.split()
        if not words or words[0].startswith("#"):
            continue
        if not words[0].lstrip("+-").replace(".", "", 1).replace("e", "", 1).isdigit():
            words = words[1:]
        try:
            rows.append([float(w) for w in words[:4]])
        except ValueError:
            raise InputError("unreadable reference row", source=str(path), line=k + 1) from None
        if len(rows[-1]) < 4:
            raise InputError("a reference row needs time X Y Z", source=str(path), line=k + 1)
    data = np.array(rows).reshape(-1, 4)
    if len(data) < 2:
        raise InputError("fewer than two reference rows", source=str(path))
    bad = np.flatnonzero(np.diff(data[:, 0]) <= 0)
    if bad.size:
        raise InputError("reference time not increasing", source=str(path), line=int(bad[0]) + 2)
    return data[:, 0], data[:, 1:4]
