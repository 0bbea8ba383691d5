"""Readers of lab IMU logs: delimited text (CSV, PSINS) and HDF5, in blocks of rows.

A reader is opened once (header, column names, PSINS header rows) and then
yields :class:`Block` s of the columns asked for, as float64 in the order
asked for, so a log of any length is read with bounded memory. Every block
knows where its rows are in the file, so a problem found later (NaN, a time
gap) can name the 1-based line of a text file or the 1-based row of an HDF5
dataset.

Text is parsed with :func:`numpy.loadtxt` on a list of lines per block (its C
parser reads about 2 million six-column rows per second); only when it fails
is the block re-read line by line to find the line and what is wrong there.
"""

import itertools
import re
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from inins.exceptions import InputError

CHUNK_ROWS = 1 << 16
"""Rows per block."""

_COLUMN = re.compile(r"^(?P<name>.+)\[(?P<index>\d+)\]$")


@dataclass(frozen=True)
class Block:
    """Rows of a log, selected columns only.

    Attributes
    ----------
    values : ndarray, shape (k, m)
        The selected columns, float64 (an HDF5 log's next block reuses the array:
        keep a copy, not the array).
    first_row : int
        0-based index of the first row among all data rows of the log.
    lines : ndarray of int, shape (k,), or None
        1-based line of each row in a text file; None for HDF5.
    done : int
        Progress so far in bytes of the file (characters read of a text file, the
        share of rows read of an HDF5 file).
    """

    values: np.ndarray
    first_row: int
    lines: np.ndarray | None
    done: int

    def line(self, r):
        """1-based file line of row ``r`` of the block (None for HDF5)."""
        return None if self.lines is None else int(self.lines[r])

    def where(self, r):
        """Text naming row ``r`` for a message: ``"line 12"`` or ``"row 12"``."""
        if self.lines is None:
            return f"row {self.first_row + r + 1}"
        return f"line {self.lines[r]}"


class TextLog:
    """A delimited text log: optional header line, optional numeric preamble rows.

    Parameters
    ----------
    path : Path
    delimiter : str or None
        Field separator; None for runs of blanks and tabs.
    comment : str
        Lines starting with it are skipped, and it ends the data of a line.
    skip_lines : int
        Lines skipped at the top before anything else.
    header : bool
        The first line after ``skip_lines`` that is not blank or a comment
        holds the column names.
    preamble_rows : int
        Numeric rows after the header that are not data (PSINS: 3).
    """

    def __init__(
        self, path, delimiter=",", comment="#", skip_lines=0, header=False, preamble_rows=0
    ):
        self.path, self.source = Path(path), str(path)
        self.delimiter, self.comment = delimiter, comment
        self.names = None
        self.preamble = []
        self.size = _file_size(self.path)
        consumed = 0
        with self._open() as f:
            for consumed, text in enumerate(_decoded(f, self.source), start=1):
                if consumed <= skip_lines or self._skipped(text):
                    continue
                if header and self.names is None:
                    self.names = [_unquote(v) for v in self._split(text)]
                    self.header_line = consumed
                elif len(self.preamble) < preamble_rows:
                    self.preamble.append((consumed, self._numbers(text, consumed)))
                else:
                    consumed -= 1
                    break
        self.data_line = consumed + 1  # first line that may hold data
        if header and self.names is None:
            raise InputError(
                "no header line found (the file has no lines besides comments)",
                source=self.source,
                key="log.csv.header",
            )

    def _open(self):
        try:
            return open(self.path, encoding="utf-8", newline=None)
        except OSError as exc:
            raise InputError(
                f"cannot read the log: {exc.strerror}", source=self.source, key="log.file"
            ) from None

    def _skipped(self, text):
        stripped = text.strip()
        return not stripped or (bool(self.comment) and stripped.startswith(self.comment))

    def _split(self, text):
        text = text.split(self.comment, 1)[0] if self.comment else text
        return text.split(self.delimiter) if self.delimiter else text.split()

    def _numbers(self, text, line):
        fields = self._split(text)
        for j, field in enumerate(fields):
            try:
                if "_" in field:
                    raise ValueError(field)
                float(_unquote(field))
            except ValueError:
                raise InputError(
                    f"column {j}: expected a number, got {field.strip()!r}",
                    source=self.source,
                    line=line,
                ) from None
        return [float(_unquote(v)) for v in fields]

    def column_index(self, ref, key):
        """0-based index of a column given by name (needs a header) or index."""
        if isinstance(ref, int):
            return ref
        if self.names is None:
            raise InputError(
                f"column {ref!r} is named but the file has no header line; "
                "give 0-based column indices or set log.csv.header: true",
                source=self.source,
                key=key,
            )
        if ref not in self.names:
            raise InputError(
                f"no column {ref!r} in the header (line {self.header_line}: "
                f"{', '.join(self.names)})",
                source=self.source,
                key=key,
            )
        return self.names.index(ref)

    def blocks(self, columns, n_columns=None, chunk=None):
        """Yield :class:`Block` s of the columns ``columns`` (0-based indices).

        Parameters
        ----------
        columns : sequence of int
        n_columns : int, optional
            Columns every row must have; default the header's count, else the
            first data row's.
        chunk : int, optional
            Lines per block (default :data:`CHUNK_ROWS`).
        """
        chunk = chunk or CHUNK_ROWS
        n_columns = len(self.names) if n_columns is None and self.names else n_columns
        columns = list(columns)
        first_row, line, done = 0, self.data_line, 0
        with self._open() as f:
            for _ in itertools.islice(f, self.data_line - 1):
                pass
            while True:
                try:
                    lines = list(itertools.islice(f, chunk))
                except UnicodeDecodeError as exc:
                    raise InputError(
                        f"not UTF-8 text ({exc.reason}) after line {line - 1}", source=self.source
                    ) from None
                if not lines:
                    return
                done += sum(map(len, lines))
                table, rows = self._parse(lines, line, n_columns)
                if n_columns is None and table.shape[0]:
                    n_columns = table.shape[1]
                if table.shape[0]:
                    if max(columns) >= table.shape[1]:
                        raise InputError(
                            f"column index {max(columns)} is out of range: the rows have "
                            f"{table.shape[1]} columns (indices start at 0)",
                            source=self.source,
                            key="log.columns",
                        )
                    yield Block(table[:, columns], first_row, rows, done)
                    first_row += table.shape[0]
                line += len(lines)

    def _parse(self, lines, line, n_columns):
        """Parse a list of lines: (rows, 1-based line of each row)."""
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # a block of comments only: no data
                table = np.loadtxt(
                    lines,
                    delimiter=self.delimiter,
                    comments=self.comment or None,
                    ndmin=2,
                    quotechar='"',
                )
        except ValueError:
            table = None
        if table is None or (
            n_columns is not None and table.shape[0] and table.shape[1] != n_columns
        ):
            self._diagnose(lines, line, n_columns)
            raise InputError("cannot parse the data", source=self.source, line=line)
        if table.shape[0] == len(lines):
            return table, np.arange(line, line + len(lines))
        kept = [i for i, text in enumerate(lines) if not self._skipped(text)]
        return table, line + np.asarray(kept, dtype=np.int64)

    def _diagnose(self, lines, line, n_columns):
        """Raise an InputError naming the first bad line of a block."""
        for i, text in enumerate(lines):
            if self._skipped(text):
                continue
            fields = self._split(text)
            n_columns = len(fields) if n_columns is None else n_columns
            if len(fields) != n_columns:
                raise InputError(
                    f"expected {n_columns} columns, found {len(fields)}",
                    source=self.source,
                    line=line + i,
                )
            self._numbers(text, line + i)


class Hdf5Log:
    """An HDF5 log: each column is a 1-D dataset ``name`` or column ``name[j]`` of a
    2-D dataset; all have the same number of rows."""

    def __init__(self, path):
        import h5py

        self.path, self.source = Path(path), str(path)
        self.size = _file_size(self.path)
        try:
            with h5py.File(self.path, "r"):
                pass
        except OSError as exc:
            raise InputError(
                f"cannot read as HDF5 ({exc})", source=self.source, key="log.file"
            ) from None

    def _resolve(self, f, refs, keys):
        """(dataset, column or None) per reference, and the common row count."""
        import h5py

        out, n = [], None
        for ref, key in zip(refs, keys, strict=True):
            match = _COLUMN.match(ref)
            name, col = (match["name"], int(match["index"])) if match else (ref, None)
            dset = f.get(name)
            if not isinstance(dset, h5py.Dataset):
                raise InputError(
                    f"no dataset {name!r} in the file (datasets: "
                    f"{', '.join(_datasets(f)) or 'none'})",
                    source=self.source,
                    key=key,
                )
            if dset.ndim not in (1, 2) or (col is None) != (dset.ndim == 1):
                shape = "x".join(map(str, dset.shape))
                raise InputError(
                    f"dataset {name!r} has shape {shape}; name a 1-D dataset or "
                    f"a column of a 2-D one as {name}[j]",
                    source=self.source,
                    key=key,
                )
            if col is not None and col >= dset.shape[1]:
                raise InputError(
                    f"dataset {name!r} has {dset.shape[1]} columns, no column "
                    f"{col} (indices start at 0)",
                    source=self.source,
                    key=key,
                )
            if n is not None and dset.shape[0] != n:
                raise InputError(
                    f"dataset {name!r} has {dset.shape[0]} rows, the columns before it {n}",
                    source=self.source,
                    key=key,
                )
            n = dset.shape[0]
            out.append((name, col))
        return out, n

    def blocks(self, refs, keys, chunk=None):
        """Yield :class:`Block` s of the columns ``refs`` (``name`` or ``name[j]``);
        ``keys`` are the scenario keys naming them, for messages."""
        import h5py

        chunk = chunk or CHUNK_ROWS
        with h5py.File(self.path, "r") as f:
            cols, n = self._resolve(f, refs, keys)
            # each dataset opened once (f[name] costs ~0.3 ms, 8 ns a row of a block);
            # one read buffer per dataset and one values array, used block after block
            # (fresh arrays of a few MB each block go back to the system and are faulted
            # in again next block: 1 M page faults, 2 s of system time in a 24-h record)
            dsets = {name: f[name] for name, _ in cols}
            buffers, values = {}, None
            for k0 in range(0, n, chunk):
                k1 = min(n, k0 + chunk)
                if values is None or values.shape[0] != k1 - k0:
                    values = np.empty((k1 - k0, len(cols)))
                read = set()
                for j, (name, col) in enumerate(cols):
                    dset = dsets[name]
                    if dset.dtype.kind not in "biuf":
                        raise InputError(
                            f"dataset {name!r} holds {dset.dtype}, expected numbers",
                            source=self.source,
                            key=keys[j],
                        )
                    data = buffers.get(name)
                    if data is None or data.shape[0] != k1 - k0:
                        data = buffers[name] = np.empty((k1 - k0, *dset.shape[1:]), dset.dtype)
                    if name not in read:
                        dset.read_direct(data, np.s_[k0:k1])
                        read.add(name)
                    values[:, j] = data if col is None else data[:, col]
                yield Block(values, k0, None, int(self.size * k1 / n))


def _datasets(f):
    """Paths of every dataset in an open HDF5 file."""
    import h5py

    found = []
    f.visititems(lambda path, obj: found.append(path) if isinstance(obj, h5py.Dataset) else None)
    return found


def _decoded(lines, source):
    """Iterate text lines; a decoding error becomes an InputError."""
    try:
        yield from lines
    except UnicodeDecodeError as exc:
        raise InputError(f"not UTF-8 text ({exc.reason})", source=source) from None


def _file_size(path):
    if not path.exists():
        raise InputError("log file not found", source=str(path), key="log.file")
    if not path.is_file():
        raise InputError("is not a file", source=str(path), key="log.file")
    return path.stat().st_size


def _unquote(text):
    return text.strip().strip('"').strip()


def open_psins(path):
    """Open a PSINS SIMU text log: ``(TextLog, header)`` (see :func:`psins_header`).

    The format: ``%`` comment lines (the first names PSINS and SIMU), three
    header rows, then rows of integer counts gx gy gz ax ay az (an optional 7th
    column, time jitter in us, is not read).
    """
    path = Path(path)
    _file_size(path)
    with open(path, encoding="utf-8", errors="replace") as f:
        first = f.readline()
    if "PSINS" not in first or "SIMU" not in first:
        raise InputError(
            "not a PSINS SIMU log (its first line must name PSINS and SIMU)",
            source=str(path),
            line=1,
        )
    log = TextLog(path, None, "%", preamble_rows=3)
    return log, psins_header(log)


@dataclass(frozen=True)
class PsinsHeader:
    """The three header rows of a PSINS SIMU log, in the log's units and axis order.

    ``attitude_deg`` (pitch, roll, yaw; PSINS: ENU, yaw counter-clockwise from
    north), ``velocity_mps`` (E, N, U), site, ``t0_s``, ``dt_s``, the ``g_mps2`` of
    its micro-g, and the pulse weights ``gyro_pulse_arcsec`` and
    ``accel_pulse_ug_s`` (3,).
    """

    attitude_deg: list
    velocity_mps: list
    lat_deg: float
    lon_deg: float
    height_m: float
    t0_s: float
    dt_s: float
    g_mps2: float
    gyro_pulse_arcsec: list
    accel_pulse_ug_s: list


def psins_header(log):
    """The three header rows of a PSINS SIMU text log (:class:`PsinsHeader`)."""
    if len(log.preamble) < 3:
        raise InputError("a PSINS log needs 3 header rows before the data", source=log.source)
    for line, row in log.preamble:
        if len(row) < 6:
            raise InputError(
                f"PSINS header row: expected 6 numbers, found {len(row)}",
                source=log.source,
                line=line,
            )
    (_, avp), (line2, pos), (line3, scale) = log.preamble
    if not pos[4] > 0 or not pos[5] > 0:
        raise InputError(
            "PSINS header: the sampling interval (ms) and g must be > 0",
            source=log.source,
            line=line2,
        )
    if not all(v > 0 for v in scale[:6]):
        raise InputError("PSINS header: pulse weights must be > 0", source=log.source, line=line3)
    return PsinsHeader(
        attitude_deg=avp[0:3],
        velocity_mps=avp[3:6],
        lat_deg=pos[0],
        lon_deg=pos[1],
        height_m=pos[2],
        t0_s=pos[3],
        dt_s=pos[4] * 1e-3,
        g_mps2=pos[5],
        gyro_pulse_arcsec=scale[0:3],
        accel_pulse_ug_s=scale[3:6],
    )
