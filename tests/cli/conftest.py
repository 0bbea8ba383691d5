"""A fake command registered in a fresh app, with its shipped scenario in tmp."""

import importlib.util
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

from inins.cli import make_app
from inins.commands import CommandSpec
from inins.io import resources

FAKE_MODULE = "inins_test_fake_command"
DEFAULT_YAML = """\
# shipped scenario of the fake command
name: demo
duration_s: 2.0
bias_dph: [0.01, -0.02, 0.0]
checks:
  - abs(err.bias_x_dph) < 0.001
  - n_samples == 200
"""


def _load_fake():
    spec = importlib.util.spec_from_file_location(
        FAKE_MODULE, Path(__file__).with_name("fake_command.py")
    )
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture
def fake_module(monkeypatch):
    """The fake command module, importable as FAKE_MODULE."""
    module = _load_fake()
    monkeypatch.setitem(sys.modules, FAKE_MODULE, module)
    return module


@pytest.fixture
def configs(tmp_path, monkeypatch):
    """A configs/ tree in tmp holding configs/fake/default.yaml."""
    root = tmp_path / "configs"
    (root / "fake").mkdir(parents=True)
    (root / "fake" / "default.yaml").write_text(DEFAULT_YAML)
    monkeypatch.setattr(resources, "configs_root", lambda: root)
    return root


@pytest.fixture
def app(fake_module, configs, monkeypatch):
    """An app with the fake command (plain run) and fake-stream (streaming run)."""
    stream = type(sys)("inins_test_fake_stream")
    stream.SCENARIO_MODEL = fake_module.SCENARIO_MODEL
    stream.run = fake_module.run_streaming
    monkeypatch.setitem(sys.modules, stream.__name__, stream)
    (configs / "fake-stream").mkdir()
    (configs / "fake-stream" / "default.yaml").write_text("name: stream\n")
    return make_app(
        [
            CommandSpec("fake", "A fake command.", module=FAKE_MODULE),
            CommandSpec("fake-stream", "A fake streaming command.", module=stream.__name__),
            CommandSpec("fake-todo", "A command of a later version.", available=False),
        ]
    )


@pytest.fixture
def invoke(app):
    """``invoke(*args)`` -> click Result of ``inins ARGS`` on the fake app."""
    runner = CliRunner()

    def _invoke(*args):
        return runner.invoke(app, [str(a) for a in args])

    return _invoke
