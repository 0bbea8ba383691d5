"""Stream long series into an open HDF5 file (a :class:`~inins.results.SeriesSink`).

Rows appended to a dataset are gathered into whole chunks (about 1 MiB, see
:func:`inins.io.h5layout.chunk_rows`) and each full chunk is written once, so
gzip runs once per chunk and never re-reads a partial chunk. The dataset grows
along its leading axis.

With ``threaded=True`` a background thread does the HDF5 work (creating
datasets, compressing and writing chunks, attributes) while the producer
computes the next block; a numba kernel compiled with ``nogil=True`` runs in
parallel with compression. The queue holds at most ``max_pending`` chunks, so
memory stays bounded: ``max_pending + 1`` chunks in flight plus one chunk
buffer per dataset. Rows are copied on ``append``; the caller may reuse its
array. An exception in the writer thread is raised in the caller at its next
``create``/``append``/``set_attrs``/``close``.

Before each chunk write the free space is checked (:func:`inins.io.diskspace.check_room`):
HDF5 reports a failed write late (at flush or close) and may crash on a file whose
writes failed, so the sink stops with :class:`inins.exceptions.OutputError` while
a margin sized to the file (:func:`inins.io.diskspace.margin_for`) is still free.
"""

import queue
import threading

import numpy as np

from inins.io.diskspace import check_room
from inins.io.h5layout import LONG_ROWS, chunk_rows, encode_attrs, storage_options


class _Stream:
    """Per-dataset state kept by the producer."""

    def __init__(self, row_shape, dtype, rows_per_chunk):
        self.row_shape, self.dtype = row_shape, dtype
        self.chunk = rows_per_chunk
        self.buffer = np.empty((rows_per_chunk, *row_shape), dtype)
        self.fill = 0
        self.emitted = 0


class H5SeriesSink:
    """A :class:`~inins.results.SeriesSink` writing into an open ``h5py.File``.

    Parameters
    ----------
    h5file : h5py.File
        Open for writing. While a threaded sink is open, only the sink may
        touch the file.
    threaded : bool
        Write on a background thread (see the module docstring).
    max_pending : int
        Queue bound in chunks (threaded only).
    """

    def __init__(self, h5file, threaded: bool = False, max_pending: int = 4):
        self._file = h5file
        self._streams: dict = {}
        self._error = None
        self._closed = False
        self.peak_pending = 0
        self._queue = queue.Queue(maxsize=max(1, max_pending)) if threaded else None
        self._abort = threading.Event()
        self._thread = None
        if threaded:
            self._thread = threading.Thread(target=self._work, name="inins-h5-writer", daemon=True)
            self._thread.start()

    # -- SeriesSink -------------------------------------------------------
    def create(
        self,
        path,
        row_shape,
        dtype,
        units,
        frame="",
        description="",
        expected_rows=None,
        attrs=None,
    ) -> None:
        """Declare a dataset of rows of ``row_shape`` (it starts empty)."""
        if path in self._streams:
            raise ValueError(f"dataset {path!r} is created twice")
        row_shape, dtype = tuple(int(n) for n in row_shape), np.dtype(dtype)
        opts = storage_options(row_shape, dtype, expected_rows)
        rows = opts.get("chunks", (None,))[0]
        if rows is None:  # short: uncompressed chunks sized to the expected rows
            rows = max(1, min(int(expected_rows or 1), LONG_ROWS, chunk_rows(row_shape, dtype)))
            opts = {"chunks": (rows, *row_shape)}
        self._streams[path] = _Stream(row_shape, dtype, rows)
        meta = {"units": units, "frame": frame, "description": description, **(attrs or {})}
        self._submit(("create", path, row_shape, dtype, opts, encode_attrs(meta)))

    def append(self, path, rows) -> None:
        """Add rows (shape ``(k, *row_shape)``) at the end of dataset ``path``."""
        stream = self._stream(path)
        rows = np.asarray(rows)
        if rows.shape[1:] != stream.row_shape:
            raise ValueError(f"{path}: rows of shape {rows.shape[1:]}, declared {stream.row_shape}")
        if not np.can_cast(rows.dtype, stream.dtype, "same_kind"):
            raise TypeError(f"{path}: cannot store {rows.dtype} rows in a {stream.dtype} dataset")
        i, n = 0, rows.shape[0]
        while i < n:
            if stream.fill == 0 and n - i >= stream.chunk:
                whole = stream.chunk if self._thread else (n - i) // stream.chunk * stream.chunk
                block = rows[i : i + whole]
                self._emit(path, stream, block.astype(stream.dtype, copy=self._thread is not None))
                i += whole
                continue
            take = min(stream.chunk - stream.fill, n - i)
            stream.buffer[stream.fill : stream.fill + take] = rows[i : i + take]
            stream.fill += take
            i += take
            if stream.fill == stream.chunk:
                self._flush_buffer(path, stream)

    def set_attrs(self, path, attrs) -> None:
        """Set attributes of a dataset or group (after ``create`` for a dataset)."""
        self._submit(("attrs", path, encode_attrs(attrs)))

    # -- life cycle -------------------------------------------------------
    def rows_written(self, path) -> int:
        """Rows appended so far to ``path`` (written or buffered)."""
        stream = self._stream(path)
        return stream.emitted + stream.fill

    def close(self) -> None:
        """Write buffered rows, wait for the writer thread, raise its error if any."""
        if self._closed:
            return
        try:
            for path, stream in self._streams.items():
                if stream.fill:
                    self._flush_buffer(path, stream)
        finally:
            self._closed = True
            self._stop()
        self._raise_if_failed()

    def abort(self) -> None:
        """Stop without writing buffered rows (the file is being discarded)."""
        if self._closed:
            return
        self._closed = True
        self._abort.set()
        self._stop()

    def __enter__(self):
        return self

    def __exit__(self, exc_type, exc, tb):
        if exc_type is None:
            self.close()
        else:
            self.abort()
        return False

    # -- internals --------------------------------------------------------
    def _stream(self, path) -> _Stream:
        try:
            return self._streams[path]
        except KeyError:
            raise KeyError(f"dataset {path!r} was not created in this sink") from None

    def _flush_buffer(self, path, stream) -> None:
        block = stream.buffer[: stream.fill]
        if self._thread is not None:  # hand the buffer over, start a new one
            stream.buffer = np.empty_like(stream.buffer)
        self._emit(path, stream, block)
        stream.fill = 0

    def _emit(self, path, stream, block) -> None:
        start = stream.emitted
        stream.emitted += block.shape[0]
        self._submit(("write", path, start, block))

    def _submit(self, op) -> None:
        if self._closed:
            raise RuntimeError("the sink is closed")
        self._raise_if_failed()
        if self._thread is None:
            self._do(op)
            return
        self._queue.put(op)
        self.peak_pending = max(self.peak_pending, self._queue.qsize())

    def _raise_if_failed(self) -> None:
        if self._error is not None:
            raise self._error

    def _work(self) -> None:
        while True:
            op = self._queue.get()
            if op is None:
                return
            if self._error is not None or self._abort.is_set():
                continue  # drain, so the producer never blocks on a dead writer
            try:
                self._do(op)
            except BaseException as exc:
                self._error = exc

    def _stop(self) -> None:
        if self._thread is not None:
            self._queue.put(None)
            self._thread.join()

    def _do(self, op) -> None:
        kind, path = op[0], op[1]
        if kind == "create":
            _, _, row_shape, dtype, opts, meta = op
            dset = self._file.create_dataset(
                path, shape=(0, *row_shape), maxshape=(None, *row_shape), dtype=dtype, **opts
            )
            for key, value in meta.items():
                dset.attrs[key] = value
        elif kind == "write":
            _, _, start, block = op
            filename = getattr(self._file, "filename", None)
            if filename is not None:
                check_room(filename, block.nbytes)
            dset = self._file[path]
            dset.resize(start + block.shape[0], axis=0)
            dset[start : start + block.shape[0]] = block
        else:
            if path in ("", "/"):
                obj = self._file
            else:
                obj = self._file[path] if path in self._file else self._file.require_group(path)
            for key, value in op[2].items():
                obj.attrs[key] = value
