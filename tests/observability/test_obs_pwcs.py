"""PWCS observability against closed forms and the classic / published results.

Closed form used throughout. A direction ``x`` of the alignment model is
unobservable on a segment with velocity aiding iff it stays out of every
measurement and is a stationary point of the error dynamics: ``dv = 0``,
``F x = 0``. For a tilt ``phi = u`` that needs (002 eq. 2, our phi angle)
``f_n x u + C_nb ba = 0`` and ``-w_in x u - C_nb bg = 0``, i.e.

    v(u) = [dv 0; phi u; ba -C_nb^T (f_n x u); bg -C_nb^T (w_in x u)],

one direction per tilt axis. At rest, heading 0 (``f_n = [0, 0, -g]``,
``w_ie = W [cos L, 0, -sin L]``):

    v(e_N) = phi_N + g ba_y + W sin L bg_y       (north tilt with the east accel bias)
    v(e_E) = phi_E - g ba_x - W sin L bg_x - W cos L bg_z   (east tilt, north accel bias)
    v(e_D) = phi_D + W cos L bg_y                (heading with the east gyro bias:
                                                  the gyrocompass error bg_E / (W cos L))
"""

import numpy as np
import pytest

from inins.core import earth
from inins.core import rotation as rot
from inins.core.units import DEG, DPH, MG
from inins.observability import measurements as meas
from inins.observability import models, pwcs
from inins.observability.segments import make_segment

LAT = 37.0 * DEG
LLA = (LAT, 127.0 * DEG, 0.0)
W = earth.RATE
VEL = meas.Measurement("velocity", 0.01)
LOS = np.array([[0.0, 0.0, -1.0], [0.5, 0.3, -0.8], [-0.4, 0.6, -0.6], [0.2, -0.7, -0.5]])
LOS = LOS / np.linalg.norm(LOS, axis=1)[:, None]
BASELINE_Y = meas.Measurement("dd_phase", 0.005, baseline_b=(0.0, 1.5, 0.0), los_n=LOS)
ALIGN12, ALIGN10 = models.MODELS["align12"], models.MODELS["align10"]


def _closed_form(model, segment, u):
    """v(u) of the module docstring on the states of ``model``.

    Compared with ``atol=1e-11`` (SI per unit of the pivot: 1e-11 rad/s of gyro
    bias per rad of tilt is 2e-6 deg/h per rad) and ``rtol=1e-9``.
    """
    w_in = earth.rate_ie_n(segment.lla[0]) + earth.rate_en_n(
        segment.lla[0], segment.lla[2], segment.vel_n
    )
    full = dict(
        zip(
            models.ALIGN12.names,
            np.concatenate(
                [
                    np.zeros(3),
                    u,
                    -segment.mat_nb.T @ np.cross(segment.f_n, u),
                    -segment.mat_nb.T @ np.cross(w_in, u),
                ]
            ),
            strict=True,
        )
    )
    return np.array([full[name] for name in model.names])


@pytest.mark.parametrize("heading", [0.0, 30 * DEG])
def test_stationary_12_state_alignment_with_velocity_has_rank_9(heading):
    seg = make_segment(600.0, LLA, heading=heading)
    res = pwcs.analyse(ALIGN12, [seg], [VEL])
    assert (res.rank, res.n_states, res.n_unobservable) == (9, 12, 3)
    assert res.method == "stripped" and res.condition_holds == (True,)
    assert pwcs.gramian_rank(ALIGN12, [seg], [VEL]) == 9
    # the three directions, pivots phi_N, phi_E, phi_D, against the closed form
    for c, u in enumerate(np.eye(3)):
        np.testing.assert_allclose(
            res.null_space[:, c], _closed_form(ALIGN12, seg, u), rtol=1e-9, atol=1e-11
        )
    # only the velocity errors and the vertical accelerometer bias are observable alone
    observable = {n for n, o in zip(res.names, res.observable, strict=True) if o}
    assert observable == {"dv_N", "dv_E", "dv_D", "ba_z"}
    # the large singular value gap the tolerance sits in (scaled, row-normalised)
    s = res.singular_values[-1]
    assert s[8] > 1e-5 * s[0] and s[9] < 1e-14 * s[0]


def test_stationary_null_directions_written_out_at_heading_zero():
    seg = make_segment(600.0, LLA, heading=0.0)
    res = pwcs.analyse(ALIGN12, [seg], [VEL])
    g = -seg.f_n[2]
    assert g == pytest.approx(earth.gravity(LAT, 0.0), rel=1e-15)
    v = {n: res.null_space[i] for i, n in enumerate(res.names)}
    # phi_N with ba_y (east accel bias) = g phi_N, bg_y = W sin L phi_N
    np.testing.assert_allclose(v["ba_y"], [g, 0, 0], rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(v["bg_y"], [W * np.sin(LAT), 0, W * np.cos(LAT)], rtol=1e-9)
    # phi_E with ba_x (north accel bias) = -g phi_E, bg_x = -W sin L, bg_z = -W cos L
    np.testing.assert_allclose(v["ba_x"], [0, -g, 0], rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(v["bg_x"], [0, -W * np.sin(LAT), 0], rtol=1e-9, atol=1e-20)
    np.testing.assert_allclose(v["bg_z"], [0, -W * np.cos(LAT), 0], rtol=1e-9, atol=1e-20)
    # heading: phi_D = bg_E / (W cos L), the gyrocompass heading error
    assert 1.0 / v["bg_y"][2] == pytest.approx(1.0 / (W * np.cos(LAT)), rel=1e-9)
    assert res.combinations == (
        f"phi_N + {g:.4g}·ba_y + {W * np.sin(LAT):.4g}·bg_y",
        f"phi_E - {g:.4g}·ba_x - {W * np.sin(LAT):.4g}·bg_x - {W * np.cos(LAT):.4g}·bg_z",
        f"phi_D + {W * np.cos(LAT):.4g}·bg_y",
    )


def test_a_heading_change_makes_the_12_state_model_observable():
    segs = [make_segment(300.0, LLA, heading=0.0), make_segment(300.0, LLA, heading=90 * DEG)]
    res = pwcs.analyse(ALIGN12, segs, [VEL])
    assert res.rank == 12 and res.segment_rank == (9, 12) and all(res.observable)
    assert res.null_space.shape == (12, 0) and res.combinations == ()
    assert pwcs.gramian_rank(ALIGN12, segs, [VEL]) == 12
    # the same with the total matrix (the condition holds, so TOM = SOM in rank)
    assert pwcs.analyse(ALIGN12, segs, [VEL], method="total").rank == 12
    # a 180 deg reversal works too: the biases turn with the body, the tilts stay in
    # the nav frame, so the horizontal parts of ba, bg in v(u) change sign (indexing)
    flip = [segs[0], make_segment(300.0, LLA, heading=180 * DEG)]
    res = pwcs.analyse(ALIGN12, flip, [VEL])
    assert res.rank == 12 == pwcs.gramian_rank(ALIGN12, flip, [VEL])


def test_classic_10_state_model_has_rank_7():
    # Bar-Itzhack & Berman (1988): horizontal velocity measured, 3 unobservable directions
    seg = make_segment(600.0, LLA, heading=0.0)
    res = pwcs.analyse(ALIGN10, [seg], [VEL])
    assert (res.rank, res.n_unobservable) == (7, 3)
    assert pwcs.gramian_rank(ALIGN10, [seg], [VEL]) == 7
    for c, u in enumerate(np.eye(3)):
        np.testing.assert_allclose(
            res.null_space[:, c], _closed_form(ALIGN10, seg, u), rtol=1e-9, atol=1e-11
        )
    assert {n for n, o in zip(res.names, res.observable, strict=True) if o} == {"dv_N", "dv_E"}
    turn = [seg, make_segment(600.0, LLA, heading=90 * DEG)]
    assert pwcs.analyse(ALIGN10, turn, [VEL]).rank == 10
    assert pwcs.gramian_rank(ALIGN10, turn, [VEL]) == 10


def _level_flight(heading, duration=120.0, speed=150.0):
    vel = speed * np.array([np.cos(heading), np.sin(heading), 0.0])
    return make_segment(duration, (LAT, LLA[1], 3000.0), heading=heading, vel_n=vel)


def test_002_one_baseline_along_body_y_leaves_pitch_and_x_accel_bias_unobservable():
    seg = _level_flight(0.0)
    res = pwcs.analyse(ALIGN12, [seg], [VEL, BASELINE_Y])
    assert (res.rank, res.n_unobservable) == (11, 1)
    assert pwcs.gramian_rank(ALIGN12, [seg], [VEL, BASELINE_Y]) == 11
    # the one direction: tilt about the baseline (pitch at heading 0 is phi_E) with
    # ba_x = f_D phi_E (f_D = -g + Coriolis in flight), plus Earth/transport-rate gyro terms
    b_n = seg.mat_nb @ np.array([0.0, 1.0, 0.0])
    np.testing.assert_allclose(
        res.null_space[:, 0], _closed_form(ALIGN12, seg, b_n), rtol=1e-9, atol=1e-11
    )
    v = dict(zip(res.names, res.null_space[:, 0], strict=True))
    assert v["phi_E"] == 1.0 and v["ba_x"] == pytest.approx(seg.f_n[2], rel=1e-9)
    assert v["ba_x"] == pytest.approx(-9.79, abs=0.01)
    # 002 names pitch and the x accelerometer bias; strictly the direction also
    # carries bg_x = w_D and bg_z = -w_N per rad of pitch (7e-5 rad/s per rad: small
    # for a tactical gyro, not for a navigation-grade one), so those two are not
    # separable either. Everything else is observable.
    unobservable = {n for n, o in zip(res.names, res.observable, strict=True) if not o}
    assert unobservable == {"phi_E", "ba_x", "bg_x", "bg_z"}
    assert res.null_weight[res.names.index("phi_E")] == pytest.approx(
        1 / np.hypot(1, v["ba_x"]), rel=1e-6
    )
    # a baseline along body x instead leaves roll (phi_N at heading 0) with ba_y
    along_x = meas.Measurement("dd_phase", 0.005, baseline_b=(1.5, 0.0, 0.0), los_n=LOS)
    res_x = pwcs.analyse(ALIGN12, [seg], [VEL, along_x])
    assert res_x.rank == 11 and res_x.combinations[0].startswith("phi_N + 9.")
    # at another heading the unobservable tilt turns with the body (pitch axis)
    seg45 = _level_flight(45 * DEG)
    res45 = pwcs.analyse(ALIGN12, [seg45], [VEL, BASELINE_Y])
    u = seg45.mat_nb[:, 1] / seg45.mat_nb[0, 1]  # pivot phi_N = 1
    np.testing.assert_allclose(
        res45.null_space[:, 0], _closed_form(ALIGN12, seg45, u), rtol=1e-9, atol=1e-11
    )


def test_002_sequential_manoeuvre_makes_all_12_states_observable():
    segs = [_level_flight(0.0), _level_flight(90 * DEG)]
    res = pwcs.analyse(ALIGN12, segs, [VEL, BASELINE_Y])
    assert res.rank == 12 and res.segment_rank == (11, 12) and all(res.observable)
    assert pwcs.gramian_rank(ALIGN12, segs, [VEL, BASELINE_Y]) == 12
    # without the baseline a turn still leaves one direction (the velocity-only
    # alignment needs the turn for heading, the baseline for a third axis)
    assert pwcs.analyse(ALIGN12, [segs[0]], [VEL]).rank == 9


def test_total_matrix_is_used_where_the_stripping_condition_fails():
    # DD phase without velocity: dv and ba are unobservable and dv rotates under
    # Coriolis (F dv != 0), so null(Q_j) is not inside null(F_j)
    segs = [_level_flight(0.0, 100.0), _level_flight(90 * DEG, 100.0)]
    res = pwcs.analyse(ALIGN12, segs, [BASELINE_Y])
    assert res.condition_holds == (False, False) and res.method == "total"
    assert res.segment_rank == (5, 6) and res.rank == 6
    assert pwcs.gramian_rank(ALIGN12, segs, [BASELINE_Y]) == 6
    assert set(res.combinations) == {"dv_N", "dv_E", "dv_D", "ba_x", "ba_y", "ba_z"}


def test_free_inertial_and_ekf_models_at_rest():
    los = np.vstack([LOS, [[-0.6, -0.5, -0.3]]])
    los = los / np.linalg.norm(los, axis=1)[:, None]
    pr = meas.Measurement("pseudorange", 3.0, los_n=los)
    rr = meas.Measurement("range_rate", 0.05, los_n=los)
    seg = make_segment(300.0, LLA, heading=0.0)
    # NAV15 with velocity: position unobservable too (6 directions), dr_D paired with
    # ba_z through the gravity gradient dg/dh
    res = pwcs.analyse(models.MODELS["nav15"], [seg], [VEL])
    assert res.rank == 9 and pwcs.gramian_rank(models.MODELS["nav15"], [seg], [VEL]) == 9
    dg_dh = earth.gravity(LAT, 0.5) - earth.gravity(LAT, -0.5)
    dr_d = next(c for c in res.combinations if c.startswith("dr_D"))
    assert dr_d == f"dr_D - {-dg_dh:.4g}·ba_z"
    # EKF17 with pseudorange and range rate: position and clock observable, the
    # three alignment directions remain (rank 14)
    ekf17 = models.MODELS["ekf17"]
    res = pwcs.analyse(ekf17, [seg], [pr, rr])
    assert res.rank == 14 == pwcs.gramian_rank(ekf17, [seg], [pr, rr])
    assert all(o for n, o in zip(res.names, res.observable, strict=True) if n[:2] in ("dr", "cl"))
    turn = [seg, make_segment(300.0, LLA, heading=90 * DEG)]
    assert pwcs.analyse(ekf17, turn, [pr, rr]).rank == 17


def test_rref_and_combination_text():
    A = np.array([[0.0, 2.0, 4.0, 1e-20], [1.0, 1.0, 1.0, 0.0]])
    np.testing.assert_array_equal(pwcs.rref(A), [[1, 0, -1, 0], [0, 1, 2, 0]])
    names = ("a", "b", "c", "d")
    assert pwcs.combination([1.0, -9.80665, 1e-6, 0.5], names) == "a - 9.807·b + 1e-06·c + 0.5·d"
    assert pwcs.combination([1.0, -9.80665, 1e-12, 0.5], names) == "a - 9.807·b + 0.5·d"
    assert pwcs.combination([0.0, -1.0], ("a", "b")) == "- b"


def test_rotation_of_the_body_does_not_change_velocity_only_rank_but_turns_the_pairs():
    mat = rot.mat_from_euler(5 * DEG, -3 * DEG, 0.0)
    seg = make_segment(600.0, LLA, mat_nb=mat)
    res = pwcs.analyse(ALIGN12, [seg], [VEL])
    assert res.rank == 9
    for c, u in enumerate(np.eye(3)):  # tilted body: ba_z enters the levelling pairs
        np.testing.assert_allclose(
            res.null_space[:, c], _closed_form(ALIGN12, seg, u), rtol=1e-9, atol=1e-11
        )
    assert not res.observable[res.names.index("ba_z")]


def test_state_scales_change_the_weights_not_the_answer():
    seg = _level_flight(0.0)
    si = pwcs.analyse(ALIGN12, [seg], [VEL, BASELINE_Y])
    typical = np.r_[[0.1] * 3, [1e-3] * 3, [0.1 * MG] * 3, [0.01 * DPH] * 3]  # nav grade
    scaled = pwcs.analyse(ALIGN12, [seg], [VEL, BASELINE_Y], scales=typical)
    assert scaled.rank == si.rank == 11 and scaled.observable == si.observable
    np.testing.assert_allclose(scaled.null_space, si.null_space, rtol=1e-7, atol=1e-12)
    assert scaled.combinations == si.combinations
    # in nav-grade units the gyro part of 002's direction is not small: 5.8e-5 rad/s
    # per rad of pitch is 0.012 deg/h per mrad against a 0.01 deg/h scale, as large as
    # the pitch part itself (measured weights 0.118 and 0.099; in SI 5.9e-6 and 0.10)
    i, k = si.names.index("bg_z"), si.names.index("phi_E")
    assert si.null_weight[i] < 1e-5 and scaled.null_weight[i] > scaled.null_weight[k] > 0.05


@pytest.mark.parametrize("duration", [60.0, 300.0, 3000.0])
@pytest.mark.parametrize("heading", [0.0, 40 * DEG])
def test_one_segment_gramian_rank_equals_the_observability_rank(duration, heading):
    """DD phase of one baseline in level flight: the observability matrix gives rank 5
    (dv and ba are not seen, nor the tilt about the baseline with its gyro-bias pair);
    the Gramian of the same segment must agree at g t up to 3e4, where the rounding of
    e^(F t) used to pass the rank tolerance (Gramian rank 6 at 300 s and beyond)."""
    seg = _level_flight(heading, duration)
    res = pwcs.analyse(ALIGN12, [seg], [BASELINE_Y])
    assert res.rank == 5
    assert pwcs.gramian_rank(ALIGN12, [seg], [BASELINE_Y]) == 5
