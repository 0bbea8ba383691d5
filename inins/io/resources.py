"""Where the shipped scenarios live: the one place that knows.

Shipped scenarios are ``configs/<command>/<name>.yaml``. In a source checkout
or editable install ``configs/`` sits next to the ``inins/`` package; an
installed wheel may carry it inside the package as ``inins/configs/``. Both are
looked up here, the packaged copy first, and nowhere else.
"""

from pathlib import Path

from inins.exceptions import InputError

_PACKAGE_DIR = Path(__file__).resolve().parent.parent


def configs_root() -> Path:
    """The ``configs`` directory holding the shipped scenarios.

    Returns
    -------
    Path
        ``inins/configs`` if the package carries one, else ``configs`` next
        to the package (a source checkout).
    """
    packaged = _PACKAGE_DIR / "configs"
    if packaged.is_dir():
        return packaged
    return _PACKAGE_DIR.parent / "configs"


def config_path(command: str, name: str = "default") -> Path:
    """Path of the shipped scenario ``configs/<command>/<name>.yaml``.

    Parameters
    ----------
    command : str
        ``"simulate-table"``, ``"calibrate-bias"``, ...
    name : str
        Scenario name without ``.yaml``.

    Returns
    -------
    Path

    Raises
    ------
    InputError
        No such shipped scenario (the message lists those that exist).
    """
    path = configs_root() / command / f"{name}.yaml"
    if not path.is_file():
        known = ", ".join(available_configs(command)) or "none"
        raise InputError(
            f"no shipped scenario '{name}' for {command} (available: {known}); "
            "give a SCENARIO.yaml",
            source=f"configs/{command}/{name}.yaml",
        )
    return path


def available_configs(command: str) -> list[str]:
    """Names of the shipped scenarios of ``command`` (sorted)."""
    folder = configs_root() / command
    return sorted(p.stem for p in folder.glob("*.yaml")) if folder.is_dir() else []


def display_name(path: Path) -> str:
    """A machine-independent name for a shipped scenario (``configs/...``).

    Paths outside the configs directory are returned as given.
    """
    try:
        return "configs/" + Path(path).resolve().relative_to(configs_root().resolve()).as_posix()
    except ValueError:
        return str(path)
