"""Rotations: direction cosine matrices, quaternions, rotation vectors, Euler angles.

All functions accept a single item or a stack on the leading axes
(``(..., 3)``, ``(..., 4)``, ``(..., 3, 3)``) and return new arrays.
Quaternions are scalar first ``[w, x, y, z]``. ``mat_ab`` maps frame b to
frame a. Euler angles are roll, pitch, heading in z-y-x order:
``mat_nb = Rz(heading) @ Ry(pitch) @ Rx(roll)`` (package docstring).
"""

import numpy as np

_SMALL = 1e-8


def skew(vec):
    """Cross-product matrix: ``skew(a) @ b == cross(a, b)``.

    Parameters
    ----------
    vec : array_like, shape (..., 3)

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    vec = np.asarray(vec, dtype=float)
    x, y, z = vec[..., 0], vec[..., 1], vec[..., 2]
    zero = np.zeros_like(x)
    return np.stack(
        [
            np.stack([zero, -z, y], axis=-1),
            np.stack([z, zero, -x], axis=-1),
            np.stack([-y, x, zero], axis=-1),
        ],
        axis=-2,
    )


def _rotvec_coefficients(angle):
    """sin(a)/a and (1 - cos(a))/a^2, with series near zero."""
    angle2 = angle * angle
    small = angle < 1e-4
    safe = np.where(small, 1.0, angle)
    a = np.where(small, 1.0 - angle2 / 6.0 + angle2 * angle2 / 120.0, np.sin(safe) / safe)
    b = np.where(
        small, 0.5 - angle2 / 24.0 + angle2 * angle2 / 720.0, (1.0 - np.cos(safe)) / safe**2
    )
    return a, b


def mat_from_rotvec(rotvec):
    """Rodrigues formula: ``exp([rotvec x])``.

    Parameters
    ----------
    rotvec : array_like, shape (..., 3)
        Rotation vector (rad): axis times angle.

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    rotvec = np.asarray(rotvec, dtype=float)
    angle = np.linalg.norm(rotvec, axis=-1)
    a, b = _rotvec_coefficients(angle)
    k = skew(rotvec)
    return np.eye(3) + a[..., None, None] * k + b[..., None, None] * (k @ k)


def quat_from_rotvec(rotvec):
    """Unit quaternion of a rotation vector, shape (..., 4)."""
    rotvec = np.asarray(rotvec, dtype=float)
    angle = np.linalg.norm(rotvec, axis=-1)
    half = 0.5 * angle
    small = angle < 1e-4
    safe = np.where(small, 1.0, angle)
    # sin(a/2)/a with its series near zero
    k = np.where(small, 0.5 - angle * angle / 48.0, np.sin(half) / safe)
    return np.concatenate([np.cos(half)[..., None], k[..., None] * rotvec], axis=-1)


def rotvec_from_quat(quat):
    """Rotation vector (rad) of a unit quaternion, angle in [0, pi]."""
    quat = np.asarray(quat, dtype=float)
    quat = np.where(quat[..., :1] < 0.0, -quat, quat)
    w = quat[..., 0]
    vec = quat[..., 1:]
    sin_half = np.linalg.norm(vec, axis=-1)
    angle = 2.0 * np.arctan2(sin_half, w)
    small = sin_half < _SMALL
    safe = np.where(small, 1.0, sin_half)
    k = np.where(small, 2.0 / np.where(w == 0.0, 1.0, w), angle / safe)
    return k[..., None] * vec


def mat_from_quat(quat):
    """Direction cosine matrix of a quaternion (normalised first), shape (..., 3, 3)."""
    quat = np.asarray(quat, dtype=float)
    quat = quat / np.linalg.norm(quat, axis=-1, keepdims=True)
    w, x, y, z = (quat[..., i] for i in range(4))
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
            np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
            np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
        ],
        axis=-2,
    )


def quat_from_mat(mat):
    """Unit quaternion (w >= 0) of a direction cosine matrix (Shepperd's method)."""
    mat = np.asarray(mat, dtype=float)
    trace = np.trace(mat, axis1=-2, axis2=-1)
    diag = np.diagonal(mat, axis1=-2, axis2=-1)
    # candidates 4*w^2, 4*x^2, 4*y^2, 4*z^2; take the largest for stability
    cand = np.concatenate([(1.0 + trace)[..., None], 1.0 + 2.0 * diag - trace[..., None]], -1)
    choice = np.argmax(cand, axis=-1)
    m = mat
    rows = [
        np.stack(
            [
                1.0 + trace,
                m[..., 2, 1] - m[..., 1, 2],
                m[..., 0, 2] - m[..., 2, 0],
                m[..., 1, 0] - m[..., 0, 1],
            ],
            -1,
        ),
        np.stack(
            [
                m[..., 2, 1] - m[..., 1, 2],
                1.0 + 2.0 * m[..., 0, 0] - trace,
                m[..., 0, 1] + m[..., 1, 0],
                m[..., 0, 2] + m[..., 2, 0],
            ],
            -1,
        ),
        np.stack(
            [
                m[..., 0, 2] - m[..., 2, 0],
                m[..., 0, 1] + m[..., 1, 0],
                1.0 + 2.0 * m[..., 1, 1] - trace,
                m[..., 1, 2] + m[..., 2, 1],
            ],
            -1,
        ),
        np.stack(
            [
                m[..., 1, 0] - m[..., 0, 1],
                m[..., 0, 2] + m[..., 2, 0],
                m[..., 1, 2] + m[..., 2, 1],
                1.0 + 2.0 * m[..., 2, 2] - trace,
            ],
            -1,
        ),
    ]
    quat = np.take_along_axis(np.stack(rows, -2), choice[..., None, None], axis=-2)[..., 0, :]
    quat = quat / np.linalg.norm(quat, axis=-1, keepdims=True)
    return np.where(quat[..., :1] < 0.0, -quat, quat)


def rotvec_from_mat(mat):
    """Rotation vector (rad) of a direction cosine matrix."""
    return rotvec_from_quat(quat_from_mat(mat))


def quat_multiply(q, r):
    """Hamilton product ``q * r`` (apply r first, then q), shape (..., 4)."""
    q = np.asarray(q, dtype=float)
    r = np.asarray(r, dtype=float)
    w0, x0, y0, z0 = (q[..., i] for i in range(4))
    w1, x1, y1, z1 = (r[..., i] for i in range(4))
    return np.stack(
        [
            w0 * w1 - x0 * x1 - y0 * y1 - z0 * z1,
            w0 * x1 + x0 * w1 + y0 * z1 - z0 * y1,
            w0 * y1 - x0 * z1 + y0 * w1 + z0 * x1,
            w0 * z1 + x0 * y1 - y0 * x1 + z0 * w1,
        ],
        axis=-1,
    )


def quat_conjugate(quat):
    """Conjugate (inverse of a unit quaternion), shape (..., 4)."""
    quat = np.asarray(quat, dtype=float)
    return quat * np.array([1.0, -1.0, -1.0, -1.0])


def quat_rotate(quat, vec):
    """Rotate ``vec`` by ``quat``: ``mat_from_quat(quat) @ vec``, shape (..., 3)."""
    return np.einsum("...ij,...j->...i", mat_from_quat(quat), np.asarray(vec, dtype=float))


def mat_from_euler(roll, pitch, heading):
    """``mat_nb = Rz(heading) @ Ry(pitch) @ Rx(roll)`` from angles in rad.

    Parameters
    ----------
    roll, pitch, heading : array_like, broadcastable
        Euler angles (rad).

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    roll, pitch, heading = np.broadcast_arrays(
        np.asarray(roll, float), np.asarray(pitch, float), np.asarray(heading, float)
    )
    cr, sr = np.cos(roll), np.sin(roll)
    cp, sp = np.cos(pitch), np.sin(pitch)
    ch, sh = np.cos(heading), np.sin(heading)
    return np.stack(
        [
            np.stack([ch * cp, ch * sp * sr - sh * cr, ch * sp * cr + sh * sr], -1),
            np.stack([sh * cp, sh * sp * sr + ch * cr, sh * sp * cr - ch * sr], -1),
            np.stack([-sp, cp * sr, cp * cr], -1),
        ],
        axis=-2,
    )


def euler_from_mat(mat_nb):
    """Roll, pitch, heading (rad) of ``mat_nb``; heading in [0, 2 pi).

    Returns
    -------
    ndarray, shape (..., 3)
        ``[roll, pitch, heading]``.
    """
    mat_nb = np.asarray(mat_nb, dtype=float)
    roll = np.arctan2(mat_nb[..., 2, 1], mat_nb[..., 2, 2])
    pitch = np.arcsin(np.clip(-mat_nb[..., 2, 0], -1.0, 1.0))
    heading = np.mod(np.arctan2(mat_nb[..., 1, 0], mat_nb[..., 0, 0]), 2.0 * np.pi)
    return np.stack([roll, pitch, heading], axis=-1)


def axis_rotation(axis, angle):
    """Frame rotation about a coordinate axis: ``Rx``, ``Ry`` or ``Rz`` of ``angle`` (rad).

    ``axis_rotation(2, h)`` is ``Rz(h)`` of :func:`mat_from_euler`, i.e. it maps the
    rotated frame to the original one.
    """
    vec = np.zeros((*np.shape(angle), 3))
    vec[..., axis] = angle
    return mat_from_rotvec(vec)


def wrap_angle(angle):
    """Wrap to (-pi, pi]."""
    return -np.mod(-np.asarray(angle, dtype=float) + np.pi, 2.0 * np.pi) + np.pi
