"""Motion programs: rate profiles against their closed forms."""

import numpy as np
import pytest

from inins.core.units import DEG
from inins.table.program import Hold, Rotate, Spin, compile_program


def test_trapezoid_turn_closed_form():
    # 180 deg at 10 deg/s with 20 deg/s^2: 0.5 s up (2.5 deg), 17.5 s cruise, 0.5 s down
    prog = compile_program([Hold(5.0), Rotate(0, np.pi, 10 * DEG, 20 * DEG)], [0.0, 0.0])
    assert prog.duration == pytest.approx(5.0 + 18.5, abs=1e-12)
    turn = prog.steps[1]
    assert (turn.start, turn.end) == pytest.approx((5.0, 23.5), abs=1e-12)
    np.testing.assert_allclose(turn.angles_end, [np.pi, 0.0], atol=1e-14)
    angle, rate = prog.segments.evaluate([5.5, 14.25, 23.0, 30.0])
    np.testing.assert_allclose(angle[:, 0], np.array([2.5, 90.0, 177.5, 180.0]) * DEG, atol=1e-14)
    np.testing.assert_allclose(rate[:, 0], np.array([10, 10, 10, 0]) * DEG, atol=1e-14)
    np.testing.assert_allclose(prog.breakpoints, [5.0, 5.5, 23.0, 23.5])


def test_triangle_turn_when_rate_is_not_reached():
    prog = compile_program([Rotate(1, -1.0 * DEG, 10 * DEG, 20 * DEG)], [0.0, 0.0])
    t_half = np.sqrt(1.0 / 20.0)
    assert prog.duration == pytest.approx(2 * t_half, abs=1e-12)
    angle, rate = prog.segments.evaluate([t_half, 2 * t_half])
    np.testing.assert_allclose(angle[:, 1], [-0.5 * DEG, -1.0 * DEG], atol=1e-15)
    np.testing.assert_allclose(rate[:, 1], [-20 * DEG * t_half, 0.0], atol=1e-14)


def test_spin_angle_and_continuity():
    prog = compile_program([Spin(0, -30 * DEG, 10.0, 60 * DEG)], [0.1, 0.0])
    t_acc = 0.5
    assert prog.duration == pytest.approx(10.0 + 2 * t_acc)
    np.testing.assert_allclose(
        prog.steps[0].angles_end[0], 0.1 - 30 * DEG * (10.0 + t_acc), atol=1e-13
    )
    # angle and rate are continuous across every breakpoint
    for t in prog.breakpoints:
        a, r = prog.segments.evaluate([t - 1e-9, t + 1e-9])
        np.testing.assert_allclose(a[0], a[1], atol=1e-9)
        np.testing.assert_allclose(r[0], r[1], atol=1e-6)
