"""A rate-table scenario (``simulate:`` section or simulate-table scenario) in SI:
the table program, kinematics and sensor model of :mod:`inins.table.simulate`."""

import numpy as np

from inins.core.units import ARCSEC, DEG, UG
from inins.table import kinematics, program, simulate


def table_simulation(setup):
    """A ``simulate:`` section (or simulate-table scenario) in SI:
    :class:`inins.table.simulate.TableSimulation`."""
    t = setup.table
    names = tuple(t.gimbals)
    index = {name: g for g, name in enumerate(names)}
    accel = t.accel_dps2 * DEG
    steps = []
    for s in setup.motion:
        if s.kind == "hold":
            steps.append(program.Hold(s.duration_s, s.label))
        elif s.kind == "rotate":
            steps.append(
                program.Rotate(index[s.axis], s.angle_deg * DEG, s.rate_dps * DEG, accel, s.label)
            )
        else:
            steps.append(
                program.Spin(index[s.axis], s.rate_dps * DEG, s.duration_s, accel, s.label)
            )
    initial = np.array(t.initial_angles_deg or [0.0] * len(names)) * DEG
    nonorth = (
        None
        if t.axis_nonorthogonality_arcsec is None
        else np.array(t.axis_nonorthogonality_arcsec) * ARCSEC
    )
    axes_b = {"x": (1.0, 0, 0), "y": (0, 1.0, 0), "z": (0, 0, 1.0)}
    mounts = tuple(
        kinematics.MountRotation(
            np.array(axes_b[r.axis]),
            r.angle_deg * DEG,
            r.start_s,
            r.duration_s,
            r.shape == "smooth",
        )
        for r in setup.mount.rotations
    )
    traj = kinematics.TableTrajectory(
        program=program.compile_program(steps, initial),
        axes=kinematics.gimbal_axes(names, nonorth),
        mat_n_base=kinematics.base_matrix(
            t.base_azimuth_deg * DEG, t.base_tilt_arcsec[0] * ARCSEC, t.base_tilt_arcsec[1] * ARCSEC
        ),
        mat_tb0=setup.mount.mat_tb0(),
        mounts=mounts,
        lla=setup.site.lla(),
    )
    d = setup.disturbances
    after = (
        None
        if d.accel_bias_after_rotation is None
        else simulate.AfterRotationBias(
            np.array(d.accel_bias_after_rotation.step_ug) * UG,
            d.accel_bias_after_rotation.settle_time_s,
        )
    )
    chamber = (
        None
        if d.chamber is None
        else simulate.Chamber(np.array(d.chamber.time_s), np.array(d.chamber.delta_degc))
    )
    return simulate.TableSimulation(
        trajectory=traj,
        sensor=setup.imu.to_si(),
        sample_rate=setup.imu.sample_rate_hz,
        gimbal_names=names,
        encoder_noise=t.encoder_noise_arcsec * ARCSEC,
        truth_decimation=round(setup.imu.sample_rate_hz / setup.output.truth_rate_hz),
        after_rotation=after,
        chamber=chamber,
    )
