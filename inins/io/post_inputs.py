"""The files of a run-ekf ``post:`` section: its GNSS solutions, IMU log and reference
attitude, each read by the reader of its ``format`` (:mod:`inins.io.solution_files`,
:mod:`inins.io.solution_layout`). The sections are the scenario's
(:mod:`inins.scenario.run_ekf_post`); import-flight's ``format: solution`` reads the
same two sections."""

import numpy as np

from inins.core.units import DEG
from inins.io import solution_files as sf
from inins.io import solution_layout


def read_gnss(g):
    """The :class:`~inins.io.solution_files.SolutionFile` of a ``post.gnss`` section."""
    if g.format == "rtklib":
        return sf.read_rtklib_pos(g.file)
    if g.format == "recorded":
        return solution_layout.read_recorded_solution(g.file)
    if g.format == "mat":
        cols = {k: int(v) for k, v in g.columns.items()}
        return sf.read_solution_mat(
            g.file, g.mat_variable, cols, g.angle_unit, g.sigma_m, g.sigma_vel_mps, g.time_system
        )
    return sf.read_solution_csv(
        g.file, g.columns, g.angle_unit, g.time_scale_s, time_system=g.time_system
    )


def read_imu(i):
    """The :class:`~inins.io.solution_files.ImuRates` of a ``post.imu`` section."""
    if i.format == "recorded":
        return solution_layout.read_recorded_imu(i.file)
    if i.format == "mat":
        return sf.read_imu_increments_mat(
            i.file, i.mat_variable, i.gyro_columns, i.accel_columns, i.time_column, i.axes
        )
    return sf.read_imu_rates_csv(
        i.file,
        i.accel_columns,
        i.gyro_columns,
        i.time_column,
        i.time_scale_s,
        i.accel_unit,
        i.gyro_unit,
        i.axes,
        i.odometer_column,
        i.odometer_scale_mps,
    )


def read_reference_euler(g):
    """Reference roll, pitch, heading (m, 3) rad of a .mat solution with attitude columns
    (heading = ``yaw_sign`` yaw), one row per epoch of the file; None without them."""
    if g.format != "mat" or g.attitude_columns is None:
        return None
    c = g.attitude_columns
    a = sf.read_mat_columns(
        g.file, g.mat_variable, [c["roll"], c["pitch"], c["yaw"]], "post.gnss.attitude_columns"
    )
    k = DEG if g.angle_unit == "deg" else 1.0
    return np.stack([a[:, 0] * k, a[:, 1] * k, g.yaw_sign * a[:, 2] * k], axis=-1)
