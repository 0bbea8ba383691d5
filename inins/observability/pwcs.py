"""Observability of a piecewise-constant system (PWCS): TOM, SOM, rank, null space, Gramian.

Theory (Goshen-Meskin & Bar-Itzhack, "Observability analysis of piece-wise
constant systems", IEEE TAES 28(4), 1992, Part I). On segment ``j`` the
system ``x' = F_j x``, ``z = H_j x`` has the observability matrix
``Q_j = [H_j; H_j F_j; ...; H_j F_j^(n-1)]``. The total observability matrix
over ``r`` segments is
``TOM = [Q_1; Q_2 e^(F_1 D_1); ...; Q_r e^(F_(r-1) D_(r-1)) ... e^(F_1 D_1)]``
and its null space is the set of initial states no measurement sees. If
``null(Q_j) ⊂ null(F_j)`` for every segment, the stripped matrix
``SOM = [Q_1; Q_2; ...; Q_r]`` has the same null space (their Theorem 2) and
needs no matrix exponentials; where the condition fails this module uses the
TOM.

Numerics (stated once)
----------------------
- States are scaled to physical units: ``x = S x_s`` with ``S = diag(scales)``,
  by default 1 m, 1 m/s, 1 rad, 1 m/s^2, 1 rad/s, 1 (SI, :data:`UNITS`);
  every matrix is formed in the scaled state (``F_s = S^-1 F S``,
  ``H_s = H S``). Time is in seconds.
- Each measurement row is normalised to unit norm (row scaling leaves the
  null space unchanged).
- The stacked matrix is compressed segment by segment into its ``n x n``
  triangular factor (QR), which has the same singular values.
- Numerical rank: singular values above ``tol = max(M, n) * eps * s_max``,
  ``M`` the number of stacked rows (the LAPACK/numpy rule, scale-aware
  because relative to ``s_max`` of the scaled, row-normalised matrix).
- A state is observable when its unit vector is orthogonal to the null space:
  the norm of its row in the orthonormal null basis (scaled coordinates) is
  below ``10 * tol / s_r`` (``s_r`` the smallest retained singular value; the
  first-order bound on the rotation of the null space by perturbations of
  size ``tol``, Wedin 1972) and never below 1e-12.
"""

from dataclasses import dataclass

import numpy as np
from scipy import linalg

from inins.exceptions import InputError
from inins.observability import measurements as meas

_EPS = np.finfo(float).eps


def _scaled(model, segments, measurements, scales):
    """Scaled F (J, n, n) and row-normalised scaled H per segment (list of (m, n))."""
    F = model.system_matrices(segments)
    F = F / scales[None, :, None] * scales[None, None, :]
    Hs = []
    for seg in segments:
        H, _ = meas.measurement_matrix(model.layout, seg, measurements)
        H = H * scales[None, :]
        norm = np.linalg.norm(H, axis=1)
        Hs.append(H[norm > 0.0] / norm[norm > 0.0, None])
    return F, Hs


def segment_matrix(F, H):
    """Observability matrix ``Q = [H; H F; ...; H F^(n-1)]`` of one segment, shape (m n, n)."""
    n = F.shape[0]
    blocks = [H]
    for _ in range(n - 1):
        blocks.append(blocks[-1] @ F)
    return np.vstack(blocks)


def _rank_tol(s, rows):
    return max(rows, len(s)) * _EPS * (s[0] if len(s) else 0.0)


def _null(R, rows):
    """Orthonormal null basis of the stacked matrix whose R factor is ``R``."""
    _, s, vt = np.linalg.svd(R)
    tol = _rank_tol(s, rows)
    rank = int(np.sum(s > tol))
    return s, rank, vt[rank:].T, tol


def _condition_holds(R, rows, F):
    """``null(Q) ⊂ null(F)`` with ``R`` the triangular factor of ``Q``: F maps the
    (scaled) null basis of Q to ~0: ``|F N|_F <= 1e-12 |F|_F``."""
    N = _null(R, rows)[2]
    if N.shape[1] == 0:
        return True
    return bool(np.linalg.norm(F @ N) <= 1e-12 * max(np.linalg.norm(F), 1e-300))


def _r_factor(A):
    """Upper-triangular ``R`` (n, n) of ``A = Q R`` (LAPACK dgeqrf; same singular values)."""
    n = A.shape[1]
    qr = linalg.lapack.dgeqrf(A)[0]
    R = np.zeros((n, n))
    k = min(A.shape)
    R[:k] = np.triu(qr[:k, :n])
    return R


def _compress(R, block):
    return _r_factor(block if R is None else np.vstack([R, block]))


@dataclass(frozen=True)
class PwcsResult:
    """Rank and null space of the observability matrix along the segments.

    Attributes
    ----------
    names : tuple of str
        State names in order.
    units : tuple of str
        SI unit of each state.
    scales : ndarray, shape (n,)
        State scales used (SI).
    method : str
        ``"stripped"`` (SOM; the condition held on every segment) or ``"total"``.
    condition_holds : tuple of bool
        ``null(Q_j) ⊂ null(F_j)`` per segment.
    rank : int
    n_states : int
    n_unobservable : int
        ``n_states - rank``.
    tolerance : float
        Rank tolerance on the scaled singular values.
    singular_values : ndarray, shape (J, n)
        Singular values of the scaled matrix stacked up to and including
        segment ``j`` (descending), so row ``j`` shows what segments 1..j see.
    segment_rank : tuple of int
        Rank after each segment.
    null_space : ndarray, shape (n, k)
        Unobservable directions in SI, reduced-row-echelon: column ``c`` has
        1 at its pivot state and 0 at the other pivots.
    combinations : tuple of str
        ``null_space`` written out: ``"phi_E - 9.8·ba_x - ..."`` means moving
        phi_E by 1 rad together with ba_x by -9.8 m/s^2, ... changes no
        measurement (coefficients in SI per unit of the pivot state).
    observable : tuple of bool
        Per state: orthogonal to the null space.
    null_weight : ndarray, shape (n,)
        Per state: norm of its row in the orthonormal scaled null basis
        (0 observable, 1 not seen at all).
    """

    names: tuple
    units: tuple
    scales: np.ndarray
    method: str
    condition_holds: tuple
    rank: int
    n_states: int
    n_unobservable: int
    tolerance: float
    singular_values: np.ndarray
    segment_rank: tuple
    null_space: np.ndarray
    combinations: tuple
    observable: tuple
    null_weight: np.ndarray


def analyse(model, segments, measurements, *, scales=None, method="auto"):
    """Rank, null space and observable states of ``model`` along ``segments``.

    Parameters
    ----------
    model : Model
    segments : sequence of Segment
    measurements : sequence of Measurement
        The same measurements on every segment (rows evaluated per segment).
    scales : array_like, shape (n,), optional
        State scales (SI); default 1 (see module docstring).
    method : {"auto", "stripped", "total"}
        ``"auto"``: SOM if ``null(Q_j) ⊂ null(F_j)`` on every segment, else TOM.

    Returns
    -------
    PwcsResult
    """
    if not segments:
        raise InputError("at least one segment is needed", key="segments")
    if method not in ("auto", "stripped", "total"):
        raise InputError(f"method must be auto, stripped or total, got {method!r}", key="method")
    n = len(model.layout)
    scales = np.ones(n) if scales is None else np.asarray(scales, dtype=float)
    F, Hs = _scaled(model, segments, measurements, scales)
    Qs = [segment_matrix(F[j], Hs[j]) for j in range(len(segments))]
    Rs = [_r_factor(Q) for Q in Qs]  # Q_j = U_j R_j: R_j stands for Q_j below
    holds = tuple(_condition_holds(Rs[j], len(Q), F[j]) for j, Q in enumerate(Qs))
    use_total = method == "total" or (method == "auto" and not all(holds))
    R, rows, transition = None, 0, np.eye(n)
    sv, ranks = [], []
    for j, Q in enumerate(Qs):
        R = _compress(R, Rs[j] @ transition if use_total else Rs[j])
        rows += len(Q)
        s = np.linalg.svd(R, compute_uv=False)
        sv.append(s)
        ranks.append(int(np.sum(s > _rank_tol(s, rows))))
        if use_total:
            transition = linalg.expm(F[j] * segments[j].duration) @ transition
    s, rank, N, tol = _null(R, rows)
    weight = np.linalg.norm(N, axis=1)
    threshold = max(10.0 * tol / s[rank - 1], 1e-12) if rank else 1.0
    V = np.zeros((n, 0))
    if N.shape[1]:  # echelon form in the scaled state, then back to SI with pivot 1
        Vs = rref(N.T) * scales[None, :]
        pivots = np.argmax(Vs != 0.0, axis=1)
        V = (Vs / Vs[np.arange(len(Vs)), pivots][:, None]).T
    units = tuple(model.layout.unit(name) for name in model.names)
    return PwcsResult(
        names=model.names,
        units=units,
        scales=scales,
        method="total" if use_total else "stripped",
        condition_holds=holds,
        rank=rank,
        n_states=n,
        n_unobservable=n - rank,
        tolerance=tol,
        singular_values=np.array(sv),
        segment_rank=tuple(ranks),
        null_space=V,
        combinations=tuple(combination(V[:, c], model.names, scales) for c in range(V.shape[1])),
        observable=tuple(bool(w <= threshold) for w in weight),
        null_weight=weight,
    )


def rref(A, rel_tol=1e-9):
    """Reduced row-echelon form of ``A`` (shape (k, n), rank k) with partial pivoting.

    Entries below ``rel_tol`` times the largest of their row are set to zero
    (rounding left by the SVD), so exact zeros of the theory read as zeros.
    """
    A = np.array(A, dtype=float)
    k, n = A.shape
    row = 0
    for col in range(n):
        if row == k:
            break
        p = row + int(np.argmax(np.abs(A[row:, col])))
        if abs(A[p, col]) <= rel_tol * np.abs(A).max():
            continue
        A[[row, p]] = A[[p, row]]
        A[row] /= A[row, col]
        others = np.arange(k) != row
        A[others] -= np.outer(A[others, col], A[row])
        row += 1
    A[np.abs(A) < rel_tol * np.abs(A).max(axis=1, keepdims=True)] = 0.0
    return A


def combination(vector, names, scales=None, digits=4, rel_tol=1e-9):
    """A direction in state space written out in state order: ``"phi_E - 9.807·ba_x"``.

    Terms whose scaled size (``|vector| / scales``) is below ``rel_tol`` of the
    largest are dropped.
    """
    vector = np.asarray(vector, dtype=float)
    scaled = np.abs(vector) / (1.0 if scales is None else np.asarray(scales, dtype=float))
    order = [i for i in range(len(vector)) if scaled[i] > rel_tol * scaled.max()]
    terms = []
    for i in order:
        c = vector[i]
        mag = "" if np.isclose(abs(c), 1.0, rtol=1e-12) else f"{abs(c):.{digits}g}·"
        sign = "-" if c < 0 else "+"
        terms.append(f"{sign} {mag}{names[i]}")
    text = " ".join(terms)
    return text[2:] if text.startswith("+ ") else text


def gramian_factor(model, segments, measurements, *, scales=None, nodes=None):
    """Square-root factor ``R`` (``W = R^T R``) of the observability Gramian along the segments.

    ``W = sum_j Phi_j^T [int_0^D_j e^(F_j^T s) H_j^T H_j e^(F_j s) ds] Phi_j``,
    ``Phi_j = e^(F_(j-1) D_(j-1)) ... e^(F_1 D_1)``, in the scaled, row-normalised
    coordinates of :func:`analyse`. Each segment integral is taken by
    Gauss-Legendre quadrature in square-root form: the rows
    ``sqrt(w_q) H_j e^(F_j t_q) Phi_j`` are stacked and compressed by QR, so
    ``W`` is never formed and its rank is read with the SVD rule of
    :func:`analyse` instead of on squared singular values (forming ``W`` would
    lose everything below ``eps * |W|``, i.e. half the digits).

    Parameters
    ----------
    nodes : int, optional
        Quadrature nodes per segment (default ``n + 4``; ``q`` nodes are exact
        for integrands polynomial in time up to degree ``2 q - 1``).

    Returns
    -------
    R : ndarray, shape (n, n)
    rows : int
        Number of stacked rows (for the rank tolerance).
    """
    n = len(model.layout)
    scales = np.ones(n) if scales is None else np.asarray(scales, dtype=float)
    F, Hs = _scaled(model, segments, measurements, scales)
    x, w = np.polynomial.legendre.leggauss(n + 4 if nodes is None else nodes)
    R, rows, transition = None, 0, np.eye(n)
    for j, seg in enumerate(segments):
        t = 0.5 * seg.duration * (x + 1.0)
        Phi_t = linalg.expm(F[j][None] * t[:, None, None])
        weight = np.sqrt(0.5 * seg.duration * w)
        block = np.concatenate([weight[q] * Hs[j] @ Phi_t[q] for q in range(len(t))])
        R = _compress(R, block @ transition)
        rows += len(block)
        transition = linalg.expm(F[j] * seg.duration) @ transition
    return R, rows


def gramian(model, segments, measurements, *, scales=None, nodes=None):
    """Observability Gramian ``W = R^T R`` (scaled coordinates), shape (n, n); see
    :func:`gramian_factor`."""
    R, _ = gramian_factor(model, segments, measurements, scales=scales, nodes=nodes)
    return R.T @ R


def gramian_rank(model, segments, measurements, *, scales=None, nodes=None):
    """Numerical rank of the observability Gramian along the segments.

    The columns of its factor are equilibrated to unit norm first (rank-neutral);
    columns whose norm is below the rank tolerance of the column norms are
    states the Gramian does not see (rounding fill-in of ``expm``, not signal)
    and count as unobservable; then the SVD rule of :func:`analyse` applies, with
    the tolerance widened by the accuracy of the exponentials: scaling and squaring
    computes ``e^(F t)`` to about ``eps |F t|`` relative to its norm (Higham 2005),
    so the rows of a segment carry rounding of ``eps |F_j| D_j`` times their size
    in every direction, the unobservable ones included. Without that factor a
    one-segment Gramian reads rank 6 where the observability matrix gives 5 (DD
    phase of one baseline over 300 s of level flight: ``g t`` = 3000, the spurious
    singular value 5e-12 against a tolerance of 2e-14; the smallest genuine one of
    the cases tested is 0.03).
    """
    R, rows = gramian_factor(model, segments, measurements, scales=scales, nodes=nodes)
    norm = np.linalg.norm(R, axis=0)
    seen = norm > _rank_tol(norm[np.argsort(norm)[::-1]], rows)  # rounding fill-in is not seen
    if not seen.any():
        return 0
    s = np.linalg.svd(R[:, seen] / norm[seen], compute_uv=False)
    return int(np.sum(s > _rank_tol(s, rows) * _expm_growth(model, segments, scales)))


def _expm_growth(model, segments, scales):
    """``max(1, max_j |F_j D_j|_2)`` in the scaled state of :func:`analyse`."""
    n = len(model.layout)
    scales = np.ones(n) if scales is None else np.asarray(scales, dtype=float)
    F = model.system_matrices(segments) / scales[None, :, None] * scales[None, None, :]
    return max(
        1.0, max(np.linalg.norm(Fj, 2) * seg.duration for Fj, seg in zip(F, segments, strict=True))
    )
