"""Packaging: every subpackage is listed, and wheels carry the shipped scenarios."""

import tomllib
from pathlib import Path

ROOT = Path(__file__).parents[1]


def test_every_subpackage_is_listed_in_pyproject():
    listed = set(
        tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"]
    )
    found = {
        ".".join(p.parent.relative_to(ROOT).parts)
        for p in (ROOT / "inins").rglob("__init__.py")
        if "__pycache__" not in p.parts
    }
    mapped = {"inins.configs", "inins.data"}  # top-level configs/ and data/
    assert found | mapped == listed


def test_shipped_scenarios_are_found():
    from inins.io.resources import available_configs, config_path

    assert "default" in available_configs("simulate-table")
    assert config_path("simulate-table").is_file()
