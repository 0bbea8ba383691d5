"""Rotation conversions: closed forms and round-trip property tests."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from inins.core import rotation as rot

angles = st.floats(-np.pi, np.pi, allow_nan=False)
rotvecs = arrays(float, 3, elements=st.floats(-3.0, 3.0, allow_nan=False)).filter(
    lambda v: np.linalg.norm(v) < np.pi - 1e-3
)


def test_skew_is_cross_product():
    a, b = np.array([1.0, -2.0, 0.5]), np.array([0.3, 4.0, -1.0])
    np.testing.assert_allclose(rot.skew(a) @ b, np.cross(a, b), rtol=1e-15)


def test_axis_rotations_closed_form():
    h = 0.3
    np.testing.assert_allclose(
        rot.mat_from_euler(0.0, 0.0, h),
        [[np.cos(h), -np.sin(h), 0], [np.sin(h), np.cos(h), 0], [0, 0, 1]],
        atol=1e-15,
    )
    # heading 90 deg: body x points east
    mat_nb = rot.mat_from_euler(0.0, 0.0, np.pi / 2)
    np.testing.assert_allclose(mat_nb @ [1.0, 0, 0], [0, 1.0, 0], atol=1e-15)
    # pitch up 90 deg: body x points up (-down)
    mat_nb = rot.mat_from_euler(0.0, np.pi / 2, 0.0)
    np.testing.assert_allclose(mat_nb @ [1.0, 0, 0], [0, 0, -1.0], atol=1e-15)
    # roll right 90 deg: body y points down
    mat_nb = rot.mat_from_euler(np.pi / 2, 0.0, 0.0)
    np.testing.assert_allclose(mat_nb @ [0, 1.0, 0], [0, 0, 1.0], atol=1e-15)


def test_rotvec_closed_form_and_small_angle():
    mat = rot.mat_from_rotvec([0.0, 0.0, np.pi / 2])
    np.testing.assert_allclose(mat, rot.axis_rotation(2, np.pi / 2), atol=1e-15)
    small = np.array([1e-9, -2e-9, 3e-9])
    np.testing.assert_allclose(rot.mat_from_rotvec(small), np.eye(3) + rot.skew(small), atol=1e-17)
    np.testing.assert_allclose(rot.rotvec_from_mat(np.eye(3) + rot.skew(small)), small, rtol=1e-7)


@settings(max_examples=200, deadline=None)
@given(angles, st.floats(-1.5, 1.5), angles)
def test_euler_round_trip(roll, pitch, heading):
    mat = rot.mat_from_euler(roll, pitch, heading)
    np.testing.assert_allclose(mat @ mat.T, np.eye(3), atol=1e-14)
    back = rot.euler_from_mat(mat)
    np.testing.assert_allclose(rot.wrap_angle(back - [roll, pitch, heading]), 0.0, atol=1e-12)


@settings(max_examples=200, deadline=None)
@given(rotvecs)
def test_rotvec_quat_mat_round_trips(rv):
    mat = rot.mat_from_rotvec(rv)
    quat = rot.quat_from_rotvec(rv)
    np.testing.assert_allclose(rot.mat_from_quat(quat), mat, atol=1e-14)
    np.testing.assert_allclose(rot.rotvec_from_mat(mat), rv, atol=1e-12)
    q2 = rot.quat_from_mat(mat)
    np.testing.assert_allclose(q2 * np.sign(q2[0] * quat[0] or 1.0), quat, atol=1e-14)
    np.testing.assert_allclose(rot.rotvec_from_quat(quat), rv, atol=1e-12)


@settings(max_examples=100, deadline=None)
@given(rotvecs, rotvecs)
def test_quat_product_is_matrix_product(a, b):
    qa, qb = rot.quat_from_rotvec(a), rot.quat_from_rotvec(b)
    np.testing.assert_allclose(
        rot.mat_from_quat(rot.quat_multiply(qa, qb)),
        rot.mat_from_rotvec(a) @ rot.mat_from_rotvec(b),
        atol=1e-14,
    )
    v = np.array([0.2, -1.0, 3.0])
    np.testing.assert_allclose(rot.quat_rotate(qa, v), rot.mat_from_rotvec(a) @ v, atol=1e-14)
    np.testing.assert_allclose(
        rot.quat_multiply(qa, rot.quat_conjugate(qa)), [1, 0, 0, 0], atol=1e-15
    )


def test_stacked_inputs():
    rng = np.random.default_rng(0)
    rv = rng.uniform(-1, 1, (5, 4, 3))
    mats = rot.mat_from_rotvec(rv)
    assert mats.shape == (5, 4, 3, 3)
    np.testing.assert_allclose(rot.rotvec_from_mat(mats), rv, atol=1e-12)
    eul = rot.euler_from_mat(mats)
    np.testing.assert_allclose(rot.mat_from_euler(*np.moveaxis(eul, -1, 0)), mats, atol=1e-14)


def test_quat_from_mat_near_180_degrees():
    for axis in np.eye(3):
        mat = rot.mat_from_rotvec(axis * (np.pi - 1e-9))
        np.testing.assert_allclose(rot.mat_from_quat(rot.quat_from_mat(mat)), mat, atol=1e-14)
