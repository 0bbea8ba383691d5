"""simulate-table: an IMU on a rate table running a motion program (spec §3, 000 §2).

The simulation streams chunk by chunk into a :class:`inins.results.SeriesSink`:
exact increments from the table kinematics (:mod:`inins.table.kinematics`),
then the disturbances of 000 §2 (accelerometer bias change after a rotation,
chamber temperature), then the sensor error model
(:func:`inins.core.imu.apply_errors`). Memory is bounded by the chunk size,
whatever the length of the run.

The datasets written are the table-data layout documented in
:mod:`inins.io.tabledata`.
"""

from dataclasses import dataclass

import numpy as np

from inins.core import imu, pulses, rotation, trajectory
from inins.core.units import DEG_RTH, DPH, PPM, UG, UG_RTHZ
from inins.io.report import format_table
from inins.results import CommandResult, Series

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

    trajectory: object
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


def _declare(sink, sim):
    n, d = sim.n_samples, sim.truth_decimation
    m = n // d
    n_g = len(sim.gimbal_names)
    s = sim.sensor
    quantized = (np.any(s.gyro_pulse_weight > 0), np.any(s.accel_pulse_weight > 0))
    for name, q, unit, weights in (("dtheta", quantized[0], "rad", s.gyro_pulse_weight),
                                   ("dv", quantized[1], "m/s", s.accel_pulse_weight)):
        attrs = {"pulse_weight": weights} if q else None
        what = "pulse counts" if q else "increments"
        sink.create(f"imu/{name}", (3,), np.int32 if q else np.float64,
                    "count" if q else unit, "b", f"IMU {name} {what} per sample",
                    expected_rows=n, attrs=attrs)
    truth = (("truth/time", (), "s", "", "time of the truth samples"),
             ("truth/quat_nb", (4,), "1", "nb", "true attitude quaternion, scalar first"),
             ("truth/table_angles", (n_g,), "rad", "t", "true gimbal angles, outer first"),
             ("truth/mount_rotvec", (3,), "rad", "b", "mount rotation vector"),
             ("truth/gyro_bias", (3,), "rad/s", "b", "total gyro bias, mean over the interval"),
             ("truth/accel_bias", (3,), "m/s^2", "b", "total accel bias, mean over the interval"),
             ("table/time", (), "s", "", "time of the encoder readings"),
             ("table/encoder", (n_g,), "rad", "t", "encoder readings, outer gimbal first"))
    for path, row, unit, frame, text in truth:
        sink.create(path, row, np.float64, unit, frame, text, expected_rows=m)
    return quantized


def _chunk(sim, k0, k1, rng, encoder_rng, err_state):
    """Measured increments and decimated truth of samples k0..k1-1."""
    dt, d = sim.dt, sim.truth_decimation
    edges = dt * np.arange(k0, k1 + 1)
    ideal = trajectory.ideal_increments(sim.trajectory, edges, nodes=1, chunk=edges.size)
    mid = edges[:-1] + 0.5 * dt
    temp = sim.chamber.at(mid) if sim.chamber is not None else None
    extra = (sim.after_rotation.bias(mid, sim.rotation_ends())
             if sim.after_rotation is not None else None)
    dtheta, dv, err_state, bias = imu.apply_errors(
        ideal[0], ideal[1], dt, sim.sensor, rng, err_state,
        temperature_delta=temp, accel_bias_extra=extra, truth_every=d)
    t_truth = edges[d::d]
    mat_nb, _, _ = sim.trajectory.state(t_truth)
    angles = sim.trajectory.table_angles(t_truth)
    truth = {
        "truth/time": t_truth,
        "truth/quat_nb": rotation.quat_from_mat(mat_nb),
        "truth/table_angles": angles,
        "truth/mount_rotvec": sim.trajectory.mount_rotvec(t_truth),
        "truth/gyro_bias": bias.gyro,
        "truth/accel_bias": bias.accel,
        "table/time": t_truth,
        "table/encoder": angles + sim.encoder_noise * encoder_rng.standard_normal(angles.shape),
    }
    return dtheta, dv, truth, err_state


def simulation_chunks(sim, rng):
    """Yield ``(k0, dtheta, dv, truth)`` chunk by chunk: measured increments (SI) of
    samples k0.. and the truth rows (dict of arrays) falling in that chunk."""
    n, d = sim.n_samples, sim.truth_decimation
    if n == 0:
        raise ValueError("the motion program is shorter than one truth interval")
    chunk = max(d, CHUNK_SAMPLES - CHUNK_SAMPLES % d)
    encoder_rng = rng.spawn(1)[0]  # own stream: results do not depend on the chunk size
    err_state = None
    for k0 in range(0, n, chunk):
        dtheta, dv, truth, err_state = _chunk(sim, k0, min(n, k0 + chunk), rng, encoder_rng,
                                              err_state)
        yield k0, dtheta, dv, truth


def simulate_table(sim, rng, sink, progress=None):
    """Run the simulation and stream the table-data layout into ``sink``.

    Parameters
    ----------
    sim : TableSimulation
    rng : numpy.random.Generator
    sink : inins.results.SeriesSink
    progress : callable, optional
        Called as ``progress(samples_done, samples_total)`` after each chunk.
    """
    quantized = _declare(sink, sim)
    s = sim.sensor
    for k0, dtheta, dv, truth in simulation_chunks(sim, rng):
        sink.append("imu/dtheta", pulses.counts_from_increments(dtheta, s.gyro_pulse_weight)
                    if quantized[0] else dtheta)
        sink.append("imu/dv", pulses.counts_from_increments(dv, s.accel_pulse_weight)
                    if quantized[1] else dv)
        for path, rows in truth.items():
            sink.append(path, rows)
        if progress is not None:
            progress(k0 + dtheta.shape[0], sim.n_samples)


def step_schedule(sim):
    """The step schedule as datasets: which samples belong to which step."""
    steps = sim.trajectory.program.steps
    dt = sim.dt

    def first(t):  # first sample whose interval starts at or after t
        return min(sim.n_samples, int(np.ceil(t / dt - 1e-9)))

    def stop(t):  # one past the last sample whose interval ends by t
        return min(sim.n_samples, int(np.floor(t / dt + 1e-9)))

    return {
        "steps/kind": Series(np.array([s.kind for s in steps], dtype="S8"), "1", "",
                             "hold, rotate or spin"),
        "steps/label": Series(np.array([s.label for s in steps], dtype="S32"), "1", "",
                              "label given in the scenario"),
        "steps/axis": Series(np.array([s.axis for s in steps], dtype=np.int32), "1", "",
                             "moving gimbal index (outer = 0), -1 for a hold"),
        "steps/start_time": Series(np.array([s.start for s in steps]), "s", "", "step start"),
        "steps/end_time": Series(np.array([s.end for s in steps]), "s", "", "step end"),
        "steps/start_index": Series(np.array([first(s.start) for s in steps], dtype=np.int64),
                                    "1", "", "first IMU sample starting at or after the start"),
        "steps/stop_index": Series(np.array([stop(s.end) for s in steps], dtype=np.int64),
                                   "1", "", "one past the last IMU sample ending by the end"),
        "steps/angles_start": Series(np.array([s.angles_start for s in steps]), "rad", "t",
                                     "gimbal angles at the step start"),
        "steps/angles_end": Series(np.array([s.angles_end for s in steps]), "rad", "t",
                                   "gimbal angles at the step end"),
    }


def truth_scalars(sensor):
    """Sensor error truth in lab units for summary.json (deg/h, ug)."""
    out = {}
    for i, axis in enumerate("xyz"):
        out[f"gyro_bias_{axis}_dph"] = float(sensor.gyro_bias[i] / DPH)
        out[f"accel_bias_{axis}_ug"] = float(sensor.accel_bias[i] / UG)
    return out


def run_simulation(sim, rng, sink, progress=None):
    """simulate-table end to end: stream the data into ``sink`` and describe the run.

    Returns
    -------
    inins.results.CommandResult
        Step schedule datasets, layout attributes (site, imu, table, truth),
        summary numbers and the report body.
    """
    simulate_table(sim, rng, sink, progress)
    lla = sim.trajectory.lla
    attrs = {
        "site": {"lat_rad": lla[0], "lon_rad": lla[1], "height_m": lla[2]},
        "imu": {"t0_s": 0.0, "dt_s": sim.dt, "sample_rate_hz": sim.sample_rate},
        "table": {"gimbals": list(sim.gimbal_names), "axes": sim.trajectory.axes,
                  "mat_n_base": sim.trajectory.mat_n_base},
        "truth": {"mat_tb0": sim.trajectory.mat_tb0, "truth_decimation": sim.truth_decimation,
                  **{f"sensor.{k}": np.asarray(v, dtype=float)
                     for k, v in vars(sim.sensor).items()}},
    }
    results = {"samples": sim.n_samples, "duration_s": sim.n_samples * sim.dt,
               "sample_rate_hz": sim.sample_rate,
               "steps": len(sim.trajectory.program.steps)}
    return CommandResult(command="simulate-table", results=results,
                         truth=truth_scalars(sim.sensor), datasets=step_schedule(sim),
                         attrs=attrs, report=report(sim))


def report(sim):
    """Report body: site, table, motion program, sensor errors."""
    lla = sim.trajectory.lla
    s = sim.sensor
    steps = [[st.index, st.kind, st.label, sim.gimbal_names[st.axis] if st.axis >= 0 else "",
              st.start, st.end, *np.degrees(st.angles_end)]
             for st in sim.trajectory.program.steps]
    gimbals = [f"{g} end" for g in sim.gimbal_names]
    sensors = [
        ["gyro bias", *(s.gyro_bias / DPH), "deg/h"],
        ["gyro ARW", *(s.gyro_arw / DEG_RTH), "deg/sqrt(h)"],
        ["gyro scale", *(s.gyro_scale / PPM), "ppm"],
        ["accel bias", *(s.accel_bias / UG), "ug"],
        ["accel VRW", *(s.accel_vrw / UG_RTHZ), "ug/sqrt(Hz)"],
        ["accel scale", *(s.accel_scale / PPM), "ppm"],
    ]
    lines = [
        f"site: latitude {np.degrees(lla[0]):.6f} deg, longitude {np.degrees(lla[1]):.6f} "
        f"deg, height {lla[2]:.1f} m",
        f"table: gimbals {', '.join(sim.gimbal_names)} (outer first)",
        f"IMU: {sim.sample_rate:g} Hz, {sim.n_samples} samples "
        f"({sim.n_samples * sim.dt:.1f} s); truth every {sim.truth_decimation} samples",
        "", "motion program",
        format_table(steps, ["#", "kind", "label", "axis", "start", "end", *gimbals],
                     ["", "", "", "", "s", "s", *["deg"] * len(gimbals)], fmt=".6g"),
        "", "sensor errors (truth)",
        format_table(sensors, ["term", "x", "y", "z", "unit"], fmt=".6g"),
    ]
    if sim.after_rotation is not None:
        lines += ["", "accelerometer bias change after each rotation: "
                  f"{np.array2string(sim.after_rotation.step / UG, precision=1)} ug, "
                  f"settling {sim.after_rotation.settle_time:g} s"]
    if sim.trajectory.mounts:
        for m in sim.trajectory.mounts:
            lines.append(f"mount rotation: {np.degrees(m.angle):.6g} deg about body "
                         f"{np.array2string(m.axis, precision=3)} from {m.start:g} s "
                         f"over {m.duration:g} s")
    return "\n".join(lines)
