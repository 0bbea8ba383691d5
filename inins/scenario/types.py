"""The scenario type aliases, declared once (every scenario model uses these).

``PositiveFloat``
    A number > 0 (durations, rates, sample rates).
``NonNegFloat``
    A number >= 0 (noise densities, magnitudes).
``Vec3``
    One number (used for all three axes) or three numbers, x y z; becomes a tuple of 3.
``NonNegVec3``
    A :data:`Vec3` of numbers >= 0.
``LeverArm``
    Three numbers, each within 100 m (an antenna farther from its IMU is a unit mistake).
``MountingAngles``
    Roll, pitch, yaw (deg): roll within +-180, pitch within +-90, yaw within +-360.
``Sigma(low, high)``
    A 1-sigma within [low, high] in the key's unit: smaller is a filter that trusts a
    prior it cannot have (1e-300), larger one that says nothing (a heading sigma of 1e9).
"""

from typing import Annotated

from pydantic import AfterValidator, Field


def _three(value):
    if isinstance(value, int | float):
        return (float(value),) * 3
    if len(value) != 3:
        raise ValueError(f"expected one number or a list of 3, got {len(value)} numbers")
    return tuple(float(v) for v in value)


def _non_negative(value):
    if any(v < 0 for v in value):
        raise ValueError("must not be negative")
    return value


PositiveFloat = Annotated[float, Field(gt=0)]
NonNegFloat = Annotated[float, Field(ge=0)]
Vec3 = Annotated[float | list[float], AfterValidator(_three)]
NonNegVec3 = Annotated[Vec3, AfterValidator(_non_negative)]


def Sigma(low: float, high: float):
    """A 1-sigma within ``[low, high]`` (module docstring)."""
    return Annotated[float, Field(ge=low, le=high)]


_Arm = Annotated[float, Field(ge=-100.0, le=100.0)]
LeverArm = tuple[_Arm, _Arm, _Arm]
MountingAngles = tuple[
    Annotated[float, Field(ge=-180.0, le=180.0)],
    Annotated[float, Field(ge=-90.0, le=90.0)],
    Annotated[float, Field(ge=-360.0, le=360.0)],
]
