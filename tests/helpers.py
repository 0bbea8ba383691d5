"""Shared test helpers: shipped scenarios loaded with ``--set``-style overrides; the
argument types a kernel is called with."""

from pathlib import Path

import yaml

from inins.core import jit
from inins.scenario.base import load_scenario

ROOT = Path(__file__).resolve().parents[1]
CONFIGS = ROOT / "configs"
SHARED_DATA = ROOT.parent / "shared" / "data"


def overrides_of(**updates):
    """``{"imu.gyro.bias_dph": [1, 0, 0]}`` -> ``["imu.gyro.bias_dph=[1, 0, 0]"]``."""

    def text(value):
        return yaml.safe_dump(value, default_flow_style=True).removesuffix("...\n").strip()

    return [f"{key}={text(value)}" for key, value in updates.items()]


def shipped(model_cls, relative, *overrides, **updates):
    """The shipped scenario ``configs/<relative>`` validated as ``model_cls``, with
    ``--set`` items (strings) and keyword updates (``key.path=value``) applied in order."""
    items = [*overrides, *overrides_of(**updates)]
    return load_scenario(model_cls, CONFIGS / relative, items, None)[0]


def kernel_argument_types(monkeypatch, module, name):
    """numba's types of the arguments of every call of kernel ``module.name`` from here
    on (a list, filled as calls go through to the kernel).

    Compared call by call instead of counting the dispatcher's compiled signatures:
    a test that ran earlier in the same process may have compiled another one (any
    order of the tests, any split among workers)."""
    numba = jit.activate()
    kernel = getattr(module, name)
    seen = []

    def record(*args):
        seen.append(tuple(numba.typeof(a) for a in args))
        return kernel(*args)

    monkeypatch.setattr(module, name, record)
    return seen
