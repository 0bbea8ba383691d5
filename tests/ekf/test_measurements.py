"""The per-epoch GNSS input of the tightly coupled filter refuses bad values, naming the key
(its rows against the nonlinear model: ``tests/ekf/test_jacobians.py``)."""

import numpy as np
import pytest

from inins.ekf.measurements import GnssEpoch
from inins.exceptions import InputError


def test_bad_epoch_names_the_key():
    with pytest.raises(InputError) as info:
        GnssEpoch(
            0.0, [1], np.zeros((1, 3)), np.zeros((1, 3)), [0.0], [0.0], [0.0], [0.0], [0.0], [1.0]
        )
    assert info.value.key == "sigma"
    with pytest.raises(InputError) as info:
        GnssEpoch(
            1.0,
            [1],
            np.zeros((1, 3)),
            np.zeros((1, 3)),
            [0.0],
            [0.0],
            [0.0],
            [0.0],
            [1.0],
            [1.0],
            arrival=0.5,
        )
    assert info.value.key == "arrival"
