"""Navigation error definitions and the INS error-state model library.

Error definitions (package docstring): estimated minus true; attitude error is
the phi angle, ``mat_nb_est = (I - [phi x]) @ mat_nb_true``; position error is
expressed in NED metres at the true position.
"""

import numpy as np

from inins.core import earth, rotation


def attitude_error(mat_nb_est, mat_nb_true):
    """Phi-angle attitude error (rad), shape (..., 3), NED.

    ``mat_nb_est = (I - [phi x]) @ mat_nb_true`` to first order; exactly,
    ``mat_nb_est @ mat_nb_true.T = exp(-[phi x])``.
    """
    mat_nb_est = np.asarray(mat_nb_est, dtype=float)
    mat_nb_true = np.asarray(mat_nb_true, dtype=float)
    return -rotation.rotvec_from_mat(mat_nb_est @ np.swapaxes(mat_nb_true, -1, -2))


def position_error_ned(lla_est, lla_true):
    """Position error (m), shape (..., 3), NED at the true position.

    Parameters
    ----------
    lla_est, lla_true : array_like, shape (..., 3)
        ``[lat (rad), lon (rad), height (m)]``.
    """
    lla_est = np.asarray(lla_est, dtype=float)
    lla_true = np.asarray(lla_true, dtype=float)
    d_ecef = earth.ecef_from_llh(*np.moveaxis(lla_est, -1, 0)) - earth.ecef_from_llh(
        *np.moveaxis(lla_true, -1, 0)
    )
    mat_en = earth.mat_en(lla_true[..., 0], lla_true[..., 1])
    return np.einsum("...ji,...j->...i", mat_en, d_ecef)
