"""Files of a sweep folder: the append-only journal, the flat table (CSV and HDF5),
the manifest.

``journal.jsonl``
    One JSON line per finished point, appended and flushed as each point ends, so
    a killed sweep (Ctrl-C, kill -9, a lost worker) keeps every finished point. A
    last line cut short by a kill is ignored when read.
``sweep.csv``, ``sweep.h5``
    The table, rebuilt from the journal and written under temporary names then
    renamed (:mod:`inins.io.atomic`): never half-written.
``sweep.json``
    What the folder holds (command, base scenario fingerprint), so a rerun knows
    whether it resumes the same sweep.
"""

import contextlib
import csv
import io
import json
import math
import os
from pathlib import Path

import numpy as np

from inins.exceptions import InputError
from inins.io.atomic import AtomicFile, write_text_atomic

JOURNAL = "journal.jsonl"
MANIFEST = "sweep.json"
TABLE_CSV = "sweep.csv"
TABLE_H5 = "sweep.h5"


def read_journal(outdir) -> dict:
    """Finished points of the journal, ``{point key: record}`` (the last record of a
    key wins; a cut-off or garbled line is skipped)."""
    path = Path(outdir) / JOURNAL
    records = {}
    if not path.is_file():
        return records
    with path.open("r", encoding="utf-8") as handle:
        for line in handle:
            if not line.endswith("\n"):
                break  # cut short by a kill
            try:
                record = json.loads(line)
            except json.JSONDecodeError:
                continue
            if isinstance(record, dict) and "key" in record:
                records[record["key"]] = record
    return records


class Journal:
    """Append-only record of finished points (a context manager).

    Each record is one ``write`` of a whole line; a write that fails (a full disk)
    is cut back off the file, so the journal holds whole records only and a rerun
    resumes from them.

    Parameters
    ----------
    outdir : Path
        The sweep folder; the journal is ``outdir/journal.jsonl``.
    """

    def __init__(self, outdir):
        self.path = Path(outdir) / JOURNAL
        self._fd = None

    def __enter__(self):
        self._repair()
        self._fd = os.open(self.path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o666)
        return self

    def __exit__(self, exc_type, exc, tb):
        os.close(self._fd)

    def _repair(self) -> None:
        """Cut a partial last line (a kill mid-write) so the next record starts clean."""
        if not self.path.is_file():
            return
        data = self.path.read_bytes()
        if data and not data.endswith(b"\n"):
            with self.path.open("r+b") as handle:
                handle.truncate(data.rfind(b"\n") + 1)

    def append(self, record: dict) -> None:
        """Write one record to the OS (survives a kill of this process); on a failed
        write the file is cut back to its last whole record and
        :class:`~inins.exceptions.OutputError` raised."""
        from inins.exceptions import OutputError
        from inins.io.diskspace import device_of, is_disk_full

        data = memoryview((json.dumps(record, allow_nan=False) + "\n").encode("utf-8"))
        size = os.fstat(self._fd).st_size
        try:
            while data:
                data = data[os.write(self._fd, data) :]
        except OSError as exc:
            with contextlib.suppress(OSError):
                os.ftruncate(self._fd, size)
            reason = (
                f"no space left on {device_of(self.path)}"
                if is_disk_full(exc)
                else (exc.strerror or str(exc))
            )
            raise OutputError(
                f"{reason} writing the sweep journal: the sweep stopped; the points "
                "finished so far are kept, run the same command again to resume",
                source=str(self.path),
            ) from None


def read_manifest(outdir) -> dict | None:
    """The manifest of a sweep folder, or None if there is none."""
    path = Path(outdir) / MANIFEST
    if not path.is_file():
        return None
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError) as exc:
        raise InputError(f"unreadable sweep manifest ({exc})", source=str(path)) from None


def write_manifest(outdir, manifest: dict) -> None:
    """Write the manifest atomically."""
    write_text_atomic(Path(outdir) / MANIFEST, json.dumps(manifest, indent=2) + "\n")


def reset(outdir) -> None:
    """Forget a previous sweep in ``outdir`` (journal, manifest and table)."""
    for name in (JOURNAL, MANIFEST, TABLE_CSV, TABLE_H5):
        with _ignore_missing():
            os.remove(Path(outdir) / name)


class _ignore_missing:
    def __enter__(self):
        return self

    def __exit__(self, exc_type, exc, tb):
        return exc_type is FileNotFoundError


def _cell(value) -> str:
    """CSV text of one cell: floats in shortest round-trip form, empty for missing."""
    if value is None:
        return ""
    if isinstance(value, bool | np.bool_):
        return "true" if value else "false"
    if isinstance(value, float | np.floating):
        return "" if math.isnan(value) else repr(float(value))
    return str(value)


def write_table_csv(path, columns: dict) -> None:
    """Write ``{column name: sequence}`` as CSV (a header, one row per point), atomically."""
    names = list(columns)
    rows = zip(*(columns[n] for n in names), strict=True) if names else []
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(names)
    for row in rows:
        writer.writerow([_cell(v) for v in row])
    write_text_atomic(path, buffer.getvalue())


def write_table_h5(path, groups: dict, attrs: dict) -> None:
    """Write the table as HDF5, atomically: ``groups[group][name]`` is a 1-D column
    (float64, int64, bool or text) stored as ``/group/name``; ``attrs[path]`` are
    attributes of a group or dataset (``""`` for the root)."""
    import h5py

    with AtomicFile(path) as target:
        with h5py.File(target.tmp, "w") as h5:
            for group, columns in groups.items():
                node = h5.require_group(group)
                for name, values in columns.items():
                    node.create_dataset(name, data=_h5_array(values))
            for where, values in attrs.items():
                node = h5[where] if where else h5
                for key, value in values.items():
                    node.attrs[key] = value


def _h5_array(values) -> np.ndarray:
    array = np.asarray(values)
    if array.dtype.kind in "fiub":
        return array
    import h5py

    return np.array([str(v) for v in values], dtype=h5py.string_dtype())


def read_table_h5(path) -> dict:
    """The table of ``sweep.h5`` as ``{"group/name": ndarray}`` (text as str)."""
    import h5py

    out = {}
    with h5py.File(path, "r") as h5:

        def visit(name, node):
            if isinstance(node, h5py.Dataset):
                data = node[()]
                if node.dtype.kind == "O":
                    data = np.array([v.decode() if isinstance(v, bytes) else v for v in data])
                out[name] = data

        h5.visititems(visit)
    return out
