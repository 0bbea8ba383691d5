"""The results file ``OUTDIR/CMD.h5``: atomic writer, storage layout, readers.

Layout
======
Root attributes: provenance (:data:`inins.io.provenance.PROVENANCE_KEYS`) and
``summary_json`` (the ``summary.json`` text). Every dataset carries ``units``,
``frame`` and ``description`` attributes; groups and datasets may carry more
attributes from the command (:attr:`CommandResult.attrs`).

Storage: datasets of more than :data:`LONG_ROWS` rows are chunked (about
:data:`CHUNK_BYTES` per chunk along the leading axis) and compressed with gzip
level 1, with the shuffle filter for floating-point data only (it helps
floats, not small integers). gzip is readable by every HDF5 reader (MATLAB,
HDFView, netCDF, h5py); LZF would be ~25 % faster but is h5py-only. Shorter
datasets are contiguous and uncompressed.

Attribute values
================
Numbers, booleans, strings and arrays (or lists of numbers or of strings) are
stored natively. A dict is flattened into dotted names
(``{"mount": {"tilt_rad": 1e-5}}`` -> attribute ``mount.tilt_rad``). Anything
else (None, lists of dicts, mixed lists) is stored as its JSON text.
"""

import contextlib
import json
import os
from pathlib import Path

import h5py
import numpy as np

from inins.exceptions import InputError, OutputError
from inins.io.atomic import AtomicFile
from inins.io.diskspace import FullDiskWatch, check_room, disk_full_error, is_disk_full
from inins.io.h5layout import (  # noqa: F401 (re-exported)
    CHUNK_BYTES,
    GZIP_LEVEL,
    LONG_ROWS,
    chunk_rows,
    encode_attrs,
    storage_options,
)
from inins.io.hdf5_sink import H5SeriesSink
from inins.io.provenance import PROVENANCE_KEYS

_abandoned = []
"""Files HDF5 failed to write (full disk), left open: closing them can crash HDF5. Their
temporary file is already removed; the space returns when the process ends."""


def _dataset_array(path, data) -> np.ndarray:
    arr = np.asarray(data)
    if arr.dtype.kind == "U" or (
        arr.dtype == object and all(isinstance(v, str) for v in arr.ravel())
    ):
        return arr.astype(h5py.string_dtype())
    if arr.dtype.kind not in "biufcS":
        raise TypeError(f"dataset {path!r}: cannot store data of dtype {arr.dtype}")
    return arr


class ResultsWriter:
    """Write an HDF5 results file under a temporary name.

    Parameters
    ----------
    target : str, Path or AtomicFile
        The final path (the writer commits on a clean exit from ``with``), or
        an :class:`~inins.io.atomic.AtomicFile` whose owner commits (the
        runner commits CMD.h5 together with the report and summary).

    Examples
    --------
    >>> with ResultsWriter(outdir / "simulate-table.h5") as w:  # doctest: +SKIP
    ...     w.set_attrs("", provenance)
    ...     w.write_result(result)
    """

    def __init__(self, target):
        self._owns = not isinstance(target, AtomicFile)
        self.atomic = AtomicFile(target) if self._owns else target
        self.file = None
        self._sinks = []
        self._watch = FullDiskWatch()

    def __enter__(self):
        self._watch = FullDiskWatch().__enter__()
        try:
            self.file = h5py.File(self.atomic.tmp, "w")
        except BaseException:
            self._watch.__exit__()
            raise
        return self

    def __exit__(self, exc_type, exc, tb):
        try:
            if exc_type is None:
                try:
                    self.close()
                except BaseException:
                    self.abort()
                    raise
                if self._owns:
                    self.atomic.commit()
            else:
                self.abort()
        finally:
            self._watch.__exit__()
        if exc is not None and is_disk_full(exc) and not isinstance(exc, OutputError):
            raise disk_full_error(self.atomic.path) from None
        return False

    def close(self) -> None:
        """Finish open sinks, flush and close the file (it stays under its temporary name).

        Raises
        ------
        OutputError
            The disk is full (checked before the final flush, since HDF5 reports a
            failed write only at flush or close).
        """
        for sink in self._sinks:
            sink.close()
        self._sinks.clear()
        if self.file is not None:
            if self._watch.full:
                raise disk_full_error(self.atomic.path)
            check_room(self.atomic.tmp, 0)
            try:
                self.file.flush()
            except (OSError, RuntimeError) as exc:
                if is_disk_full(exc):
                    raise disk_full_error(self.atomic.path) from None
                raise
            if self._watch.full:
                raise disk_full_error(self.atomic.path)
            self.file.close()
            self.file = None

    def abort(self) -> None:
        """Drop everything: stop sinks, close and remove the temporary file.

        The temporary file is emptied first, so that HDF5's closing flush finds room
        even on a full disk (it cannot be stopped from flushing, and a failed flush
        on close can crash it).
        """
        for sink in self._sinks:
            sink.abort()
        self._sinks.clear()
        if self.file is not None:
            with contextlib.suppress(OSError):
                os.truncate(self.atomic.tmp, 0)
            if self._watch.full:  # HDF5 has failed writes behind it: closing can crash
                _abandoned.append(self.file)
            else:
                with contextlib.suppress(Exception):
                    self.file.close()
            self.file = None
        self.atomic.discard()

    def sink(self, threaded: bool = False, max_pending: int = 4):
        """A :class:`~inins.results.SeriesSink` streaming into this file.

        See :class:`inins.io.hdf5_sink.H5SeriesSink`. Close it (or leave the
        writer's ``with``) before writing other datasets.
        """
        sink = H5SeriesSink(self.file, threaded=threaded, max_pending=max_pending)
        self._sinks.append(sink)
        return sink

    def set_attrs(self, path: str, attrs: dict) -> None:
        """Set attributes of a group or dataset (groups are created as needed)."""
        if path in ("", "/"):
            obj = self.file
        elif path in self.file:
            obj = self.file[path]
        else:
            obj = self.file.require_group(path)
        for key, value in encode_attrs(attrs).items():
            obj.attrs[key] = value

    def write_series(self, path: str, series) -> None:
        """Write one :class:`~inins.results.Series` with its unit/frame attributes."""
        if path in self.file:
            raise ValueError(f"dataset {path!r} is written twice")
        arr = _dataset_array(path, series.data)
        n_rows = arr.shape[0] if arr.ndim else None
        opts = storage_options(arr.shape[1:], arr.dtype, n_rows) if arr.ndim else {}
        if arr.dtype.kind in "OSU":
            opts.pop("shuffle", None)
        dset = self.file.create_dataset(path, data=arr, **opts)
        dset.attrs["units"] = series.units
        dset.attrs["frame"] = series.frame
        dset.attrs["description"] = series.description

    def write_result(self, result) -> None:
        """Write a :class:`~inins.results.CommandResult`'s datasets and attributes.

        Raises
        ------
        ValueError
            A dataset written twice, or a root attribute that would overwrite
            provenance.
        """
        for path, series in result.datasets.items():
            self.write_series(path, series)
        for path, attrs in result.attrs.items():
            if path in ("", "/"):
                clash = (set(PROVENANCE_KEYS) | {"summary_json"}) & set(encode_attrs(attrs))
                if clash:
                    raise ValueError(f"root attributes {sorted(clash)} are reserved")
            self.set_attrs(path, attrs)


def open_results(path):
    """Open a results file read-only.

    Returns
    -------
    h5py.File

    Raises
    ------
    InputError
        Missing file or not HDF5.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError("file not found", source=str(path))
    try:
        return h5py.File(path, "r")
    except OSError as exc:
        raise InputError(f"cannot read as HDF5 ({exc})", source=str(path)) from None


def read_datasets(path, group, names, what="an inins results file"):
    """The datasets ``names`` of ``group`` in a results file, as float arrays by name.

    Raises
    ------
    InputError
        Missing file, not HDF5, no such group (the file is not ``what``), or a
        dataset missing.
    """
    with open_results(path) as f:
        g = f.get(group)
        if not isinstance(g, h5py.Group):
            raise InputError(f"not {what}: no group {group}", source=str(path))
        missing = [name for name in names if name not in g]
        if missing:
            raise InputError(
                f"incomplete {group} group: missing {', '.join(missing)}",
                source=str(path),
                key=group,
            )
        return {name: np.asarray(g[name][()], dtype=float) for name in names}


def read_provenance(path) -> dict:
    """Root attributes of a results file (``summary_json`` excluded), as Python values."""
    with open_results(path) as f:
        return {k: _plain(v) for k, v in f.attrs.items() if k != "summary_json"}


def read_summary(path) -> dict:
    """The summary stored in a results file.

    Raises
    ------
    InputError
        Not an inins results file (no ``summary_json`` attribute).
    """
    with open_results(path) as f:
        text = f.attrs.get("summary_json")
    if text is None:
        raise InputError("not an inins results file (no summary_json attribute)", source=str(path))
    return json.loads(text)


def list_datasets(path) -> list[dict]:
    """Every dataset: ``path``, ``shape``, ``dtype``, ``units``, ``frame``, ``description``."""
    found = []

    def visit(name, obj):
        if isinstance(obj, h5py.Dataset):
            found.append(
                {
                    "path": name,
                    "shape": obj.shape,
                    "dtype": str(obj.dtype),
                    **{k: _plain(obj.attrs.get(k, "")) for k in ("units", "frame", "description")},
                }
            )

    with open_results(path) as f:
        f.visititems(visit)
    return found


def _plain(value):
    """An attribute as a Python value (bytes -> str, numpy -> list/scalar)."""
    if isinstance(value, bytes):
        return value.decode("utf-8", "replace")
    if isinstance(value, np.ndarray):
        return [_plain(v) for v in value.tolist()]
    if isinstance(value, np.generic):
        return value.item()
    return value
