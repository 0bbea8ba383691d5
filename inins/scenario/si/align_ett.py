"""An align-ett scenario's method settings in SI (:class:`inins.calibration.ett.EttOptions`)."""

from inins.calibration.ett import EttOptions
from inins.core.units import ARCSEC, DEG, DEG_RTH, UG, UG_RTHZ


def options(scenario):
    """The method settings in SI (:class:`inins.calibration.ett.EttOptions`)."""
    p = scenario.positions

    def scaled(value, unit):
        return None if value is None else value * unit

    return EttOptions(
        vertical_label=p.vertical_label,
        level_label=p.level_label,
        settle=p.settle_s,
        window=p.window_s,
        mat_tb0=scenario.mat_tb0(),
        table_azimuth=scaled(scenario.table_azimuth_deg, DEG),
        table_azimuth_sigma=scenario.table_azimuth_sigma_arcsec * ARCSEC,
        accel_bias_sigma=scenario.accel_bias_sigma_ug * UG,
        accel_vrw=scaled(scenario.accel_vrw_ug_rthz, UG_RTHZ),
        gyro_arw=scaled(scenario.gyro_arw_deg_rth, DEG_RTH),
    )
