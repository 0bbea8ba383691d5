"""simulate-table: an IMU on a rate table running a motion program (spec §3, 000 §2).

The simulation yields typed chunks (:class:`inins.core.records.TableChunk`):
exact increments from the table kinematics (:mod:`inins.table.kinematics`),
then the disturbances of 000 §2 (accelerometer bias change after a rotation,
chamber temperature), then the sensor error model
(:func:`inins.core.imu.apply_errors`). Memory is bounded by the chunk size,
whatever the length of the run.

``inins simulate-table`` writes them in the table-data layout
(:mod:`inins.io.tabledata`); calibrate-bias and align-ett may keep them in memory
(:meth:`inins.core.records.MemoryRecord.from_chunks`).
"""

from dataclasses import dataclass

import numpy as np

from inins.core import imu, rotation, trajectory
from inins.core.records import Step, StepKind, TableChunk, Truth
from inins.table.kinematics import TableTrajectory

CHUNK_SAMPLES = 1 << 18


@dataclass(frozen=True)
class AfterRotationBias:
    """Accelerometer bias change after each table rotation (000 §2, Fig. 2).

    Every rotate or spin step adds ``step`` (m/s^2, b frame), reached
    exponentially with time constant ``settle_time`` (s; 0 = at once) from the
    end of the rotation; the changes of successive rotations add up.
    """

    step: np.ndarray
    settle_time: float = 0.0

    def bias(self, time, rotation_ends):
        """Bias change (m/s^2), shape (n, 3), at ``time`` (s, increasing)."""
        time = np.asarray(time, dtype=float)
        ends = np.asarray(rotation_ends, dtype=float)
        if time.size == 0:
            return np.zeros((0, 3))
        # a change is complete (to the last bit) 40 time constants after its rotation
        settled = ends <= time[0] - 40.0 * self.settle_time
        total = np.tile(np.count_nonzero(settled) * self.step, (time.size, 1))
        for t_end in ends[~settled & (ends < time[-1])]:
            age = time - t_end
            if self.settle_time > 0.0:
                weight = -np.expm1(-np.clip(age, 0.0, None) / self.settle_time)
            else:
                weight = (age > 0.0).astype(float)
            total += weight[:, None] * self.step
        return total


@dataclass(frozen=True)
class Chamber:
    """Chamber temperature offset from the sensors' reference (K), piecewise linear in time."""

    time: np.ndarray
    delta: np.ndarray

    def at(self, time):
        """Temperature offset (K) at ``time`` (s)."""
        return np.interp(time, self.time, self.delta)


@dataclass(frozen=True)
class TableSimulation:
    """Everything simulate-table needs, in SI.

    Attributes
    ----------
    trajectory : inins.table.kinematics.TableTrajectory
    sensor : inins.core.imu.SensorErrors
    sample_rate : float
        IMU sample rate (Hz).
    gimbal_names : tuple of str
        Outer gimbal first.
    encoder_noise : float
        White noise of the encoder readings (rad, 1 sigma).
    truth_decimation : int
        Truth and encoder readings are kept every ``truth_decimation`` samples.
    after_rotation : AfterRotationBias or None
    chamber : Chamber or None
    """

    trajectory: TableTrajectory
    sensor: imu.SensorErrors
    sample_rate: float
    gimbal_names: tuple
    encoder_noise: float = 0.0
    truth_decimation: int = 10
    after_rotation: AfterRotationBias | None = None
    chamber: Chamber | None = None

    @property
    def dt(self):
        """Sample interval (s)."""
        return 1.0 / self.sample_rate

    @property
    def n_samples(self):
        """Whole samples in the program, rounded down to a multiple of the decimation."""
        n = int(np.floor(self.trajectory.program.duration * self.sample_rate + 1e-9))
        return n - n % self.truth_decimation

    def rotation_ends(self):
        """End times (s) of the rotate and spin steps."""
        return [s.end for s in self.trajectory.program.steps if s.kind != "hold"]


def _chunk(sim, k0, k1, rng, encoder_rng, err_state):
    """Measured increments, decimated truth and encoder readings of samples k0..k1-1."""
    dt, d = sim.dt, sim.truth_decimation
    edges = dt * np.arange(k0, k1 + 1)
    ideal = trajectory.ideal_increments(sim.trajectory, edges, nodes=1, chunk=edges.size)
    mid = edges[:-1] + 0.5 * dt
    temp = sim.chamber.at(mid) if sim.chamber is not None else None
    extra = (
        sim.after_rotation.bias(mid, sim.rotation_ends())
        if sim.after_rotation is not None
        else None
    )
    dtheta, dv, err_state, bias = imu.apply_errors(
        ideal[0],
        ideal[1],
        dt,
        sim.sensor,
        rng,
        err_state,
        temperature_delta=temp,
        accel_bias_extra=extra,
        truth_every=d,
    )
    t_truth = edges[d::d]
    mat_nb, _, _ = sim.trajectory.state(t_truth)
    angles = sim.trajectory.table_angles(t_truth)
    truth = Truth(
        t_truth,
        rotation.quat_from_mat(mat_nb),
        angles,
        sim.trajectory.mount_rotvec(t_truth),
        bias.gyro,
        bias.accel,
    )
    encoder = angles + sim.encoder_noise * encoder_rng.standard_normal(angles.shape)
    return TableChunk(k0, dtheta, dv, t_truth, encoder, truth), err_state


def simulation_chunks(sim, rng, progress=None):
    """Yield the simulation as :class:`inins.core.records.TableChunk` s, in order.

    Parameters
    ----------
    sim : TableSimulation
    rng : numpy.random.Generator
    progress : callable, optional
        Called as ``progress(samples_done, samples_total)`` after each chunk.
    """
    n, d = sim.n_samples, sim.truth_decimation
    if n == 0:
        raise ValueError("the motion program is shorter than one truth interval")
    chunk = max(d, CHUNK_SAMPLES - CHUNK_SAMPLES % d)
    encoder_rng = rng.spawn(1)[0]  # own stream: results do not depend on the chunk size
    err_state = None
    for k0 in range(0, n, chunk):
        part, err_state = _chunk(sim, k0, min(n, k0 + chunk), rng, encoder_rng, err_state)
        yield part
        if progress is not None:
            progress(k0 + part.dtheta.shape[0], n)


def schedule(sim):
    """The step schedule: which samples belong to which step (tuple of
    :class:`inins.core.records.Step`)."""
    dt, n = sim.dt, sim.n_samples

    def first(t):  # first sample whose interval starts at or after t
        return min(n, int(np.ceil(t / dt - 1e-9)))

    def stop(t):  # one past the last sample whose interval ends by t
        return min(n, int(np.floor(t / dt + 1e-9)))

    return tuple(
        Step(
            StepKind(s.kind),
            s.label,
            s.axis,
            s.start,
            s.end,
            first(s.start),
            stop(s.end),
            np.asarray(s.angles_start),
            np.asarray(s.angles_end),
        )
        for s in sim.trajectory.program.steps
    )
