"""Rate-table records: what calibrate-bias and align-ett read, from a file or a simulation.

The types are declared here, in the core, because the methods that read a record
(:mod:`inins.calibration`), the simulator that produces one (:mod:`inins.table`) and
the file layer that stores one (:mod:`inins.io.tabledata`) all use them and none of
them may import another.

:class:`TableRecord` is the base: metadata in memory, increments on demand.
:class:`MemoryRecord` keeps the increments as arrays (a simulation run in memory,
:meth:`MemoryRecord.from_chunks`); :class:`inins.io.tabledata.TableData` streams them
from a table-data HDF5 file. Sample k covers ``[t0 + k dt, t0 + (k + 1) dt]``.
"""

import enum
from dataclasses import dataclass, field

import numpy as np


class StepKind(enum.StrEnum):
    """What the table does during a step."""

    HOLD = "hold"
    ROTATE = "rotate"
    SPIN = "spin"


@dataclass(frozen=True)
class Step:
    """One step of the schedule; samples [start_index, stop_index) lie wholly inside it.

    Attributes
    ----------
    kind : StepKind
    label : str
        Position name given in the scenario or log (or found from the encoders).
    axis : int
        Moving gimbal (outer = 0), -1 for a hold.
    start_time, end_time : float
        s.
    start_index, stop_index : int
        IMU samples [start_index, stop_index).
    angles_start, angles_end : ndarray, shape (g,)
        Gimbal angles (rad), outer first.
    """

    kind: StepKind
    label: str
    axis: int
    start_time: float
    end_time: float
    start_index: int
    stop_index: int
    angles_start: np.ndarray
    angles_end: np.ndarray


@dataclass(frozen=True)
class Truth:
    """Simulated truth at the truth rate (rows stacked on the leading axis).

    Attributes
    ----------
    time : ndarray, shape (m,)
        s.
    quat_nb : ndarray, shape (m, 4)
        True attitude, scalar first.
    table_angles : ndarray, shape (m, g)
        True gimbal angles (rad), outer first.
    mount_rotvec : ndarray, shape (m, 3)
        Mount rotation vector (rad), b frame.
    gyro_bias, accel_bias : ndarray, shape (m, 3)
        Total sensor biases, means over each truth interval (rad/s, m/s^2).
    attrs : dict
        Sensor error parameters in SI (``sensor.<name>``) and ``mat_tb0``; empty in
        the rows of a simulation chunk.
    """

    time: np.ndarray
    quat_nb: np.ndarray
    table_angles: np.ndarray
    mount_rotvec: np.ndarray
    gyro_bias: np.ndarray
    accel_bias: np.ndarray
    attrs: dict = field(default_factory=dict)


TRUTH_SERIES = ("time", "quat_nb", "table_angles", "mount_rotvec", "gyro_bias", "accel_bias")
"""The row fields of :class:`Truth`, in order (the ``/truth`` datasets of a table-data file)."""


@dataclass(frozen=True)
class TableChunk:
    """A stretch of a simulated or imported record: increments (SI, b frame) of samples
    ``start .. start + len(dtheta)``, and the truth and encoder rows that fall in it."""

    start: int
    dtheta: np.ndarray
    dv: np.ndarray
    encoder_time: np.ndarray
    encoder: np.ndarray
    truth: Truth | None = None


@dataclass(frozen=True)
class TableRecord:
    """A rate-table record: metadata in memory, increments in SI on demand.

    Attributes
    ----------
    t0, dt : float
        Start of the first sample interval and the sample interval (s).
    lla : ndarray, shape (3,)
        Latitude, longitude (rad), height (m) of the table.
    gimbals : tuple of str
        Gimbal names, outer first.
    axes : ndarray, shape (g, 3)
        Unit gimbal axes, each in its parent frame.
    mat_n_base : ndarray, shape (3, 3)
        Table base -> NED.
    steps : tuple of Step
    encoder_time : ndarray, shape (m,)
    encoder : ndarray, shape (m, g)
        Encoder readings (s, rad).
    truth : Truth or None
        Simulation only.
    source : str
        File name or ``"simulation"``, for messages.
    """

    t0: float
    dt: float
    lla: np.ndarray
    gimbals: tuple
    axes: np.ndarray
    mat_n_base: np.ndarray
    steps: tuple
    encoder_time: np.ndarray
    encoder: np.ndarray
    truth: Truth | None
    source: str

    @property
    def n_samples(self) -> int:
        """Number of IMU samples."""
        raise NotImplementedError

    def imu(self, start=0, stop=None):
        """Increments of samples [start, stop): dtheta (rad), dv (m/s), each (k, 3)."""
        raise NotImplementedError

    def imu_chunks(self, start=0, stop=None, chunk=1 << 18):
        """Yield ``(k0, dtheta, dv)`` over samples [start, stop) in chunks."""
        raise NotImplementedError

    def sample_time(self, index):
        """End time (s) of sample ``index``."""
        return self.t0 + (np.asarray(index) + 1) * self.dt


@dataclass(frozen=True)
class MemoryRecord(TableRecord):
    """A :class:`TableRecord` whose increments are arrays in memory."""

    dtheta: np.ndarray = field(default=None, repr=False)
    dv: np.ndarray = field(default=None, repr=False)

    @classmethod
    def from_chunks(cls, chunks, truth_attrs=None, **meta):
        """Concatenate :class:`TableChunk` s into a record.

        Parameters
        ----------
        chunks : iterable of TableChunk
            In order, starting at sample 0.
        truth_attrs : dict, optional
            :attr:`Truth.attrs` of the record (the chunks' truth rows have none).
        **meta
            The :class:`TableRecord` fields other than the encoder and truth series.
        """
        parts = list(chunks)

        def cat(get):
            return np.concatenate([get(c) for c in parts])

        truth = None
        if parts and parts[0].truth is not None:
            truth = Truth(
                *(cat(lambda c, n=name: getattr(c.truth, n)) for name in TRUTH_SERIES),
                attrs=dict(truth_attrs or {}),
            )
        return cls(
            **meta,
            encoder_time=cat(lambda c: c.encoder_time),
            encoder=cat(lambda c: c.encoder),
            truth=truth,
            dtheta=cat(lambda c: c.dtheta),
            dv=cat(lambda c: c.dv),
        )

    @property
    def n_samples(self):
        """Number of IMU samples."""
        return self.dtheta.shape[0]

    def imu(self, start=0, stop=None):
        """Increments of samples [start, stop): dtheta (rad), dv (m/s), each (k, 3)."""
        return self.dtheta[start:stop], self.dv[start:stop]

    def imu_chunks(self, start=0, stop=None, chunk=1 << 18):
        """Yield ``(k0, dtheta, dv)`` over samples [start, stop) in chunks."""
        stop = self.n_samples if stop is None else stop
        for k0 in range(start, stop, chunk):
            k1 = min(stop, k0 + chunk)
            yield k0, self.dtheta[k0:k1], self.dv[k0:k1]
