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
    """The specialisations are numba's dispatchers': load numba."""
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


def test_a_compile_is_announced_with_its_expected_time_and_a_cache_load_is_not():
    from inins.commands.warmup import CompileNotice

    jit.activate()
    lines, during = [], []
    notice = jit.on_compile(CompileNotice("inins test", lines.append, expected_s=30, every_s=60))
    probe = jit.on_compile(
        lambda event, name, s: during.append(notice.line()) if event == "start" else None
    )
    try:

        @jit.njit(cache=False)  # a cached copy from an earlier run would load silently
        def scaled(x):
            return 3.0 * x

        assert scaled(2.0) == 6.0
        assert lines == [
            "inins test: compiling numerical kernels for this machine (once after an install, "
            "an upgrade or an edit, up to about 30 s; later runs load them) ..."
        ]
        assert "compiling " in during[0] and ".scaled (" in during[0]
        assert "(0 compiled," in during[0] and "s left)" in during[0]
        assert notice.count == 1 and notice.active == []
        assert scaled(3.0) == 9.0  # compiled already: nothing more to say
        assert len(lines) == 1 and len(during) == 1
    finally:
        jit.remove_compile_listener(notice)
        jit.remove_compile_listener(probe)
        notice.close()


def test_a_long_compile_prints_a_line_every_few_seconds_until_it_ends():
    import time

    from inins.commands.warmup import CompileNotice

    lines = []
    notice = CompileNotice("inins test", lines.append, expected_s=None, every_s=0.02)
    notice("start", "inins.ekf.step.epoch", 0.0)
    deadline = time.monotonic() + 10.0
    while len(lines) < 3 and time.monotonic() < deadline:
        time.sleep(0.01)
    notice("done", "inins.ekf.step.epoch", 1.0)
    notice.close()
    assert len(lines) >= 3
    assert lines[1].startswith("inins test:   compiling ekf.step.epoch (0 compiled, ")
