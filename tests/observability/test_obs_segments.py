"""Segments: the physics make_segment fills in, validation, and cutting a trajectory."""

import itertools

import numpy as np
import pytest

from inins.core import earth, flight
from inins.core import rotation as rot
from inins.core.units import DEG
from inins.exceptions import InputError
from inins.observability import analysis, models
from inins.observability import measurements as meas
from inins.observability.segments import Segment, cut_segments, make_segment

LLA = (37.0 * DEG, 127.0 * DEG, 500.0)


def test_make_segment_at_rest_and_in_level_flight():
    rest = make_segment(60.0, LLA, heading=30 * DEG)
    g = earth.gravity(LLA[0], LLA[2])
    np.testing.assert_allclose(rest.f_n, [0, 0, -g], rtol=0, atol=1e-15)
    np.testing.assert_allclose(rest.f_b, [0, 0, -g], rtol=0, atol=1e-14)
    np.testing.assert_allclose(rest.mat_nb @ rest.omega_ib_b, earth.rate_ie_n(LLA[0]), atol=1e-20)
    vel = np.array([0.0, 200.0, 0.0])  # east at 200 m/s
    fly = make_segment(60.0, LLA, heading=90 * DEG, vel_n=vel)
    w = 2 * earth.rate_ie_n(LLA[0]) + earth.rate_en_n(LLA[0], LLA[2], vel)
    # f = (2 w_ie + w_en) x v - g: Coriolis and centripetal terms, ~0.02 m/s^2 up/north
    np.testing.assert_allclose(fly.f_n, np.cross(w, vel) - [0, 0, g], rtol=1e-15)
    assert 0.01 < np.hypot(fly.f_n[0], fly.f_n[2] + g) < 0.05
    given = make_segment(10.0, LLA, mat_nb=rot.mat_from_euler(0.1, 0.2, 0.3), f_b=[1.0, 0, -9.0])
    np.testing.assert_allclose(given.f_b, [1.0, 0, -9.0], rtol=1e-14, atol=1e-15)


def test_bad_segments_name_the_key():
    good = make_segment(1.0, LLA)
    bent = good.mat_nb.copy()
    bent[0, 0] = 1.01
    with pytest.raises(InputError, match="not a rotation") as err:
        Segment(1.0, bent, good.f_n, good.omega_ib_b, good.vel_n, good.lla, key="segments.2")
    assert err.value.key == "segments.2.mat_nb"
    with pytest.raises(InputError, match="not a rotation"):  # a reflection
        Segment(1.0, np.diag([1.0, 1.0, -1.0]), good.f_n, good.omega_ib_b, good.vel_n, good.lla)
    with pytest.raises(InputError, match="duration") as err:
        make_segment(0.0, LLA, key="segments.0")
    assert err.value.key == "segments.0.duration"
    with pytest.raises(InputError, match="heading or mat_nb"):
        make_segment(1.0, LLA, heading=0.0, mat_nb=np.eye(3))
    with pytest.raises(InputError, match="shape"):
        make_segment(1.0, LLA, vel_n=(1.0, 2.0))


def _flat_turn(rate_hz=10.0):
    """100 s north, a 90 deg flat turn at 3 deg/s (30 s), 100 s east; f_b constant."""
    t = np.arange(0.0, 230.0 + 1e-9, 1.0 / rate_hz)
    heading = np.clip((t - 100.0) * 3 * DEG, 0.0, 90 * DEG)
    mat = rot.mat_from_euler(0.0 * t, 0.0 * t, heading)
    vel = 100.0 * np.stack([np.cos(heading), np.sin(heading), 0 * t], -1)
    f_b = np.tile([0.0, 0.0, -9.8], (len(t), 1))
    omega = np.zeros((len(t), 3))
    omega[(t > 100.0) & (t <= 130.0), 2] = 3 * DEG
    lla = np.tile(LLA, (len(t), 1))
    return t, mat, f_b, omega, vel, lla


def test_cut_segments_by_attitude_change():
    t, mat, f_b, omega, vel, lla = _flat_turn()
    segs = cut_segments(t, mat, f_b, omega, vel, lla, attitude_threshold=2 * DEG)
    assert sum(s.duration for s in segs) == pytest.approx(230.0, abs=1e-9)
    # each sample turns 0.3 deg: a segment ends at the 7th sample (2.1 deg > 2 deg).
    # The first runs to 100.7 s, then 41 of 0.7 s to 129.4 s (88.2 deg); the last 1.8 deg
    # stay under the threshold, so the last segment runs on to 230 s: 43 in all
    assert len(segs) == 43
    assert segs[0].duration == pytest.approx(100.7) and segs[-1].duration == pytest.approx(100.6)
    assert all(s.duration == pytest.approx(0.7) for s in segs[1:-1])
    headings = [rot.euler_from_mat(s.mat_nb)[2] for s in segs]
    assert np.all(np.diff(headings[:-1]) > 0) and headings[-1] == pytest.approx(90 * DEG)
    # a step of the specific force starts a segment on its sample
    f_step = f_b.copy()
    f_step[t >= 50.0, 0] = 1.0
    segs = cut_segments(t, mat, f_step, omega, vel, lla, attitude_threshold=100 * DEG)
    assert [round(s.duration, 6) for s in segs] == [50.0, 180.0]
    np.testing.assert_allclose(segs[1].f_b, [1.0, 0, -9.8], atol=1e-12)


def test_cut_segments_of_the_turn_make_002_observable_like_the_two_legs():
    t, mat, f_b, omega, vel, lla = _flat_turn(rate_hz=2.0)
    los = np.array([[0.0, 0.0, -1.0], [0.5, 0.3, -0.8], [-0.4, 0.6, -0.6]])
    los = los / np.linalg.norm(los, axis=1)[:, None]
    segs = cut_segments(t, mat, f_b, omega, vel, lla, attitude_threshold=5 * DEG, los_n=los)
    aiding = [
        meas.Measurement("velocity", 0.05),
        meas.Measurement("dd_phase", 0.005, baseline_b=(0, 1.5, 0)),
    ]
    found = analysis.analyse(models.MODELS["align12"], segs, aiding)
    assert found.rank == 12 == found.gramian_rank
    assert found.pwcs.segment_rank[0] == 11 and all(s.observable for s in found.states)


def test_cut_segments_input_errors():
    t, mat, f_b, omega, vel, lla = _flat_turn()
    with pytest.raises(InputError, match="shape") as err:
        cut_segments(t, mat, f_b[:-1], omega, vel, lla)
    assert err.value.key == "f_b"
    bad = mat.copy()
    bad[5] *= 1.1
    with pytest.raises(InputError, match="sample 5") as err:
        cut_segments(t, bad, f_b, omega, vel, lla)
    assert err.value.key == "mat_nb"
    with pytest.raises(InputError, match="increasing"):
        cut_segments(t[::-1], mat, f_b, omega, vel, lla)


def test_aircraft_flight_cut_into_segments_keeps_each_within_the_threshold():
    traj = flight.aircraft_trajectory()
    t = np.arange(0.0, 240.0 + 1e-9, 0.5)
    mat, vel, lla = traj.state(t)
    omega, f_b = traj.rates(t)
    segs = cut_segments(
        t, mat, f_b, omega, vel, lla, attitude_threshold=3 * DEG, force_threshold=0.5
    )
    starts = np.concatenate([[0.0], np.cumsum([s.duration for s in segs])])
    assert starts[-1] == pytest.approx(240.0) and len(segs) > 10
    for a, b in itertools.pairwise(starts):
        inside = (t >= a - 1e-9) & (t < b - 1e-9)
        first = np.argmax(inside)
        rel = np.swapaxes(mat[first], 0, 1) @ mat[inside]
        angle = np.linalg.norm(rot.rotvec_from_mat(rel), axis=-1)
        assert angle.max() <= 3 * DEG
        assert np.linalg.norm(f_b[inside] - f_b[first], axis=-1).max() <= 0.5


def test_interval_means_of_chunked_increments():
    """Means over intervals that straddle chunk boundaries equal the means of the whole
    array; samples before the first edge and after the last are left out."""
    from inins.observability.segments import interval_means

    rng = np.random.default_rng(4)
    dtheta, dv = rng.normal(size=(100, 3)), rng.normal(size=(100, 3))
    edges = np.array([5, 17, 40, 41, 90])
    chunks = [(k, dtheta[k : k + 23], dv[k : k + 23]) for k in range(0, 100, 23)]
    omega, force = interval_means(chunks, edges, 0.01)
    for j in range(len(edges) - 1):
        lo, hi = edges[j], edges[j + 1]
        np.testing.assert_allclose(omega[j], dtheta[lo:hi].sum(0) / ((hi - lo) * 0.01))
        np.testing.assert_allclose(force[j], dv[lo:hi].sum(0) / ((hi - lo) * 0.01))
