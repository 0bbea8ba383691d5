"""A calibrate-imu scenario's table-free detector in SI
(:class:`inins.calibration.tablefree.Detector`)."""

from inins.calibration import tablefree
from inins.core.units import DEG


def tablefree_detector(scenario):
    """The static-interval detector of ``table_free.detector``."""
    d = scenario.table_free.detector
    return tablefree.Detector(
        d.window_s,
        d.init_interval_s,
        d.threshold_factor,
        d.min_interval_s,
        d.max_tilt_change_deg * DEG,
    )
