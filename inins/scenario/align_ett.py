"""Scenario of ``inins align-ett`` (spec §5, 000 §3.1): where the table data come from,
which holds are the ETT positions, and what is known of the table and the sensors.

The data come from exactly one of

- ``data: table-data.h5`` -- a simulate-table or import-log output, read with
  :func:`inins.io.tabledata.read_table_data`; a relative path is relative to the
  scenario file (:data:`inins.scenario.base.ScenarioPath`);
- ``simulate: {...}`` -- a complete simulate-table scenario without ``seed`` and
  ``checks`` (:class:`inins.scenario.simulate_table.TableSetup`), simulated in
  memory with the run's seed, so that one align-ett scenario is one run of a sweep
  (``--set simulate.imu.accel.bias_ug=20``).

The nominal mounting (``imu_axes``) is design knowledge, not truth: the key, else
``simulate.mount.imu_axes``, else the nearest axis permutation of the estimate itself.
"""

import numpy as np
from pydantic import Field, field_validator

from inins.scenario.base import ScenarioSection as Section
from inins.scenario.simulate_table import DIRECTIONS, Direction, TableSource
from inins.scenario.types import NonNegFloat, PositiveFloat


class Positions(Section):
    """The two ETT positions (000 §3.1) and the windows averaged there."""

    vertical_label: str | None = Field(
        None,
        description="step label of the vertical hold (table pitched 90 deg); null: "
        "the first hold whose platform normal is horizontal",
    )
    level_label: str | None = Field(
        None,
        description="step label of the level hold; null: the first level hold after "
        "the vertical one, else the last before it",
    )
    settle_s: NonNegFloat = Field(
        5.0, description="time skipped at the start of each hold, after the rotation (s)"
    )
    window_s: PositiveFloat | None = Field(
        None, description="averaging window after the settle time (s); null: the rest of the hold"
    )


class AlignEttScenario(TableSource):
    """Azimuth of the IMU on the table from its accelerometers at the pitch-90 deg and level
    positions (equivalent linear transformation, 000 §3.1), compared with gyrocompassing."""

    imu_axes: list[Direction] | None = Field(
        None,
        min_length=3,
        max_length=3,
        description="nominal mounting: table directions of the IMU x, y, z axes (000: "
        "right, forward, up); null: simulate.mount.imu_axes, else the nearest axis "
        "permutation of the estimate",
    )
    positions: Positions = Field(default_factory=Positions)
    table_azimuth_deg: float | None = Field(
        None,
        description="azimuth of the table base from true north replacing the "
        "data's (deg); null: the data's",
    )
    table_azimuth_sigma_arcsec: NonNegFloat = Field(
        0.0, description="1 sigma of the table base azimuth (arcsec)"
    )
    accel_bias_sigma_ug: NonNegFloat = Field(
        10.0, description="1 sigma of each accelerometer bias, for the heading 1 sigma (ug)"
    )
    accel_vrw_ug_rthz: NonNegFloat | None = Field(
        None,
        description="accelerometer velocity random walk (ug/sqrt(Hz)); null: from "
        "the scatter of the data in the windows",
    )
    gyro_arw_deg_rth: NonNegFloat | None = Field(
        None,
        description="gyro angle random walk for the gyrocompass 1 sigma "
        "(deg/sqrt(h)); null: from the scatter of the data",
    )

    @field_validator("imu_axes")
    @classmethod
    def _right_handed(cls, value):
        if value is not None:
            mat = np.array([DIRECTIONS[v] for v in value]).T
            if not np.allclose(mat.T @ mat, np.eye(3)) or np.linalg.det(mat) < 0:
                raise ValueError("the three directions must form a right-handed triad")
        return value

    def mat_tb0(self):
        """Nominal mounting (IMU body -> platform), or None to take it from the estimate."""
        axes = self.imu_axes
        if axes is None and self.simulate is not None:
            axes = self.simulate.mount.imu_axes
        return None if axes is None else np.array([DIRECTIONS[v] for v in axes]).T
