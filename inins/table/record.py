"""A rate-table record: what calibrate-bias and align-ett read, from a file or a simulation.

:class:`TableRecord` is the protocol. :class:`inins.io.tabledata.TableData` implements
it on a table-data HDF5 file (increments streamed from disk);
:func:`memory_record` on a simulation kept in a :class:`inins.results.MemorySink`.
Sample k covers ``[t0 + k dt, t0 + (k + 1) dt]``.
"""

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from inins.core import pulses


@dataclass(frozen=True)
class Step:
    """One step of the schedule; samples [start_index, stop_index) lie wholly inside it."""

    kind: str
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
    """Simulated truth at the truth rate (see :mod:`inins.io.tabledata`)."""

    time: np.ndarray
    quat_nb: np.ndarray
    table_angles: np.ndarray
    mount_rotvec: np.ndarray
    gyro_bias: np.ndarray
    accel_bias: np.ndarray
    attrs: dict


class TableRecord(Protocol):
    """Metadata in memory; increments on demand, in SI (rad, m/s)."""

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
    source: str

    def imu(self, start=0, stop=None): ...

    def imu_chunks(self, start=0, stop=None, chunk=...): ...


@dataclass(frozen=True)
class MemoryRecord:
    """A :class:`TableRecord` whose increments are arrays in memory."""

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
    dtheta: np.ndarray
    dv: np.ndarray
    source: str = "simulation"

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


def memory_record(sim, sink, schedule):
    """A :class:`MemoryRecord` of a simulation streamed into a MemorySink.

    Parameters
    ----------
    sim : inins.table.simulate.TableSimulation
    sink : inins.results.MemorySink
        Filled by :func:`inins.table.simulate.simulate_table`.
    schedule : dict
        :func:`inins.table.simulate.step_schedule` of ``sim``.
    """
    s = sim.sensor

    def increments(name, weight):
        rows = sink[f"imu/{name}"]
        return pulses.increments_from_counts(rows, weight) if rows.dtype.kind == "i" else rows

    col = {k.split("/")[1]: v.data for k, v in schedule.items()}
    steps = tuple(
        Step(col["kind"][i].decode(), col["label"][i].decode(), int(col["axis"][i]),
             float(col["start_time"][i]), float(col["end_time"][i]),
             int(col["start_index"][i]), int(col["stop_index"][i]),
             col["angles_start"][i], col["angles_end"][i])
        for i in range(len(col["kind"])))
    truth = Truth(sink["truth/time"], sink["truth/quat_nb"], sink["truth/table_angles"],
                  sink["truth/mount_rotvec"], sink["truth/gyro_bias"],
                  sink["truth/accel_bias"],
                  {"mat_tb0": sim.trajectory.mat_tb0,
                   **{f"sensor.{k}": np.asarray(v, float) for k, v in vars(s).items()}})
    traj = sim.trajectory
    return MemoryRecord(
        t0=0.0, dt=sim.dt, lla=np.asarray(traj.lla, float), gimbals=tuple(sim.gimbal_names),
        axes=traj.axes, mat_n_base=traj.mat_n_base, steps=steps,
        encoder_time=sink["table/time"], encoder=sink["table/encoder"], truth=truth,
        dtheta=increments("dtheta", s.gyro_pulse_weight),
        dv=increments("dv", s.accel_pulse_weight))
