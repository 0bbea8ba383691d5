"""Shared test helpers: shipped scenarios loaded with ``--set``-style overrides."""

import functools
from pathlib import Path

import yaml

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
    ``--set`` items (strings) and keyword updates (``key.path=value``) applied in order.

    Loaded once per process for the same arguments (the models are frozen; Monte Carlo
    tests ask for the same scenario once per seed)."""
    return _shipped(model_cls, relative, (*overrides, *overrides_of(**updates)))


@functools.cache
def _shipped(model_cls, relative, items):
    return load_scenario(model_cls, CONFIGS / relative, list(items), None)[0]
