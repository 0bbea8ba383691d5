"""Text files read a line at a time with a bound on each line (plain or gzip).

A data file of any size is read in memory proportional to what it holds, never to
what follows: a line longer than the reader's bound is refused at once as bad input
(a 2 GB file of junk after a valid header is refused at its first line, not after it
has been loaded), and the readers that use these functions parse each line as it
comes, so that the first line that is not data ends the read.
"""

import gzip
import io

from inins.exceptions import InputError

MAX_LINE = 4096
"""Longest line (characters) a data file of inins may have; longer is not data."""


CHUNK = 1 << 20
"""Bytes read at a time."""


def open_binary(path):
    """A binary stream of ``path``, decompressed when it is gzip (by its magic bytes)."""
    path = str(path)
    try:
        with open(path, "rb") as f:
            compressed = f.read(2) == b"\x1f\x8b"
        return gzip.open(path, "rb") if compressed else open(path, "rb")
    except OSError as exc:
        raise InputError(f"cannot read: {exc.strerror or exc}", source=path) from None


def open_text(path):
    """A text stream of ``path`` (gzip or not); undecodable bytes replaced, so that junk
    is refused by the parser with its line, not by the decoder."""
    return io.TextIOWrapper(open_binary(path), encoding="utf-8", errors="replace", newline="")


def chunks(path, max_chars=MAX_LINE, what="a data file"):
    """``(number of the first line, [lines])`` of ``path`` a :data:`CHUNK` of bytes at a
    time (1-based numbers, the ends of line removed).

    Raises
    ------
    InputError
        The file cannot be read or decompressed, or a line is longer than
        ``max_chars`` (file and line named).
    """
    path = str(path)

    def too_long(n):
        return InputError(
            f"line longer than {max_chars} characters: not {what} (junk?)", source=path, line=n
        )

    with open_binary(path) as f:
        n, rest = 1, b""
        while True:
            try:
                chunk = f.read(CHUNK)
            except (OSError, EOFError, gzip.BadGzipFile) as exc:
                raise InputError(f"cannot read: {exc}", source=path, line=n) from None
            if not chunk:
                break
            parts = (rest + chunk).split(b"\n")
            rest = parts.pop()
            if len(rest) > max_chars + 1:
                raise too_long(n + len(parts))
            if not parts:
                continue
            text = b"\n".join(parts).decode("utf-8", "replace").replace("\r", "").split("\n")
            if max(map(len, text)) > max_chars:
                raise too_long(n + next(i for i, t in enumerate(text) if len(t) > max_chars))
            yield n, text
            n += len(text)
        if rest:
            yield n, [rest.decode("utf-8", "replace").replace("\r", "")]


def lines(path, max_chars=MAX_LINE, what="a data file"):
    """``(number, line)`` of every line of ``path`` (:func:`chunks`, one at a time)."""
    for first, block in chunks(path, max_chars, what):
        yield from enumerate(block, first)


class LineReader:
    """Lines of a file one at a time with a one-line look-ahead (:meth:`peek`) and a
    fast :meth:`take` of several, for readers of record formats (RINEX) that must see
    the next line before taking it. Holds one chunk of the file at a time.

    ``number`` is the 1-based line number of the line returned last.
    """

    def __init__(self, path, max_chars=MAX_LINE, what="a data file"):
        self.path = str(path)
        self._chunks = chunks(path, max_chars, what)
        self._buf, self._i, self._first = [], 0, 1
        self.number = 0

    def _fill(self):
        """True when a line is waiting (a new chunk read if needed)."""
        while self._i >= len(self._buf):
            got = next(self._chunks, None)
            if got is None:
                return False
            self._first, self._buf = got
            self._i = 0
        return True

    def peek(self):
        """The next line without taking it (None at the end)."""
        return self._buf[self._i] if self._fill() else None

    def next(self):
        """The next line (None at the end)."""
        if not self._fill():
            return None
        self._i += 1
        self.number = self._first + self._i - 1
        return self._buf[self._i - 1]

    def take(self, count):
        """The next ``count`` lines (fewer at the end of the file)."""
        if self._i + count <= len(self._buf):
            out = self._buf[self._i : self._i + count]
            self._i += count
            self.number = self._first + self._i - 1
            return out
        out = []
        while len(out) < count and (line := self.next()) is not None:
            out.append(line)
        return out

    def close(self):
        self._chunks.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
