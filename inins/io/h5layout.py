"""Storage layout of HDF5 series and attribute encoding, shared by the results writer
(:mod:`inins.io.hdf5`) and the streaming sink (:mod:`inins.io.hdf5_sink`).

Datasets of more than :data:`LONG_ROWS` rows are chunked (about :data:`CHUNK_BYTES`
per chunk along the leading axis) and compressed with gzip level 1, with the shuffle
filter for floating-point data only; shorter datasets are contiguous. Attribute dicts
are flattened to dotted names; values HDF5 cannot hold are stored as JSON text.
"""

import json

import h5py
import numpy as np

LONG_ROWS = 10_000
"""Datasets with more rows than this are chunked and compressed."""
CHUNK_BYTES = 1 << 20
"""Target chunk size in bytes."""
GZIP_LEVEL = 1


def chunk_rows(row_shape, dtype) -> int:
    """Rows per chunk for about :data:`CHUNK_BYTES` per chunk (at least 1)."""
    row_bytes = int(np.prod(row_shape, dtype=np.int64)) * np.dtype(dtype).itemsize
    return max(1, CHUNK_BYTES // max(row_bytes, 1))


def storage_options(row_shape, dtype, n_rows: int | None) -> dict:
    """``h5py.Group.create_dataset`` keywords for a series of ``n_rows`` rows.

    Parameters
    ----------
    row_shape : tuple
        Shape of one row (``()`` for a scalar series).
    dtype : numpy dtype
    n_rows : int or None
        Number of rows; None if unknown (a stream: chunked and compressed).

    Returns
    -------
    dict
        Empty (contiguous) for short series; else ``chunks``, ``compression``,
        ``compression_opts`` and ``shuffle``.
    """
    if n_rows is not None and n_rows <= LONG_ROWS:
        return {}
    rows = chunk_rows(row_shape, dtype)
    if n_rows is not None:
        rows = min(rows, n_rows)
    return {
        "chunks": (rows, *row_shape),
        "compression": "gzip",
        "compression_opts": GZIP_LEVEL,
        "shuffle": np.dtype(dtype).kind == "f",
    }


def encode_attrs(attrs: dict, prefix: str = "") -> dict:
    """Attribute values HDF5 can hold, dicts flattened to dotted names."""
    out = {}
    for key, value in attrs.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            out.update(encode_attrs(value, prefix=f"{name}."))
        else:
            out[name] = _attr_value(value)
    return out


def _attr_value(value):
    if isinstance(value, str):
        return str(value)  # an enum.StrEnum member becomes its plain text
    if isinstance(value, bool | int | float | np.generic):
        return value
    if isinstance(value, list | tuple) and all(isinstance(v, str) for v in value):
        return np.array(list(value), dtype=h5py.string_dtype())
    if isinstance(value, list | tuple | np.ndarray):
        try:
            arr = np.asarray(value)
        except ValueError:  # ragged
            arr = np.empty(0, dtype=object)
        if arr.dtype.kind in "biufc":
            return arr
        if arr.dtype.kind == "U":
            return arr.astype(h5py.string_dtype())
    return json.dumps(value, default=_json_default)


def _json_default(value):
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    raise TypeError(f"attribute value of type {type(value).__name__} cannot be stored")
