"""The transition order of the total observability matrix and of the Gramian: segment
``j`` sees the initial state through ``e^(F_(j-1) D_(j-1)) ... e^(F_1 D_1)``, the
latest segment leftmost. Checked on three segments of different headings and lengths
(where ``e^(F_1 D_1) e^(F_2 D_2)`` and ``e^(F_2 D_2) e^(F_1 D_1)`` differ: the singular
values of the two products' TOMs differ by 27 %) against an independent propagation:
the state transition from the start is integrated as an ODE in time order
(``scipy.integrate.solve_ivp``, no matrix exponential), then the TOM and the Gramian are
built from it."""

import numpy as np
from scipy import integrate

from inins.core.units import DEG
from inins.observability import measurements as meas
from inins.observability import models, pwcs
from inins.observability.segments import make_segment

LAT = 37.0 * DEG
MODEL = models.MODELS["align12"]
VEL = meas.Measurement("velocity", 0.01)


def _segments():
    out = []
    for heading, duration in ((0.0, 60.0), (90 * DEG, 300.0), (30 * DEG, 100.0)):
        vel = 150.0 * np.array([np.cos(heading), np.sin(heading), 0.0])
        out.append(make_segment(duration, (LAT, 127 * DEG, 3000.0), heading=heading, vel_n=vel))
    return out


def _time_ordered_transitions(F, durations):
    """Phi(t) from the start, integrated through the segments in time order: a callable
    per segment giving Phi at local time t, and Phi at each segment start."""
    n = F.shape[1]
    start, starts, dense = np.eye(n), [], []
    for Fj, d in zip(F, durations, strict=True):
        starts.append(start)
        sol = integrate.solve_ivp(
            lambda _, y, Fj=Fj: (Fj @ y.reshape(n, n)).ravel(),
            (0.0, d),
            start.ravel(),
            method="DOP853",
            rtol=1e-12,
            atol=1e-14,
            dense_output=True,
        )
        dense.append(lambda t, s=sol: s.sol(t).reshape(n, n))
        start = sol.y[:, -1].reshape(n, n)
    return starts, dense


def _scaled_system(segments):
    F = MODEL.system_matrices(segments)
    Hs = []
    for seg in segments:
        H, _ = meas.measurement_matrix(MODEL.layout, seg, [VEL])
        Hs.append(H / np.linalg.norm(H, axis=1)[:, None])
    return F, Hs


def test_total_observability_matrix_follows_time_order():
    segments = _segments()
    F, Hs = _scaled_system(segments)
    starts, _ = _time_ordered_transitions(F, [s.duration for s in segments])
    res = pwcs.analyse(MODEL, segments, [VEL], method="total")
    for j in range(len(segments)):
        tom = np.vstack([pwcs.segment_matrix(F[i], Hs[i]) @ starts[i] for i in range(j + 1)])
        s = np.linalg.svd(tom, compute_uv=False)
        np.testing.assert_allclose(res.singular_values[j], s, rtol=1e-6, atol=1e-9 * s[0])
    # the case discriminates: the product in the other order gives other singular values
    e1 = starts[1]  # e^(F1 D1)
    e2 = starts[2] @ np.linalg.inv(e1)  # e^(F2 D2)
    wrong = np.vstack(
        [
            pwcs.segment_matrix(F[0], Hs[0]),
            pwcs.segment_matrix(F[1], Hs[1]) @ e1,
            pwcs.segment_matrix(F[2], Hs[2]) @ (e1 @ e2),
        ]
    )
    s_wrong = np.linalg.svd(wrong, compute_uv=False)
    assert np.max(np.abs(s_wrong - res.singular_values[-1]) / s_wrong[0]) > 0.1


def test_gramian_follows_time_order():
    segments = _segments()
    F, Hs = _scaled_system(segments)
    _, dense = _time_ordered_transitions(F, [s.duration for s in segments])
    x, w = np.polynomial.legendre.leggauss(40)
    W = np.zeros((12, 12))
    for j, seg in enumerate(segments):
        for xq, wq in zip(x, w, strict=True):
            A = Hs[j] @ dense[j](0.5 * seg.duration * (xq + 1.0))
            W += 0.5 * seg.duration * wq * A.T @ A
    got = pwcs.gramian(MODEL, segments, [VEL])
    np.testing.assert_allclose(got, W, rtol=1e-7, atol=1e-9 * np.abs(W).max())
