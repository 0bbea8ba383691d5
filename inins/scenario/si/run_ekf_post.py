"""A run-ekf ``post:`` section in SI: the loosely coupled filter's configuration
(:class:`inins.ekf.loose.LooseConfig`) and its post-processing settings
(:class:`inins.ekf.post.PostSettings`)."""

import numpy as np

from inins.core.units import DEG, UG
from inins.ekf import loose, post


def loose_config(p, dt, lever):
    """:class:`~inins.ekf.loose.LooseConfig` of the ``post:`` section ``p``.

    Parameters
    ----------
    p : inins.scenario.run_ekf_post.PostProcess
        The validated section (lab units).
    dt : float
        IMU sample interval (s).
    lever : ndarray, shape (3,)
        IMU-to-antenna lever arm in the body frame (m).
    """
    n = p.noise
    k = n.factor
    s0 = p.initial_sigma
    sigma0 = [s0.position_m] * 3 + [s0.velocity_mps] * 3
    sigma0 += [s0.tilt_deg * DEG] * 2 + [s0.heading_deg * DEG]
    sigma0 += [s0.accel_bias_ug * UG] * 3 + [s0.gyro_bias_dps * DEG] * 3
    sigma0 += [1e-3] * 9 if p.misalignments else []
    cfg = loose.LooseConfig(
        dt=dt,
        misalignments=p.misalignments,
        feedback=p.feedback,
        lever_arm=lever,
        arw=np.full(3, k * n.arw_dps_rthz * DEG),
        vrw=np.full(3, k * n.vrw_ug_rthz * UG),
        gyro_bias_rw=np.full(3, k * n.gyro_bias_walk_dps_rthz * DEG),
        accel_bias_rw=np.full(3, k * n.accel_bias_walk_ug_rthz * UG),
        sigma0=np.array(sigma0),
        time_offset=p.time.state,
        time_offset_sigma=p.time.state_sigma_s,
        time_offset_walk=p.time.state_walk_s_rts,
        gate_probability=p.gate_probability,
        outlier_probability=p.outlier_gate.probability,
        outlier_sigma_scale=p.outlier_gate.sigma_scale,
        reinit_after=p.outlier_gate.reinit_after,
        nhc_sigma=p.aiding.nhc_sigma_mps,
        odometer_sigma=p.aiding.odometer_sigma_mps,
        zupt_sigma=p.aiding.zupt_sigma_mps,
        zaru_sigma=p.aiding.zaru_sigma_dps * DEG,
        mounting=np.radians(p.aiding.mounting_deg),
        stationary_accel=p.aiding.stationary.accel_mps2,
        stationary_gyro=p.aiding.stationary.gyro_dps * DEG,
        stationary_window=p.aiding.stationary.window_s,
    )
    return cfg


def post_settings(p):
    """:class:`~inins.ekf.post.PostSettings` (SI) of the ``post:`` section ``p``."""
    t, o = p.time, p.outages
    return post.PostSettings(
        dt=1.0 / p.imu.rate_hz,
        q_flags=tuple(p.gnss.q_flags),
        sigma_scale={int(q): float(v) for q, v in p.gnss.sigma_scale.items()},
        use_velocity=p.gnss.use_velocity,
        time=post.TimeSettings(
            fit=t.fit == "turn_rate",
            window=t.window_s,
            search=t.search_s,
            model=t.model,
            alpha=t.rate_false_alarm,
            offset=t.offset_s,
            state=t.state,
        ),
        static_window=tuple(p.static_window_s),
        motion_speed=p.motion_speed_mps,
        init_reference=p.init == "reference",
        init_heading_error=p.init_heading_error_deg * DEG,
        lever_arm=np.asarray(p.lever_arm_m, float),
        outages=post.OutageSettings(o.every_s, o.length_s, o.first_s, tuple(o.windows), o.count),
        stationary_windows=None
        if p.aiding.stationary_windows_s is None
        else tuple(p.aiding.stationary_windows_s),
        odometer=p.aiding.odometer_sigma_mps > 0,
        reference_q=p.reference_q,
        score_from=p.score_from_s,
        smooth=p.smoother == "rts",
    )
