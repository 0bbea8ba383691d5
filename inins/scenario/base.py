"""Typed scenario models: the base every command's scenario builds on.

How to write a scenario model
=============================

Subclass :class:`ScenarioModel` for the top level of a command's scenario and
:class:`ScenarioSection` for nested sections. Both are frozen, forbid unknown
keys and reject NaN and infinity. Every field needs a ``description`` (a field
typed as a documented section may rely on the section's docstring); a field
whose name ends in a lab-unit suffix (see :data:`inins.scenario.labunits.UNIT_SUFFIXES`) names that
unit in its description as ``[unit]`` or ``(unit)``. :func:`field_doc_problems`
lists what is missing; the CLI tests run it on every registered command::

    class Gyro(ScenarioSection):
        bias_dph: Vec3 = Field((0.0, 0.0, 0.0), description="Bias per axis [deg/h]")
        arw_deg_rth: NonNegFloat = Field(0.0, description="Angle random walk [deg/sqrt(h)]")

    class Hold(ScenarioSection):
        duration_s: PositiveFloat = Field(description="Time at rest [s]")

The JSON Schema (``inins schema CMD``) carries the description and a ``unit``
entry for every suffixed key. Convert to SI at the edge with :func:`to_si`
(``to_si(gyro.bias_dph, "bias_dph")`` -> rad/s), never in the model.

Types: the aliases of :mod:`inins.scenario.types` (``PositiveFloat``,
``NonNegFloat``, ``Vec3``, ``NonNegVec3``). Numbers given as text
(``"5"``) are accepted, text that is not a number (``"abc"``) and booleans
given for numbers (``true``) are errors.
"""

from pathlib import Path
from typing import Annotated

from pydantic import AfterValidator, BaseModel, ConfigDict, Field, model_validator
from pydantic_core import PydanticCustomError

from inins.exceptions import InputError
from inins.scenario.labunits import (  # noqa: F401 (re-exported: the scenario author's toolbox)
    UNIT_SUFFIXES,
    field_doc_problems,
    to_si,
    types_in,
    unit_of,
)

DEFAULT_SEED = 0
"""Seed used when neither ``--seed`` nor the scenario's ``seed`` is given."""
MAX_MAGNITUDE = 1e15
"""Largest magnitude of a number in a scenario (any lab unit)."""


def _add_units(schema: dict, model: type) -> None:
    """JSON Schema hook: add ``"unit"`` to every suffixed property."""
    for name, prop in schema.get("properties", {}).items():
        found = unit_of(name)
        if found is not None:
            prop.setdefault("unit", found[0])


_NUMERIC_FIELDS: dict = {}  # model class -> names of its number-only fields


def _bool_as_text(value):
    """``True`` -> ``"true"`` (also inside a list), so a number field rejects it."""
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, list | tuple) and any(isinstance(v, bool) for v in value):
        return [str(v).lower() if isinstance(v, bool) else v for v in value]
    return value


class ScenarioSection(BaseModel):
    """Base of every scenario mapping: frozen, no unknown keys, finite numbers."""

    model_config = ConfigDict(
        extra="forbid",
        frozen=True,
        allow_inf_nan=False,
        json_schema_extra=_add_units,
        validate_default=True,
        defer_build=True,
    )

    @model_validator(mode="before")
    @classmethod
    def _no_bool_for_numbers(cls, data):
        """Pydantic takes ``true`` as 1 for a number; make it an error instead.

        A boolean given for a field whose type has numbers but no ``bool`` or
        ``str`` is passed on as the text ``"true"``, which the number parser
        then rejects at the right key path.
        """
        if not isinstance(data, dict):
            return data
        numeric = cls._numeric_fields()
        return {k: _bool_as_text(v) if k in numeric else v for k, v in data.items()}

    @model_validator(mode="after")
    def _no_huge_numbers(self):
        """No number in a scenario exceeds :data:`MAX_MAGNITUDE` (lab units): larger ones
        overflow the arithmetic (a run too long is refused by its estimate instead)."""
        from inins.scenario.validation import KeyPathError

        for name in type(self)._numeric_fields():
            value = getattr(self, name, None)
            values = value if isinstance(value, list | tuple) else [value]
            for i, v in enumerate(values):
                if isinstance(v, float) and abs(v) > MAX_MAGNITUDE:
                    path = (name, i) if isinstance(value, list | tuple) else (name,)
                    raise KeyPathError(path, f"{v:g} is beyond {MAX_MAGNITUDE:g} in magnitude")
        return self

    @classmethod
    def _numeric_fields(cls) -> frozenset:
        fields = _NUMERIC_FIELDS.get(cls)
        if fields is None:
            fields = frozenset(
                name
                for name, info in cls.model_fields.items()
                if (types := types_in(info.annotation)) & {int, float} and not types & {bool, str}
            )
            _NUMERIC_FIELDS[cls] = fields
        return fields


def _check_syntax(expr: str) -> str:
    """Validate one check expression when the scenario is loaded (names come later)."""
    from inins.scenario.checks import CheckSyntaxError, parse_check

    try:
        parse_check(expr)
    except CheckSyntaxError as exc:
        raise PydanticCustomError("check_syntax", "{problem}", {"problem": str(exc)}) from None
    return expr


CheckExpr = Annotated[str, AfterValidator(_check_syntax)]
"""A pass/fail expression (see :mod:`inins.scenario.checks`), syntax-checked on load."""


def _relative_to_scenario(value, info):
    base = (info.context or {}).get("base_dir")
    value = Path(value).expanduser()
    return value if base is None or value.is_absolute() else Path(base) / value


ScenarioPath = Annotated[Path, AfterValidator(_relative_to_scenario)]
"""A file path; a relative path is relative to the scenario file's directory."""


def input_file_problem(path: Path) -> str | None:
    """What is wrong with an input file path (not UTF-8, a directory, missing), or None."""
    try:
        str(path).encode("utf-8")
    except UnicodeEncodeError:
        return "the path is not valid UTF-8"
    if path.is_dir():
        return f"{path} is a directory, expected a file"
    if not path.exists():
        return f"file not found: {path}"
    return None


def loaded_from_file(info) -> bool:
    """True when validation runs in :func:`load_scenario` (a scenario file), where input
    files are checked; a model built in code (a test, a sweep) is not."""
    return bool(info is not None and (info.context or {}).get("check_files"))


def _existing_file(value: Path, info) -> Path:
    """An input file must exist and be a file, checked when the scenario is loaded (so
    the message names the key and line)."""
    if not loaded_from_file(info):
        return value
    problem = input_file_problem(value)
    if problem:
        raise PydanticCustomError("input_file", "{problem}", {"problem": problem})
    return value


InputFile = Annotated[Path, AfterValidator(_relative_to_scenario), AfterValidator(_existing_file)]
"""A :data:`ScenarioPath` that must name an existing file when the scenario is loaded."""


class ScenarioModel(ScenarioSection):
    """Top level of a command's scenario: adds ``seed`` and ``checks``."""

    seed: Annotated[int, Field(ge=0, le=2**63 - 1)] | None = Field(
        None,
        description="Random seed (integer >= 0). --seed overrides it; "
        f"if neither is given the seed is {DEFAULT_SEED}",
    )
    checks: list[CheckExpr] = Field(
        default_factory=list,
        description="Pass/fail criteria on the results, e.g. 'abs(err.beta_x_dph) < 0.002'. "
        "Names are result keys; truth.NAME is the truth, err.NAME = result - truth; "
        "abs, min, max, sqrt, arithmetic, comparisons, and/or/not. A failed check exits 1",
    )


def resolve_seed(cli_seed: int | None, scenario_seed: int | None) -> int:
    """Seed precedence: ``--seed`` > scenario ``seed`` > :data:`DEFAULT_SEED`."""
    if cli_seed is not None:
        return int(cli_seed)
    if scenario_seed is not None:
        return int(scenario_seed)
    return DEFAULT_SEED


def load_scenario(model_cls, path, overrides, default_path):
    """Read, override and validate a scenario.

    Parameters
    ----------
    model_cls : type[ScenarioModel]
        The command's scenario model.
    path : Path or None
        The user's scenario file; None runs ``default_path``.
    overrides : list of str
        ``--set KEY.PATH=VALUE`` items, applied in order. A key missing from
        the file is created (with any missing parent mappings); the model then
        rejects keys it does not know, naming the ``--set`` item. List items
        must already exist.
    default_path : Path
        The packaged default scenario (see :func:`inins.io.resources.config_path`).

    Returns
    -------
    model : ScenarioModel
    text : str
        The scenario text: the file as written if there are no overrides, else
        the YAML of the data after overrides, headed by a comment listing them.
    source : str
        Name of the scenario for messages and provenance.

    Raises
    ------
    InputError
        Any problem, naming the file, key path, line and what was expected.
    """
    from pydantic import ValidationError

    from inins.io.resources import display_name
    from inins.scenario import yaml_source
    from inins.scenario.validation import to_input_error

    source = display_name(default_path) if path is None else str(path)
    text = _read_text(default_path if path is None else path, source)
    data, lines = yaml_source.parse_yaml(text, source)
    set_by = {}
    for item in overrides:
        key_path, value = yaml_source.parse_override(item)
        yaml_source.apply_override(data, key_path, value, item)
        set_by[key_path] = item
    if overrides:
        header = "".join(f"#   --set {item}\n" for item in overrides)
        text = f"# {source} with overrides:\n{header}" + yaml_source.dump_yaml(data)
    try:
        scenario_dir = Path(default_path if path is None else path).resolve().parent
        model = model_cls.model_validate(
            data, context={"base_dir": scenario_dir, "check_files": True}
        )
    except ValidationError as exc:
        raise to_input_error(
            exc, data=data, lines=lines, source=source, model_cls=model_cls, overrides=set_by
        ) from None
    return model, text, source


def _read_text(path, source: str) -> str:
    """Text of a scenario file; every failure is an InputError."""
    from pathlib import Path

    path = Path(path)
    try:
        return path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise InputError("scenario file not found", source=source) from None
    except IsADirectoryError:
        raise InputError("is a directory, expected a YAML scenario file", source=source) from None
    except UnicodeDecodeError as exc:
        raise InputError(
            f"not UTF-8 text ({exc.reason} at byte {exc.start})", source=source
        ) from None
    except OSError as exc:
        raise InputError(f"cannot read scenario: {exc.strerror}", source=source) from None
