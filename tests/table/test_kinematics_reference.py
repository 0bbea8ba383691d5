"""The table kinematics kernel against its previous implementation, bit for bit.

``kinematics_v0`` is a frozen copy of the kernel before it was rewritten to compile
faster (3x3 matrices as tuples instead of small arrays, no slice assignments, no
allocation per call). The arithmetic is the same operation for operation, so the
rates, specific forces, attitudes and gimbal angles must be identical.
"""

import kinematics_v0
import numpy as np
import pytest

from inins.core import rotation
from inins.core.units import DEG
from inins.table import kinematics
from inins.table.kinematics import MountRotation, TableTrajectory, base_matrix, gimbal_axes
from inins.table.program import Hold, Rotate, Spin, compile_program
from tests.helpers import kernel_argument_types


@pytest.mark.parametrize("names", [["yaw", "pitch"], ["yaw", "pitch", "roll"]])
def test_matches_previous_kernel_bit_for_bit(names):
    g = len(names)
    steps = [
        Hold(5.0),
        Rotate(0, np.pi, 10 * DEG, 20 * DEG),
        Hold(3.0),
        Rotate(1, np.pi / 2, 10 * DEG, 20 * DEG),
        Spin(g - 1, 30 * DEG, 4.0, 15 * DEG),
        Hold(2.0),
    ]
    nonorth = np.array([[1e-4, -2e-4], [3e-4, 1e-5], [-1e-4, 2e-4]])[:g]
    mounts = (
        MountRotation(np.array([0.6, 0.0, 0.8]), 0.01, 2.0, 10.0, True),
        MountRotation(np.array([0.0, 1.0, 0.0]), -0.003, 12.0, 5.0, False),
    )
    traj = TableTrajectory(
        compile_program(steps, np.linspace(0.1, 0.3, g)),
        gimbal_axes(names, nonorth),
        base_matrix(0.3, 1e-4, -2e-4),
        rotation.mat_from_euler(0.01, 0.02, 0.5),
        mounts,
        np.array([37.0 * DEG, 127.0 * DEG, 50.0]),
    )
    # forward in time through holds, turns, spins and both mount ramps, then back
    time = np.concatenate(
        [np.linspace(0.0, traj.breakpoints[-1] + 1.0, 20_001), [3.0, 1.0, 20.0, 0.0]]
    )
    for want_mat in (False, True):
        new = traj._evaluate(time, want_mat)
        old = kinematics_v0.evaluate(traj, time, want_mat)
        if not want_mat:  # mat_nb is an unwritten placeholder
            new, old = new[:2] + new[3:], old[:2] + old[3:]
        for a, b in zip(new, old, strict=True):
            assert a.shape == b.shape
            assert np.array_equal(a, b)


def test_warm_up_compiles_the_one_specialisation_every_table_uses(monkeypatch):
    types = kernel_argument_types(monkeypatch, kinematics, "_kinematics_kernel")
    kinematics.warm_up()
    program = compile_program([Rotate(2, 1.0, 0.5, 1.0)], np.zeros(3))
    traj = TableTrajectory(
        program,
        gimbal_axes(["yaw", "pitch", "roll"]),
        base_matrix(1.0),
        np.eye(3),
        (),
        np.array([0.6, 2.2, 10.0]),
    )
    traj.rates([0.5, 1.0])
    traj.state(np.float32(2.0))
    assert len(types) == 4 and len(set(types)) == 1
