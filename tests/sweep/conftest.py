"""Shared pieces of the sweep tests: tiny scenarios and a sweep-file writer."""

from pathlib import Path

import pytest
import yaml

HERE = Path(__file__).resolve().parent
TINY_SIMULATE = HERE / "tiny-simulate.yaml"
TINY_CALIBRATE = HERE / "tiny-calibrate.yaml"


def write_sweep(folder: Path, name: str = "sweep.yaml", **content) -> Path:
    """Write a sweep file ``folder/name`` from keyword content; return its path."""
    path = Path(folder) / name
    path.write_text(yaml.safe_dump(content, sort_keys=False), encoding="utf-8")
    return path


@pytest.fixture
def sim_sweep(tmp_path):
    """A 3 x 2 grid over the tiny simulate-table scenario (a factory of sweep files)."""

    def make(**extra):
        content = {
            "command": "simulate-table",
            "base": str(TINY_SIMULATE),
            "grid": {"motion.0.duration_s": [1, 2, 3], "imu.sample_rate_hz": [10, 20]},
        }
        content.update(extra)
        return write_sweep(tmp_path, **content)

    return make


@pytest.fixture(scope="session")
def pool():
    """Two local workers kept for the whole test session (each starts once)."""
    from inins.sweep.executors import LocalExecutor

    executor = LocalExecutor(2, None, keep_open=True)
    yield executor
    executor.close()
