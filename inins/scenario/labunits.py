"""Lab units at the scenario edge: key suffixes, SI factors, documentation checks.

A scenario key carries its unit as a suffix (``bias_dph``, ``duration_s``,
spec §2); :data:`UNIT_SUFFIXES` is the table, :func:`unit_of` reads a key,
:func:`to_si` converts a value, and :func:`field_doc_problems` checks that a
scenario model documents every key with its unit.
"""

import re
import typing

from pydantic import BaseModel

from inins.core import units

UNIT_SUFFIXES = {
    "_deg_rth": ("deg/sqrt(h)", units.DEG_RTH),
    "_ug_rthz": ("ug/sqrt(Hz)", units.UG_RTHZ),
    "_arcsec": ("arcsec", units.ARCSEC),
    "_degc": ("degC", None),
    "_deg": ("deg", units.DEG),
    "_dph": ("deg/h", units.DPH),
    "_dps": ("deg/s", units.DPS),
    "_dps2": ("deg/s^2", units.DEG),
    "_ug_s": ("ug*s", units.UG_S),
    "_ug": ("ug", units.UG),
    "_mg": ("mg", units.MG),
    "_ppm": ("ppm", units.PPM),
    "_mps": ("m/s", 1.0),
    "_hz": ("Hz", 1.0),
    "_s": ("s", 1.0),
    "_m": ("m", 1.0),
}
"""Key suffix -> (unit label used in descriptions, factor to SI or None).

Longest suffix wins (``arw_deg_rth`` is deg/sqrt(h), not deg). ``_degc`` is a
temperature in degrees Celsius and has no SI factor (use it as it is). Rates
compose with ``_per_``: ``temp_sens_ug_per_degc`` is ug/degC (SI factor of ug,
a temperature difference being the same in degC and K).
"""


def unit_of(name: str) -> tuple[str, float | None] | None:
    """Unit label and SI factor of a key from its suffix, or None.

    Examples
    --------
    >>> unit_of("bias_dph")[0]
    'deg/h'
    >>> unit_of("temp_sens_dph_per_degc")[0]
    'deg/h/degC'
    >>> unit_of("order") is None
    True
    """
    head, per, tail = name.rpartition("_per_")
    if per:
        top, bottom = unit_of(head), unit_of("_" + tail)
        if top is None or bottom is None:
            return None
        factor = None if top[1] is None else top[1] / (bottom[1] or 1.0)
        return f"{top[0]}/{bottom[0]}", factor
    for suffix in sorted(UNIT_SUFFIXES, key=len, reverse=True):
        if name.endswith(suffix):
            return UNIT_SUFFIXES[suffix]
    return None


def to_si(value, name: str):
    """Convert a lab-unit scenario value to SI using its key's suffix.

    Parameters
    ----------
    value : float or sequence of float
    name : str
        The key, e.g. ``"bias_dph"`` (deg/h -> rad/s).

    Returns
    -------
    float or ndarray
    """
    import numpy as np

    found = unit_of(name)
    if found is None or found[1] is None:
        raise ValueError(f"{name!r} has no lab-unit suffix with an SI factor")
    if isinstance(value, int | float):
        return float(value) * found[1]
    return np.asarray(value, dtype=float) * found[1]


def types_in(annotation) -> set:
    """Every plain type mentioned in an annotation (through unions, lists, ...)."""
    found = {annotation} if isinstance(annotation, type) else set()
    for arg in typing.get_args(annotation):
        found |= types_in(arg)
    return found


def field_doc_problems(model_cls) -> list[str]:
    """Fields of a scenario model (and its nested models) lacking documentation.

    A field needs a ``description``, unless its type is a documented model
    (a class docstring, which the JSON Schema shows). A field whose name ends
    in a unit suffix must state that unit as ``[unit]`` or ``(unit)``.

    Parameters
    ----------
    model_cls : type[pydantic.BaseModel]

    Returns
    -------
    list of str
        One line per problem, ``"Model.field: what is missing"``; empty if
        every key is documented.
    """
    problems: list[str] = []
    _collect_doc_problems(model_cls, problems, set())
    return problems


def _collect_doc_problems(model_cls, problems, seen) -> None:
    if model_cls in seen:
        return
    seen.add(model_cls)
    for name, info in model_cls.model_fields.items():
        text = info.description or ""
        nested = [t for t in types_in(info.annotation) if issubclass(t, BaseModel)]
        documented_model = len(nested) == 1 and (nested[0].__doc__ or "").strip()
        if not text.strip() and not documented_model:
            problems.append(f"{model_cls.__name__}.{name}: no description")
        found = unit_of(name)
        unit_named = {f"[{found[0]}]", f"({found[0]})"} if found else set()
        if found is not None and not nested and not unit_named & _units_in(text):
            problems.append(
                f"{model_cls.__name__}.{name}: description must state the unit "
                f"as [{found[0]}], got {text!r}"
            )
        for sub in nested:
            _collect_doc_problems(sub, problems, seen)


def _units_in(text: str) -> set:
    """Bracketed and parenthesised words of a description."""
    return set(re.findall(r"\[[^\]]*\]|\([^()]*(?:\([^()]*\))?[^()]*\)", text))
