"""The post-processing steps of a recorded drive (:mod:`inins.ekf.post`) and the scores
of :mod:`inins.ekf.scoring`, each on arrays with a known answer."""

import numpy as np
import pytest

from inins.core import error_model, rotation
from inins.core.units import DEG
from inins.ekf import loose, post, scoring
from inins.ekf.post import Solution
from inins.exceptions import InputError

LLA0 = np.array([0.6, 2.0, 50.0])


def test_velocity_of_positions_on_a_line():
    """Positions moving at (12, -5, 0.3) m/s in the NED axes of the first epoch: central
    differences of the ECEF positions in those axes give it back (to 1 um/s)."""
    t = np.arange(0.0, 60.0, 1.0)
    v = np.array([12.0, -5.0, 0.3])
    lla = error_model.lla_offset(np.broadcast_to(LLA0, (t.size, 3)), t[:, None] * v)
    np.testing.assert_allclose(
        post.velocity_from_positions(t, lla), np.tile(v, (t.size, 1)), atol=1e-6
    )


def test_resample_integrates_the_rates_over_each_interval():
    """A rate linear in time is integrated exactly by its value at the interval's middle."""
    t = np.arange(0.0, 20.0, 0.013)
    rates = np.stack([0.1 + 0.02 * t, -0.3 * np.ones_like(t), 0.05 * t], -1)
    inc, grid = post.resample(t, rates, 0.01, 1.0, 15.0)
    assert grid[0] == 1.0 and grid[-1] < 15.0 - 0.005
    mid = grid + 0.005
    want = np.stack([0.1 + 0.02 * mid, -0.3 * np.ones_like(mid), 0.05 * mid], -1) * 0.01
    np.testing.assert_allclose(inc, want, rtol=1e-12, atol=1e-15)


def test_overlap_and_time_mapping():
    t0, t1 = post.overlap(np.arange(3.004, 100.0, 0.01), np.arange(0.0, 90.0), 0.01)
    assert t0 == pytest.approx(3.01) and t1 == 89.0
    with pytest.raises(InputError) as info:
        post.overlap(np.arange(0.0, 100.0, 0.01), np.arange(95.0, 200.0), 0.01)
    assert info.value.key == "post.time"
    tig, fit = post.map_time(
        np.arange(5.0), None, None, None, post.TimeSettings(fit=False, offset=2.5), 0, 0
    )
    assert fit is None and tig.tolist() == [2.5, 3.5, 4.5, 5.5, 6.5]


def test_initial_state_puts_the_imu_below_the_antenna():
    """The antenna at ``lla0``, the lever arm (1, 0.5, -1.5) m in a body at heading 90 deg:
    the IMU is at ``lla0 - C_nb l``; the antenna of that state is ``lla0`` again."""
    mat = rotation.mat_from_euler(0.0, 0.0, 90 * DEG)
    lever = np.array([1.0, 0.5, -1.5])
    nav = post.initial_state(LLA0, mat, np.zeros(3), lever)
    np.testing.assert_allclose(
        error_model.position_error_ned(nav.lla, LLA0), -mat @ lever, atol=1e-9
    )
    ant = loose.antenna_positions(nav.quat_nb[None], nav.lla[None], lever)
    # the NED axes at the IMU and at the antenna differ by |l| / R: 3e-7 m here
    np.testing.assert_allclose(error_model.position_error_ned(ant[0], LLA0), 0.0, atol=1e-6)
    # east of the IMU by the body's x (heading east), above it by 1.5 m
    np.testing.assert_allclose(mat @ lever, [-0.5, 1.0, -1.5], atol=1e-15)


def test_antenna_positions_carry_the_time_offset():
    """``lla + C_nb l_b + v offset``: a body heading north moving east at 10 m/s."""
    quat = rotation.quat_from_mat(np.eye(3))[None]
    lla = LLA0[None]
    got = loose.antenna_positions(
        quat, lla, np.array([2.0, 0.0, 0.0]), np.array([[0, 10.0, 0]]), 0.1
    )
    np.testing.assert_allclose(
        error_model.position_error_ned(got, lla), [[2.0, 1.0, 0.0]], atol=1e-9
    )


def test_outage_windows_from_the_run_start():
    s = post.OutageSettings(every=60.0, length=15.0, windows=((200.0, 210.0),))
    assert post.outage_windows(s, 100.0, 400.0) == (
        (160.0, 175.0),
        (220.0, 235.0),
        (280.0, 295.0),
        (300.0, 310.0),
        (340.0, 355.0),
    )
    # a peer's placement: 15 s every three outage lengths from 40 s, eleven of them
    peer = post.OutageSettings(every=45.0, length=15.0, first=40.0, count=11)
    wins = post.outage_windows(peer, 0.0, 1000.0)
    assert len(wins) == 11 and wins[0] == (40.0, 55.0) and wins[-1] == (490.0, 505.0)


def _solution(lla, quat):
    m = lla.shape[0]
    return Solution(quat, np.zeros((m, 3)), lla, np.zeros((m, 6)), np.zeros((m, 15)), None)


def test_outage_scores_against_the_reference_epochs():
    """A solution 3 m north of the reference inside the window [10, 20) s (elsewhere on
    it): the largest horizontal drift there is 3 m; a window without a reference epoch is
    bad input naming post.reference_q."""
    t = np.arange(0.0, 40.0)
    ref = error_model.lla_offset(np.broadcast_to(LLA0, (40, 3)), np.zeros((40, 3)))
    off = np.zeros((40, 3))
    off[10:20, 0] = np.linspace(0.5, 3.0, 10)
    lla = error_model.lla_offset(ref, off)
    quat = np.tile(rotation.quat_from_mat(np.eye(3)), (40, 1))
    sc = scoring.outage_scores(
        t, {"fwd": _solution(lla, quat)}, np.zeros(3), t, ref, [(10.0, 20.0)]
    )
    assert sc["fwd"].max_horizontal[0] == pytest.approx(3.0, abs=1e-6)
    with pytest.raises(InputError) as info:
        scoring.outage_scores(
            t, {"fwd": _solution(lla, quat)}, np.zeros(3), t[:5], ref[:5], [(10.0, 20.0)]
        )
    assert info.value.key == "post.reference_q"


def test_attitude_differences_are_estimate_minus_reference():
    """Heading 0.5 deg right of the reference, roll 0.2 deg: heading mean +0.5 deg, the
    tilt 0.2 deg; epochs before ``t_from`` are not scored."""
    t = np.arange(0.0, 20.0)
    ref = rotation.mat_from_euler(np.zeros(20), np.zeros(20), np.full(20, 30 * DEG))
    est = rotation.mat_from_euler(np.full(20, 0.2 * DEG), np.zeros(20), np.full(20, 30.5 * DEG))
    est[:5] = ref[:5]  # before t_from: not scored
    d = scoring.attitude_differences(t, {"fwd": rotation.quat_from_mat(est)}, t, ref, 5.0)["fwd"]
    assert d.heading_mean == pytest.approx(0.5 * DEG, abs=1e-12)
    assert d.heading_std == pytest.approx(0.0, abs=1e-12)
    assert d.tilt_mean_max == pytest.approx(0.2 * DEG, abs=1e-12)


def test_reference_epochs_failing_the_gate_are_not_scored():
    """References on the solution (0.1 m sigma each) but epoch 12 10 m off (NIS 5000 over
    the default bound 3066) and epoch 14 4 m off (800): 12 is dropped, 14 kept; epoch 30
    the filter rejected is dropped too; with the gate off (bound inf) every one is kept."""
    from inins.ekf import gate

    t = np.arange(0.0, 40.0)
    lla = error_model.lla_offset(np.broadcast_to(LLA0, (40, 3)), np.zeros((40, 3)))
    off = np.zeros((40, 3))
    off[12, 0], off[14, 1] = 10.0, 4.0
    ref = error_model.lla_offset(lla, off)
    quat = np.tile(rotation.quat_from_mat(np.eye(3)), (40, 1))
    sol = Solution(quat, np.zeros((40, 3)), lla, np.zeros((40, 6)), np.full((40, 15), 0.1), None)
    rejected = np.zeros(40, bool)
    rejected[30] = True
    var = np.full((40, 3), 0.01)
    limit = gate.bound(0.999999, 10.0)
    keep = scoring.screen_references(t, sol, np.zeros(3), t, ref, var, limit, rejected)
    assert np.flatnonzero(~keep).tolist() == [12, 30]
    everything = scoring.screen_references(t, sol, np.zeros(3), t, ref, var, np.inf, rejected)
    assert everything.all()
