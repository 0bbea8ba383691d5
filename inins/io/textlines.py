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


def open_text(path):
    """A text stream of ``path``: gzip-compressed or not, by its magic bytes; undecodable
    bytes replaced (so that junk is refused by the parser with its line, not by the
    decoder)."""
    path = str(path)
    try:
        with open(path, "rb") as f:
            compressed = f.read(2) == b"\x1f\x8b"
        raw = gzip.open(path, "rb") if compressed else open(path, "rb")
    except OSError as exc:
        raise InputError(f"cannot read: {exc.strerror or exc}", source=path) from None
    return io.TextIOWrapper(raw, encoding="utf-8", errors="replace", newline="")


def lines(path, max_chars=MAX_LINE, what="a data file"):
    """``(number, line)`` of every line of ``path`` (1-based, the end of line removed).

    Raises
    ------
    InputError
        The file cannot be read or decompressed, or a line is longer than
        ``max_chars`` (file and line named).
    """
    path = str(path)
    with open_text(path) as f:
        n = 0
        while True:
            try:
                text = f.readline(max_chars + 2)
            except (OSError, EOFError, gzip.BadGzipFile) as exc:
                raise InputError(f"cannot read: {exc}", source=path, line=n + 1) from None
            if not text:
                return
            n += 1
            body = text.rstrip("\r\n")
            if len(body) > max_chars:
                raise InputError(
                    f"line longer than {max_chars} characters: not {what} (junk?)",
                    source=path,
                    line=n,
                )
            yield n, body


class LineReader:
    """Lines of a file one at a time with a one-line look-ahead (:meth:`peek`), for
    readers of record formats (RINEX) that must see the next line before taking it.

    ``number`` is the 1-based line number of the line :meth:`next` returned last.
    """

    def __init__(self, path, max_chars=MAX_LINE, what="a data file"):
        self.path = str(path)
        self._it = lines(path, max_chars, what)
        self._ahead = None
        self.number = 0

    def peek(self):
        """The next line without taking it (None at the end)."""
        if self._ahead is None:
            self._ahead = next(self._it, None)
        return None if self._ahead is None else self._ahead[1]

    def next(self):
        """The next line (None at the end)."""
        if self.peek() is None:
            return None
        self.number, text = self._ahead
        self._ahead = None
        return text

    def close(self):
        self._it.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
