"""warm_up() compiles each kernel with the argument types of every public call.

An install step that calls the ``warm_up()`` functions leaves a cache from which a
command loads every kernel without compiling; that holds only if the public
functions never ask the kernels for another specialisation.
"""

import numpy as np
import pytest

from inins.core import imu, jit, pulses, strapdown
from tests.helpers import kernel_argument_types


@pytest.fixture(autouse=True)
def _through_numba():
    """The specialisations are numba's: load it (else the kernel library, which takes
    calls of the library's own types, would leave the dispatchers uncompiled)."""
    jit.activate()


def test_strapdown_modes_and_options_share_one_specialisation(monkeypatch):
    types = kernel_argument_types(monkeypatch, strapdown, "_navigate")
    strapdown.warm_up()
    state = strapdown.NavState.from_attitude([0.1, 0.2, 0.3], [1.0, 2.0, 3.0], [0.6, 2.2, 10.0])
    dtheta, dv = np.full((7, 3), 1e-4), np.full((7, 3), -0.098)
    for options in (
        {},
        {"fixed_height": True},
        {"fixed_position": True},
        {"fixed_position": True, "zero_velocity": True},
        {"coning": False, "sculling": False, "decimation": 3},
    ):
        state, _ = strapdown.integrate(
            state, dtheta.tolist(), dv.astype(np.float32), 0.01, **options
        )
    assert len(types) == 6 and len(set(types)) == 1


def test_imu_options_share_one_specialisation(monkeypatch):
    types = kernel_argument_types(monkeypatch, imu, "_kernel")
    imu.warm_up()
    rng = np.random.default_rng(0)
    errors = imu.SensorErrors(gyro_bias=1e-6, gyro_pulse_weight=1e-6, accel_vrw=1e-4)
    dtheta, dv = np.zeros((8, 3)), np.zeros((8, 3))
    _, _, state, _ = imu.apply_errors(
        dtheta,
        dv,
        0.01,
        errors,
        rng,
        truth_every=4,
        temperature_delta=np.arange(8.0),
        gyro_bias_extra=np.ones((8, 3)),
    )
    imu.apply_errors(dtheta[:2], dv[:2].tolist(), 0.01, imu.SensorErrors(), rng, state)
    assert len(types) == 3 and len(set(types)) == 1


def test_pulse_counts_share_one_specialisation(monkeypatch):
    types = kernel_argument_types(monkeypatch, pulses, "_counts_kernel")
    pulses.warm_up()
    weight = np.array([1.0, 2.0, 0.5])
    pulses.counts_from_increments(np.arange(12.0).reshape(2, 2, 3) * weight, weight)
    assert len(types) == 2 and len(set(types)) == 1


def test_a_compile_is_announced_with_progress_and_a_cache_load_is_not():
    from inins.commands.warmup import CompileNotice
    from inins.core import jit

    jit.activate()
    lines = []
    notice = jit.on_compile(CompileNotice("inins test", lines.append, every_s=0.0))
    try:

        @jit.njit
        def scaled(x):
            return 3.0 * x

        assert scaled(2.0) == 6.0
        assert lines[0].startswith("inins test: compiling numerical kernels for this machine")
        assert lines[1].startswith("inins test:   1 kernels compiled")
        assert "scaled" in lines[1]
        assert scaled(3.0) == 9.0  # compiled already: nothing more to say
        assert len(lines) == 2
    finally:
        jit.remove_compile_listener(notice)
