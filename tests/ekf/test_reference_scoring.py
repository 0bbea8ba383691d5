"""Scoring against a reference trajectory (:mod:`inins.ekf.reference_scoring`), each
against a closed form: a constant offset, a time shift, the heading's sign, the lever
arm's velocity, the outage protocol."""

import math

import numpy as np
import pytest

from inins.core import error_model, rotation
from inins.ekf import reference_scoring, scoring
from inins.ekf.post import Solution
from inins.exceptions import InputError

LLA0 = np.array([0.6, 2.0, 50.0])
V = 10.0
"""Speed of the straight drive north (m/s)."""


def _quats(heading):
    return np.array([rotation.quat_from_mat(rotation.mat_from_euler(0, 0, h)) for h in heading])


def _drive(t, heading=0.0):
    """A straight drive north at :data:`V` (the body heading ``heading`` rad): a
    :class:`Solution` at times ``t`` (s)."""
    pos = np.stack([V * t, 0 * t, 0 * t], -1)
    lla = error_model.lla_offset(np.broadcast_to(LLA0, (t.size, 3)), pos)
    vel = np.tile([V, 0.0, 0.0], (t.size, 1))
    quat = _quats(np.full(t.size, heading))
    return Solution(quat, vel, lla, np.zeros((t.size, 6)), np.zeros((t.size, 15)), None)


T = np.arange(0.0, 60.0, 0.01)
"""The solution's epochs (100 Hz, s)."""
REF_T = np.arange(-5.0, 70.0, 1.0) + 0.37
"""Reference epochs (1 Hz, off the solution's grid, beyond its span on both sides)."""


def _reference(t, north=0.0, shift=0.0):
    """The drive's positions at ``t - shift``, ``north`` m north of it."""
    pos = np.stack([V * (t - shift) + north, 0 * t, 0 * t], -1)
    return error_model.lla_offset(np.broadcast_to(LLA0, (t.size, 3)), pos)


def test_constant_offset_gives_that_rms_and_only_epochs_in_the_span():
    """A reference 1.00 m north of the solution: horizontal RMS, p95 and max 1.00 m
    (within 1 mm: linear interpolation of a straight line), the error's north component
    -1 m (solution minus reference), vertical 0 (within 1 mm); the 60 reference epochs
    inside [0, 60) s only."""
    sc = reference_scoring.reference_errors(
        T, _drive(T), np.zeros(3), REF_T, _reference(REF_T, 1.0)
    )
    assert sc.time.size == 60 and sc.time[0] == pytest.approx(0.37)
    np.testing.assert_allclose(sc.pos_ned[:, 0], -1.0, atol=1e-3)
    s = sc.stats()
    for v in (s["hor"].rms, s["hor"].p95, s["hor"].max):
        assert v == pytest.approx(1.0, abs=1e-3)
    assert s["ver"].max < 1e-3
    assert s["vel"] is None and s["heading"] is None  # no reference velocity or attitude


def test_time_shift_gives_speed_times_shift():
    """A reference whose tags are 0.1 s late (it holds the drive of t - 0.1 s): the
    horizontal error is v dt = 10 m/s x 0.1 s = 1.00 m (within 1 mm), the solution ahead
    (north +1 m); the velocity error 0 against the reference's own velocity."""
    ref_vel = np.tile([V, 0.0, 0.0], (REF_T.size, 1))
    sc = reference_scoring.reference_errors(
        T, _drive(T), np.zeros(3), REF_T, _reference(REF_T, shift=0.1), ref_vel
    )
    np.testing.assert_allclose(sc.pos_ned[:, 0], 1.0, atol=1e-3)
    assert sc.stats()["hor"].rms == pytest.approx(1.0, abs=1e-3)
    assert sc.stats()["vel"].max < 1e-9


def test_heading_error_is_solution_minus_reference_clockwise():
    """Solution heading 10 deg (body x 10 deg east of north: checked on the axis
    itself), reference heading 8 deg: heading error +2 deg (RMS, max 2 deg, mean +2),
    roll and pitch 0; a reference at 359 deg against a solution at 1 deg is +2 deg too
    (wrapped)."""
    sol = _drive(T, math.radians(10.0))
    axis = scoring.forward_heading(sol.quat[:1], np.array([1.0, 0.0, 0.0]))
    assert math.degrees(axis[0]) == pytest.approx(10.0)  # east of north is positive
    euler = np.tile(np.radians([0.0, 0.0, 8.0]), (REF_T.size, 1))
    sc = reference_scoring.reference_errors(
        T, sol, np.zeros(3), REF_T, _reference(REF_T), None, euler
    )
    np.testing.assert_allclose(np.degrees(sc.euler[:, 2]), 2.0, atol=1e-9)
    assert math.degrees(sc.stats()["heading"].rms) == pytest.approx(2.0)
    assert sc.stats()["roll"].max < 1e-9
    sol = _drive(T, math.radians(1.0))
    euler[:, 2] = math.radians(359.0)
    sc = reference_scoring.reference_errors(
        T, sol, np.zeros(3), REF_T, _reference(REF_T), None, euler
    )
    np.testing.assert_allclose(np.degrees(sc.euler[:, 2]), 2.0, atol=1e-9)


def test_lever_arm_point_position_and_velocity():
    """A vehicle standing still, turning at 0.2 rad/s, the reference point 2 m ahead of
    the IMU: the point is on a circle of 2 m, its velocity w x l = 0.4 m/s along the
    tangent. Scored with the lever arm the errors are < 1 mm and < 1 mm/s; without it
    the position is 2 m off and the velocity 0.4 m/s."""
    w, lever = 0.2, np.array([2.0, 0.0, 0.0])
    heading = w * T
    sol = Solution(
        _quats(heading),
        np.zeros((T.size, 3)),
        np.broadcast_to(LLA0, (T.size, 3)).copy(),
        np.zeros((T.size, 6)),
        np.zeros((T.size, 15)),
        None,
    )
    t = REF_T[(REF_T > 0) & (REF_T < 59)]
    h = w * t
    ref_pos = np.stack([2 * np.cos(h), 2 * np.sin(h), 0 * t], -1)
    ref_vel = np.stack([-2 * w * np.sin(h), 2 * w * np.cos(h), 0 * t], -1)
    ref_lla = error_model.lla_offset(np.broadcast_to(LLA0, (t.size, 3)), ref_pos)
    sc = reference_scoring.reference_errors(T, sol, lever, t, ref_lla, ref_vel)
    assert sc.stats()["hor"].max < 1e-3 and sc.stats()["vel"].max < 1e-3
    sc = reference_scoring.reference_errors(T, sol, np.zeros(3), t, ref_lla, ref_vel)
    assert sc.stats()["hor"].rms == pytest.approx(2.0, abs=1e-3)
    assert sc.stats()["vel"].rms == pytest.approx(0.4, abs=1e-3)


def test_outage_protocol_against_the_reference():
    """Windows [10, 20) and [30, 45) s on a reference 1 m north and 0.5 m above the
    solution except 3 m north at 40.37 s: drift per window 1.0 and 3.0 m horizontal
    (RMS sqrt(5) m), 3D sqrt(1.25) and sqrt(9.25) m; a window with no reference epoch
    is bad input naming the reference file."""
    ref = _reference(REF_T, 1.0)
    ref[:, 2] += 0.5
    k = int(np.flatnonzero(np.isclose(REF_T, 40.37))[0])
    ref[k] = _reference(REF_T[k : k + 1], 3.0)[0] + [0, 0, 0.5]
    arrays = (REF_T, ref, None, None)
    out = reference_scoring.reference_scores(
        T, {"fwd": _drive(T)}, np.zeros(3), arrays, ((10.0, 20.0), (30.0, 45.0)), 0.0, "r.csv"
    )
    d = out["fwd"].drift
    np.testing.assert_allclose(d.max_horizontal, [1.0, 3.0], atol=1e-3)
    np.testing.assert_allclose(d.max_3d, np.sqrt([1.25, 9.25]), atol=1e-3)
    assert d.rms_horizontal == pytest.approx(math.sqrt(5.0), abs=1e-3)
    with pytest.raises(InputError, match=r"no reference epoch in the outage \[10.5, 10.9\)") as e:
        reference_scoring.reference_scores(
            T, {"fwd": _drive(T)}, np.zeros(3), arrays, ((10.5, 10.9),), 0.0, "r.csv"
        )
    assert e.value.source == "r.csv"
    with pytest.raises(InputError, match="no reference epoch within the run"):
        late = (REF_T + 1000.0, ref, None, None)
        reference_scoring.reference_scores(T, {"fwd": _drive(T)}, np.zeros(3), late, (), 0.0, "r")


def test_error_stats():
    """RMS, 95th percentile and max of |values| over the finite ones; None without any."""
    s = reference_scoring.error_stats(np.array([3.0, -4.0, np.nan]))
    assert s.rms == pytest.approx(math.sqrt(12.5)) and s.max == 4.0
    assert s.p95 == pytest.approx(3.95)
    assert reference_scoring.error_stats(np.array([np.nan])) is None
