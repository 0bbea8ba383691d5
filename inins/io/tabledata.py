"""The table-data HDF5 layout: written by simulate-table and the log importer, read by
calibrate-bias and align-ett.

Layout (every dataset carries ``units``, ``frame`` and ``description`` attributes)::

    /                     provenance attributes (inins.io.hdf5)
    /site                 attrs: lat_rad, lon_rad, height_m
    /imu                  attrs: t0_s (start of the first sample interval), dt_s,
                          sample_rate_hz. Sample k covers [t0 + k dt, t0 + (k+1) dt].
    /imu/dtheta  (n, 3)   gyro increments, b frame: float64 rad, or int32 pulse
                          counts (units "count") with attr pulse_weight (3,) in rad
    /imu/dv      (n, 3)   accelerometer increments, b frame: float64 m/s, or int32
                          counts with attr pulse_weight (3,) in m/s
    /steps/kind  (s,)     hold | rotate | spin
    /steps/label (s,)     position name given in the scenario or log
    /steps/axis  (s,)     moving gimbal (outer = 0), -1 for a hold
    /steps/start_time, end_time (s,)    s
    /steps/start_index, stop_index (s,) IMU samples [start_index, stop_index)
                                        lie wholly inside the step
    /steps/angles_start, angles_end (s, g)  gimbal angles (rad), outer first
    /table                attrs: gimbals (names, outer first), axes (g, 3) unit
                          gimbal axes each in its parent frame, mat_n_base (3, 3)
                          table base to NED (base azimuth and tilt)
    /table/time  (m,)     s, encoder reading times
    /table/encoder (m, g) rad, encoder readings
    /import, /check       import-log only: import settings (attrs) and the stationary
                          check of each hold (inins.io.logcheck)
    /truth/...            simulation only: time (m,), quat_nb (m, 4),
                          table_angles (m, g), mount_rotvec (m, 3),
                          gyro_bias (m, 3), accel_bias (m, 3); attrs: sensor
                          error parameters in SI and mat_tb0
"""

from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import h5py
import numpy as np

from inins.exceptions import InputError
from inins.table.record import Step, Truth

CHUNK_SAMPLES = 1 << 18


@dataclass(frozen=True)
class TableData:
    """A table-data file: metadata in memory, IMU increments read in chunks.

    Implements :class:`inins.table.record.TableRecord`.
    """

    path: Path
    t0: float
    dt: float
    n_samples: int
    lla: np.ndarray
    gimbals: tuple
    axes: np.ndarray
    mat_n_base: np.ndarray
    steps: tuple
    encoder_time: np.ndarray
    encoder: np.ndarray
    truth: Truth | None

    @property
    def source(self):
        """File name, for messages."""
        return str(self.path)

    def imu(self, start=0, stop=None):
        """Increments of samples [start, stop) in SI: dtheta (rad), dv (m/s), each (k, 3)."""
        stop = self.n_samples if stop is None else stop
        with h5py.File(self.path, "r") as f:
            return _read_si(f["imu/dtheta"], start, stop), _read_si(f["imu/dv"], start, stop)

    def imu_chunks(self, start=0, stop=None, chunk=CHUNK_SAMPLES):
        """Yield ``(k0, dtheta, dv)`` over samples [start, stop) in chunks, SI units.

        The next chunk is read and decompressed on a second thread while the caller
        works on the current one (the numba kernels release the GIL).
        """
        stop = self.n_samples if stop is None else stop
        starts = range(start, stop, chunk)
        with h5py.File(self.path, "r") as f, ThreadPoolExecutor(1) as pool:

            def read(k0):
                k1 = min(stop, k0 + chunk)
                return k0, _read_si(f["imu/dtheta"], k0, k1), _read_si(f["imu/dv"], k0, k1)

            pending = pool.submit(read, starts[0]) if starts else None
            for k0 in starts[1:]:
                current, pending = pending.result(), pool.submit(read, k0)
                yield current
            if pending is not None:
                yield pending.result()

    def sample_time(self, index):
        """End time (s) of sample ``index``."""
        return self.t0 + (np.asarray(index) + 1) * self.dt


def _read_si(dset, k0, k1):
    rows = dset[k0:k1]
    if "pulse_weight" in dset.attrs:
        return rows.astype(np.float64) * np.asarray(dset.attrs["pulse_weight"], dtype=float)
    return rows.astype(np.float64, copy=False)


def _require(f, path, name):
    if path not in f:
        raise InputError(f"not a table-data file: missing {path}", source=name, key=path)
    return f[path]


def _text(values):
    return tuple(v.decode() if isinstance(v, bytes) else str(v) for v in values)


def _steps(f):
    g = f["steps"]
    kinds, labels = _text(g["kind"][()]), _text(g["label"][()])
    cols = {k: g[k][()] for k in ("axis", "start_time", "end_time", "start_index",
                                  "stop_index", "angles_start", "angles_end")}
    return tuple(
        Step(kinds[i], labels[i], int(cols["axis"][i]), float(cols["start_time"][i]),
             float(cols["end_time"][i]), int(cols["start_index"][i]),
             int(cols["stop_index"][i]), cols["angles_start"][i], cols["angles_end"][i])
        for i in range(len(kinds)))


def _truth(f):
    if "truth" not in f:
        return None
    g = f["truth"]
    return Truth(*(g[k][()] for k in ("time", "quat_nb", "table_angles", "mount_rotvec",
                                      "gyro_bias", "accel_bias")), attrs=dict(g.attrs))


def read_table_data(path):
    """Open a table-data file and read everything but the IMU increments.

    Raises
    ------
    InputError
        The file is missing, not HDF5, or lacks part of the layout.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError("file not found", source=str(path))
    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        raise InputError(f"cannot read as HDF5 ({exc})", source=str(path)) from None
    with f:
        name = str(path)
        imu = _require(f, "imu", name)
        n = _require(f, "imu/dtheta", name).shape[0]
        if _require(f, "imu/dv", name).shape[0] != n:
            raise InputError("imu/dtheta and imu/dv differ in length", source=name, key="imu")
        site = _require(f, "site", name).attrs
        table = _require(f, "table", name)
        _require(f, "steps", name)
        return TableData(
            path=path, t0=float(imu.attrs["t0_s"]), dt=float(imu.attrs["dt_s"]),
            n_samples=n,
            lla=np.array([site["lat_rad"], site["lon_rad"], site["height_m"]], dtype=float),
            gimbals=_text(table.attrs["gimbals"]),
            axes=np.asarray(table.attrs["axes"], dtype=float).reshape(-1, 3),
            mat_n_base=np.asarray(table.attrs["mat_n_base"], dtype=float).reshape(3, 3),
            steps=_steps(f),
            encoder_time=table["time"][()], encoder=table["encoder"][()], truth=_truth(f))
