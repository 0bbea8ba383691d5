"""Scenario section ``post.reference:`` of ``inins run-ekf``: an independent reference
trajectory the post-processed run is scored against (:mod:`inins.io.reference_files`
reads it, :func:`inins.ekf.scoring.reference_errors` scores against it).

The file is RTKLIB ``.pos``, a CSV with a header row of named columns (the roles of a
solution CSV, :data:`inins.io.solution_checks.CSV_ROLES`, sigmas not needed, plus
``roll``, ``pitch``, ``heading``), or a 2-D array in a ``.mat`` file (0-based column
indices). Its time system and offset and the lever arm of its point are its own.
"""

from typing import Literal

from pydantic import Field, model_validator

from inins.scenario.base import InputFile
from inins.scenario.base import ScenarioSection as Section
from inins.scenario.types import LeverArm
from inins.scenario.validation import KeyPathError

ATTITUDE_ROLES = ("roll", "pitch", "heading")
"""Column roles of a reference attitude (angle_unit; heading clockwise from north)."""
_SIGMA_ROLES = {"sigma_n", "sigma_e", "sigma_d", "sigma_vn", "sigma_ve", "sigma_vd", "q"}


def reference_role_problem(columns):
    """What is wrong with a reference's role -> column mapping, or None: the solution
    rule (:func:`inins.io.solution_checks.role_problem`, no sigmas needed) on the
    position, velocity and time roles; no sigma or quality roles; the attitude
    roles ``roll``, ``pitch``, ``heading`` all or ``heading`` alone.

    Returns
    -------
    (role, message) or None
    """
    from inins.io.solution_checks import role_problem

    for role in sorted(set(columns) & _SIGMA_ROLES):
        return role, f"a reference has no {role} column (its sigmas and flags are not used)"
    attitude = set(columns) & set(ATTITUDE_ROLES)
    if attitude and attitude != {"heading"} and attitude != set(ATTITUDE_ROLES):
        missing = sorted(set(ATTITUDE_ROLES) - attitude)
        return missing[
            0
        ], f"attitude columns: heading alone, or roll, pitch and heading ({missing} missing)"
    rest = {k: v for k, v in columns.items() if k not in ATTITUDE_ROLES}
    return role_problem(rest, False)


class ReferenceTrajectory(Section):
    """A reference trajectory to score the forward and smoothed solutions against:
    position (and, where the file has them, NED velocity and attitude) of a point of
    the vehicle at its own epochs."""

    file: InputFile = Field(
        description="reference trajectory file (.csv, .pos, .mat, optionally .gz), "
        "relative to this file (path)"
    )
    format: Literal["csv", "rtklib", "mat"] = Field(
        "csv",
        description="csv: a header row of column names (columns); rtklib: an RTKLIB .pos "
        "(its velocity columns where present); mat: a 2-D array mat_variable (file format)",
    )
    mat_variable: str = Field("", description="mat: the array's name (name)")
    columns: dict[str, str | int] = Field(
        default_factory=dict,
        description="csv: role -> column name (mat: 0-based index); roles time, lat, lon, "
        "height (or x, y, z ECEF m), vel_n, vel_e, vel_d or vel_u (m/s), roll, pitch, "
        "heading (angle_unit; heading alone or all three) (column names)",
    )
    angle_unit: Literal["deg", "rad"] = Field(
        "deg", description="csv, mat: unit of lat, lon, roll, pitch and heading (unit)"
    )
    time_scale_s: float = Field(
        1.0, gt=0.0, description="csv, mat: seconds per unit of the time column (s)"
    )
    time_system: Literal["gps", "utc", "unix"] = Field(
        "gps",
        description="csv, mat: what the time column counts: gps seconds since 1980-01-06; "
        "utc seconds on that grid; unix UTC seconds since 1970-01-01 (UTC: the leap "
        "seconds of the date added; a .pos file says UTC in its header) (s)",
    )
    time_offset_s: float = Field(
        0.0,
        ge=-86400.0,
        le=86400.0,
        description="added to every reference time tag after time_scale_s, in its time "
        "system, to put it on the solution file's clock, within a day (s)",
    )
    lever_arm_m: LeverArm = Field(
        (0.0, 0.0, 0.0),
        description="the reference point minus the IMU, body axes, each within 100 m (m)",
    )
    q_flags: list[int] | None = Field(
        None,
        min_length=1,
        description="rtklib: the quality flags of the epochs used as reference (every "
        "epoch: null) (RTKLIB Q)",
    )

    @model_validator(mode="after")
    def _roles(self):
        if self.format == "rtklib":
            if self.columns:
                raise KeyPathError(("columns",), "format rtklib: no columns to map")
            if self.time_system != "gps":
                raise KeyPathError(
                    ("time_system",), "format rtklib: its time system is in the file"
                )
            return self
        if self.q_flags is not None:
            raise KeyPathError(("q_flags",), f"format {self.format}: the file has no flags")
        problem = reference_role_problem(self.columns)
        if problem:
            raise KeyPathError(("columns", problem[0]), problem[1])
        kind = str if self.format == "csv" else int
        for role, column in self.columns.items():
            if not isinstance(column, kind) or (kind is int and column < 0):
                what = "a column name of the header" if kind is str else "a 0-based index"
                raise KeyPathError(("columns", role), f"{self.format}: {what}")
        if self.format == "mat" and not self.mat_variable:
            raise KeyPathError(("mat_variable",), "mat: the name of the array is required")
        return self
