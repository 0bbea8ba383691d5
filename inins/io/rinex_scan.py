"""The body of a RINEX 2.11 or 3.0x observation file read a block of bytes at a time with
array operations: every line of a block found at once, the epoch lines parsed as
fixed-width fields of all epochs together, the records of each epoch located from the
satellite counts, and the 14-column values of all records converted in one call.

This is the fast path of :func:`inins.io.rinex_obs.read_obs`. It accepts only a body in
the strict layout the RINEX writers produce (epoch lines in their exact columns, each
epoch followed by exactly the records it counts, ASCII without control characters,
no blank line between epochs). Anything else, whether a file it cannot prove valid or
bad input, makes it give up (:class:`Fallback`), and the line-by-line reader of
:mod:`inins.io.rinex_obs` reads the file instead and refuses bad input with its file,
line and reason. Where the fast path accepts a file, the line reader accepts it too and
returns the same arrays (``tests/io/test_rinex_scan.py`` checks both on mutated files).

Memory: a block of :data:`inins.io.textlines.CHUNK` bytes at a time, plus the arrays of
the records read; junk (a line longer than :data:`inins.io.textlines.MAX_LINE`, a line
that is not where an epoch or a record must be) ends the fast path within the block
that holds it.
"""

import gzip
from dataclasses import dataclass

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from inins.io import textlines

SPACE, DOT, GT = 32, 46, 62


class Fallback(Exception):
    """The body is not in the strict layout: read it line by line instead."""


@dataclass(frozen=True)
class Scanned:
    """What the scan of a body found (the fields of
    :class:`inins.io.rinex_obs.ObservationFile` before the system codes are mapped).

    cal : ndarray (n_epochs, 6), year month day hour minute second (as written)
    flag, count, epoch_line : ndarray (n_epochs,), epoch flag, records kept, its line
    ids : ndarray of S3 (m,), satellite identifier of each record kept
    values : ndarray (m, n_types), numbers of each record kept (NaN where blank)
    line : ndarray (m,), 1-based line of each record kept
    skipped, events : dict, as :class:`inins.io.rinex_obs.ObservationFile`'s
    """

    cal: np.ndarray
    flag: np.ndarray
    count: np.ndarray
    epoch_line: np.ndarray
    ids: np.ndarray
    values: np.ndarray
    line: np.ndarray
    skipped: dict
    events: dict


def scan(path, header_lines, version, n_types, keep, rinex_letters):
    """The :class:`Scanned` body of ``path`` after its ``header_lines`` header lines, or
    None when it is not in the strict layout (the caller then reads it line by line).

    ``keep``: the satellite letters whose records are kept (RINEX 2: ``" "`` for GPS as
    well); ``rinex_letters``: the letters RINEX defines (others are counted as unknown).
    """
    try:
        return _scan(path, header_lines, version >= 3, n_types, keep, rinex_letters)
    except Fallback:
        return None


def _scan(path, header_lines, v3, n_types, keep, rinex_letters):
    parts, skipped, events = [], {}, {}
    per_block = _block_v3 if v3 else _block_v2
    with textlines.open_binary(path) as f:
        pending, to_skip, line0, final = b"", header_lines, header_lines + 1, False
        while not final:
            try:
                chunk = f.read(textlines.CHUNK)
            except (OSError, EOFError, gzip.BadGzipFile, ValueError):
                raise Fallback from None
            final = not chunk
            data = pending + chunk
            if to_skip:  # the header, already read
                cut = _after_lines(data, to_skip)
                to_skip -= data.count(b"\n", 0, cut)
                data = data[cut:]
            cut = len(data) if final else data.rfind(b"\n") + 1
            if len(data) - cut > textlines.MAX_LINE + 1:
                raise Fallback  # a line too long: junk, refused by the line reader
            whole = data[:cut]
            if final and whole and not whole.endswith(b"\n"):
                whole += b"\n"
            if b"\r" in whole:
                whole = whole.replace(b"\r\n", b"\n")
                if b"\r" in whole:
                    raise Fallback
            used, n_lines, part = per_block(whole, line0, final, n_types, keep)
            if part is not None:
                parts.append(part)
                _count(skipped, part.pop("skipped"), rinex_letters)
                for flag, n in part.pop("events").items():
                    events[flag] = events.get(flag, 0) + n
            pending = whole[used:] + data[cut:]
            line0 += n_lines
    if not parts or not any(len(p["cal"]) for p in parts):
        raise Fallback  # no epoch: the line reader says so
    joined = {key: np.concatenate([p[key] for p in parts]) for key in parts[0]}
    return Scanned(**joined, skipped=skipped, events=events)


def _after_lines(data, count):
    """Offset just after the ``count``-th newline of ``data`` (its length if fewer)."""
    at = -1
    for _ in range(count):
        at = data.find(b"\n", at + 1)
        if at < 0:
            return len(data)
    return at + 1


def _count(skipped, letters, rinex_letters):
    for byte, n in letters:
        letter = chr(byte)
        name = letter if letter in rinex_letters else f"unknown system {letter!r}"
        skipped[name] = skipped.get(name, 0) + n


class _Lines:
    """The lines of a block: start offsets, lengths, and fixed-width windows."""

    def __init__(self, whole, width):
        buf = np.frombuffer(whole, np.uint8)
        newline = np.flatnonzero(buf == 10)
        if np.count_nonzero((buf - np.uint8(SPACE)) > 94) != newline.size:
            raise Fallback  # a control character or a byte outside ASCII
        self.start = np.concatenate([[0], newline[:-1] + 1]).astype(np.int64)
        self.length = newline - self.start
        if self.length.size and self.length.max() > textlines.MAX_LINE:
            raise Fallback
        self.buf = np.concatenate([buf, np.full(width, SPACE, np.uint8)])
        self.windows = sliding_window_view(self.buf, width)
        self.width = width

    def rows(self, lines, first=0, width=None):
        """(len(lines), width) bytes of ``lines`` from column ``first``, spaces past
        each line's end (as ``line.ljust``)."""
        width = width or self.width - first
        out = self.windows[:, :width][self.start[lines] + first]
        out[np.arange(width) >= (self.length[lines] - first)[:, None]] = SPACE
        return out

    def blank_after(self, index):
        """True when every line from ``index`` on is empty or spaces."""
        rest = self.buf[self.start[index] :] if index < self.start.size else self.buf[:0]
        return bool(np.all((rest == SPACE) | (rest == 10)))


def _uint(cols):
    """Unsigned integers of fixed-width fields (n, w): spaces then at least one digit."""
    digit = (cols - np.uint8(48)) < 10
    if not np.all(digit | (cols == SPACE)) or not digit[:, -1].all():
        raise Fallback
    if np.any(digit[:, :-1] & ~digit[:, 1:]):
        raise Fallback  # a space after a digit
    value = np.zeros(len(cols), np.int64)
    for j in range(cols.shape[1]):
        value = value * 10 + np.where(digit[:, j], cols[:, j] - 48, 0)
    return value


def _seconds(cols, point):
    """Seconds of a fixed-width field written ``%11.7f``: the decimal point at column
    ``point``, exactly as ``float`` reads it (an integer over 10^7, correctly rounded)."""
    if not np.all(cols[:, point] == DOT):
        raise Fallback
    whole = _uint(cols[:, :point])
    frac = cols[:, point + 1 :]
    if not np.all((frac - np.uint8(48)) < 10):
        raise Fallback
    scale = 10 ** frac.shape[1]
    value = whole * scale
    for j in range(frac.shape[1]):
        value = value + (frac[:, j] - 48).astype(np.int64) * 10 ** (frac.shape[1] - 1 - j)
    return value / float(scale)


def _calendar(year, month, day, hour, minute, second):
    """Raise :class:`Fallback` unless every epoch has a possible date and time (the
    rules of :func:`inins.io.rinex_text.calendar_problem`)."""
    full = np.where(year < 80, year + 2000, np.where(year < 100, year + 1900, year))
    if np.any((month < 1) | (month > 12)):
        raise Fallback
    first = ((full - 1970) * 12 + month - 1).astype("datetime64[M]")
    days = ((first + 1).astype("datetime64[D]") - first.astype("datetime64[D]")).astype(int)
    midnight = (hour == 24) & (minute == 0) & (second == 0.0)
    clock = (hour <= 23) & (minute <= 59) & (second < 61.0)
    if np.any((day < 1) | (day > days)) or not np.all(clock | midnight):
        raise Fallback


def _epochs(e, fields):
    """(cal (n, 6) float, flag, nsat) of epoch-line windows ``e`` at the columns
    ``fields`` = (year, month, day, hour, minute, (second, point), flag, nsat) slices."""
    year, month, day, hour, minute = (_uint(e[:, s]) for s in fields[:5])
    sec_cols, point = fields[5]
    second = _seconds(e[:, sec_cols], point)
    flag = _uint(e[:, fields[6]])
    nsat = _uint(e[:, fields[7]])
    _calendar(year, month, day, hour, minute, second)
    if np.any(flag > 6):
        raise Fallback
    cal = np.stack([year, month, day, hour, minute], axis=1).astype(float)
    return np.concatenate([cal, second[:, None]], axis=1), flag, nsat


def _complete(cand, nxt, n_lines, final, lines):
    """How many epochs of the block are whole; the chain of epochs checked: each epoch
    line is followed by exactly the lines it counts and then by the next epoch line."""
    if cand.size == 0 or cand[0] != 0 or np.any(nxt[:-1] != cand[1:]):
        raise Fallback
    if nxt[-1] <= n_lines:
        if nxt[-1] < n_lines and not (final and lines.blank_after(nxt[-1])):
            raise Fallback
        return cand.size
    if final:
        raise Fallback  # truncated: the line reader names it
    return cand.size - 1


def _pair_tables():
    """Tables over every two-character pair (the first character in the low byte) of a
    field written ``%14.3f``: the class of the pair in the integer part (0 two spaces,
    1 space and minus, 2 space and digit, 3 minus and digit, 4 two digits, 5 any other),
    the value of its digits, and whether it is a point and a digit; then, over the
    classes of the five pairs of the integer part, whether they read as spaces, an
    optional minus and digits up to the point, and whether negative."""
    pair = np.arange(1 << 16)
    a, b = pair & 0xFF, pair >> 8
    da, db = (a >= 48) & (a <= 57), (b >= 48) & (b <= 57)
    kind = np.full(pair.size, 5, np.uint8)
    kind[(a == SPACE) & (b == SPACE)] = 0
    kind[(a == SPACE) & (b == 45)] = 1
    kind[(a == SPACE) & db] = 2
    kind[(a == 45) & db] = 3
    kind[da & db] = 4
    value = np.where(da & db, 10 * (a - 48) + (b - 48), np.where(db, b - 48, 0)).astype(float)
    point = (a == DOT) & db
    classes = np.stack(np.unravel_index(np.arange(6**5), (6,) * 5)[::-1], axis=1)
    lead = (classes >= 1) & (classes <= 3)
    valid = (
        (classes <= 4).all(axis=1)
        & (np.diff(np.minimum(classes, 2 + (classes == 4)), axis=1) >= 0).all(axis=1)
        & (lead.sum(axis=1) <= 1)
        & (classes[:, 4] >= 2)
        & (classes[:, 4] != 5)
    )
    negative = ((classes == 1) | (classes == 3)).any(axis=1)
    return kind, value, point, valid, negative


_KIND, _VALUE, _POINT, _VALID, _NEGATIVE = _pair_tables()
_WEIGHT = np.array([1e11, 1e9, 1e7, 1e5, 1e3, 1e2, 1.0])
"""Place of each pair's digits in the integer of a ``%14.3f`` field's digits."""
_BLANK_PAIR = SPACE | SPACE << 8


def _values(fields):
    """(m, n) floats of 14-column fields (m, n, 14), blanks NaN, exactly as the line
    reader's numpy conversion reads them.

    A field written ``%14.3f`` (spaces, an optional minus, digits, a point, three digits)
    is read by table: its seven character pairs give its digits and a check of its
    layout, and the value is the integer of its digits over 1000, a correctly rounded
    division of two exact doubles, which is the double ``float`` reads from the text.
    Other fields go to numpy's conversion one by one; one it cannot read ends the fast
    path (the line reader then names its line).
    """
    m, n = fields.shape[:2]
    raw = np.ascontiguousarray(fields).reshape(m * n, 14)
    pairs = raw.view(np.uint16)  # (m n, 7)
    kind = _KIND[pairs[:, :5]].astype(np.int16)
    key = kind[:, 0] + 6 * (kind[:, 1] + 6 * (kind[:, 2] + 6 * (kind[:, 3] + 6 * kind[:, 4])))
    strict = _VALID[key] & _POINT[pairs[:, 5]] & (_KIND[pairs[:, 6]] == 4)
    value = (_VALUE[pairs] @ _WEIGHT) / 1000.0
    value[_NEGATIVE[key]] *= -1.0
    blank = (key == 0) & (pairs[:, 5] == _BLANK_PAIR) & (pairs[:, 6] == _BLANK_PAIR)
    value[blank] = np.nan
    other = np.flatnonzero(~strict & ~blank)
    if other.size:
        try:
            value[other] = raw[other].copy().view("S14")[:, 0].astype(float)
        except ValueError:
            raise Fallback from None
    return value.reshape(m, n)


def _kept(letters, keep):
    keep_bytes = np.frombuffer(keep.encode("ascii"), np.uint8)
    kept = np.isin(letters, keep_bytes)
    other, counts = np.unique(letters[~kept], return_counts=True)
    first = [int(np.flatnonzero(letters == b)[0]) for b in other]
    order = np.argsort(first)
    return kept, [(int(other[i]), int(counts[i])) for i in order]


def _events(flag):
    values, counts = np.unique(flag[flag > 1], return_counts=True)
    return {int(v): int(n) for v, n in zip(values, counts, strict=True)}


V3_FIELDS = (slice(2, 6), slice(7, 9), slice(10, 12), slice(13, 15), slice(16, 18),
             (slice(18, 29), 3), slice(31, 32), slice(32, 35))  # fmt: skip
"""Columns of a RINEX 3 epoch line (``> 2016 06 06 10 00  0.0000000  0 12``)."""


def _block_v3(whole, line0, final, n_types, keep):
    """(bytes used, lines used, part) of a block of whole lines of a RINEX 3 body."""
    if not whole:
        return 0, 0, None
    width = 3 + 16 * n_types
    lines = _Lines(whole, max(width, 35))
    n_lines = lines.start.size
    first = np.where(lines.length > 0, lines.buf[lines.start], 0)
    cand = np.flatnonzero(first == GT)
    if cand.size == 0:
        return _blank_end(lines, final, len(whole))
    if lines.length[cand].min() < 35:
        raise Fallback
    cal, flag, nsat = _epochs(lines.rows(cand, 0, 35), V3_FIELDS)
    n = _complete(cand, cand + 1 + nsat, n_lines, final, lines)
    if n == 0:
        return 0, 0, None
    cand, cal, flag, nsat = cand[:n], cal[:n], flag[:n], nsat[:n]
    records = np.where(flag > 1, 0, nsat)
    rec = np.repeat(cand + 1, records) + _ramp(records)
    if rec.size and lines.length[rec].min() < 3:
        raise Fallback
    letters = lines.buf[lines.start[rec]]
    kept, skipped = _kept(letters, keep)
    rows = lines.rows(rec[kept], 0, width)
    epoch_of = np.repeat(np.arange(n), records)[kept]
    ok = flag <= 1
    part = {
        "cal": cal[ok],
        "flag": flag[ok],
        "count": np.bincount(epoch_of, minlength=n)[ok],
        "epoch_line": line0 + cand[ok],
        "ids": np.ascontiguousarray(rows[:, :3]).view("S3")[:, 0],
        "values": _values(rows[:, 3:].reshape(-1, n_types, 16)[:, :, :14]),
        "line": line0 + rec[kept],
        "skipped": skipped,
        "events": _events(flag),
    }
    used = int(cand[-1] + 1 + nsat[-1])
    return _bytes_of(lines, used, len(whole)), used, part


def _blank_end(lines, final, size):
    """A block without epoch lines: blank lines at the end of the file, else not in the
    strict layout."""
    if final and lines.blank_after(0):
        return size, lines.start.size, None
    raise Fallback


def _ramp(counts):
    """0, 1, ..., c - 1 for each count in turn."""
    total = int(counts.sum())
    return np.arange(total) - np.repeat(np.cumsum(counts) - counts, counts)


def _bytes_of(lines, used, size):
    return int(lines.start[used]) if used < lines.start.size else size


V2_FIELDS = (slice(1, 3), slice(4, 6), slice(7, 9), slice(10, 12), slice(13, 15),
             (slice(15, 26), 3), slice(26, 29), slice(29, 32))  # fmt: skip
"""Columns of a RINEX 2 epoch line (`` 15  1  8  0  0  0.0000000  0 12G01...``)."""


def _v2_epoch_lines(lines):
    """Lines in the exact layout of a RINEX 2 epoch line (the pattern
    :data:`inins.io.rinex_obs._V2_EPOCH` of the line reader)."""
    w = lines.rows(np.arange(lines.start.size), 0, 32)
    digit = (w - np.uint8(48)) < 10
    sp = w == SPACE
    ok = lines.length >= 32
    for c in (0, 3, 6, 9, 12, 15, 26, 27):
        ok &= sp[:, c]
    for c in (2, 5, 8, 11, 14, 17, 19, 20, 21, 22, 23, 24, 25, 28, 31):
        ok &= digit[:, c]
    for c in (1, 4, 7, 10, 13, 16, 29, 30):
        ok &= digit[:, c] | sp[:, c]
    return np.flatnonzero(ok & (w[:, 18] == DOT))


def _block_v2(whole, line0, final, n_types, keep):
    """(bytes used, lines used, part) of a block of whole lines of a RINEX 2 body."""
    if not whole:
        return 0, 0, None
    per = (n_types + 4) // 5
    lines = _Lines(whole, 80)
    n_lines = lines.start.size
    cand = _v2_epoch_lines(lines)
    if cand.size == 0:
        return _blank_end(lines, final, len(whole))
    cal, flag, nsat = _epochs(lines.rows(cand, 0, 32), V2_FIELDS)
    extra = np.where(nsat > 0, (nsat - 1) // 12, 0)
    nxt = np.where(flag > 1, cand + 1 + nsat, cand + 1 + extra + nsat * per)
    n = _complete(cand, nxt, n_lines, final, lines)
    if n == 0:
        return 0, 0, None
    cand, cal, flag, nsat, extra = cand[:n], cal[:n], flag[:n], nsat[:n], extra[:n]
    ok = flag <= 1
    sats = np.where(ok, nsat, 0)
    _check_lists(lines, cand[ok], nsat[ok], extra[ok])
    i = _ramp(sats)
    epoch = np.repeat(np.arange(n), sats)
    id_line = cand[epoch] + i // 12
    at = lines.start[id_line] + 32 + 3 * (i % 12)
    ids = lines.buf[at[:, None] + np.arange(3)]
    letters = ids[:, 0]
    kept, skipped = _kept(letters, keep)
    first_rec = cand[epoch] + 1 + extra[epoch] + i * per
    rec = first_rec[kept]
    text = np.stack([lines.rows(rec + j, 0, 80) for j in range(per)], axis=1)
    fields = text.reshape(len(rec), per * 5, 16)[:, :n_types, :14]
    part = {
        "cal": cal[ok],
        "flag": flag[ok],
        "count": np.bincount(epoch[kept], minlength=n)[ok],
        "epoch_line": line0 + cand[ok],
        "ids": np.ascontiguousarray(ids[kept]).view("S3")[:, 0],
        "values": _values(fields),
        "line": line0 + rec,
        "skipped": skipped,
        "events": _events(flag),
    }
    used = int(nxt[n - 1])
    return _bytes_of(lines, used, len(whole)), used, part


def _check_lists(lines, cand, nsat, extra):
    """The satellite list of each epoch holds exactly ``nsat`` satellites, 12 a line, in
    the columns the line reader takes them from (else :class:`Fallback`)."""
    if not cand.size:
        return
    full = np.repeat(cand, extra) + _ramp(extra)
    if full.size and lines.length[full].min() < 68:
        raise Fallback
    last = cand + extra
    listed = lines.rows(last, 32, 36)  # columns 33-68 of the last list line
    n_last = nsat - 12 * extra
    col = np.arange(36)
    inside = col < np.minimum(36, lines.length[last] - 32)[:, None]
    if np.any(inside & (col >= 3 * n_last[:, None]) & (listed != SPACE)):
        raise Fallback
    if np.any(lines.length[last] < 32 + 3 * n_last):
        raise Fallback
    pieces = listed.reshape(-1, 12, 3)
    filled = (pieces != SPACE).any(axis=2)
    if np.any((np.arange(12) < n_last[:, None]) & ~filled):
        raise Fallback
    if full.size:  # the full list lines: every piece a satellite
        pieces = lines.rows(full, 32, 36).reshape(-1, 12, 3)
        if not (pieces != SPACE).any(axis=2).all():
            raise Fallback
