"""An observability scenario's listed segments and measurement rows in SI
(:mod:`inins.observability.segments`, :mod:`inins.observability.measurements`)."""

import numpy as np

from inins.core import earth, rotation
from inins.core.units import DEG
from inins.observability import measurements as meas
from inins.observability.segments import make_segment


def measurement(m, index):
    """A scenario measurement as a :class:`inins.observability.measurements.Measurement`."""
    return meas.Measurement(
        kind=m.kind,
        sigma=m.sigma,
        baseline_b=m.baseline_b_m,
        lever_arm_b=m.lever_arm_b_m,
        reference=m.reference,
        key=f"measurements[{index}]",
    )


def listed_segments(scenario, los_n):
    """The scenario's ``segments:`` as :class:`inins.observability.segments.Segment` objects."""
    lla = scenario.site.lla()
    out = []
    for i, s in enumerate(scenario.segments):
        mat_nb = rotation.mat_from_euler(s.roll_deg * DEG, s.pitch_deg * DEG, s.heading_deg * DEG)
        if s.vel_n_mps is not None:
            vel = np.array(s.vel_n_mps, dtype=float)
        elif s.speed_mps is not None:
            h = s.heading_deg * DEG
            vel = s.speed_mps * np.array([np.cos(h), np.sin(h), 0.0])
        else:
            vel = np.zeros(3)
        omega = None
        if s.omega_b_dps is not None:
            w_in = earth.rate_ie_n(lla[0]) + earth.rate_en_n(lla[0], lla[2], vel)
            omega = mat_nb.T @ w_in + np.array(s.omega_b_dps) * DEG
        out.append(
            make_segment(
                s.duration_s,
                lla,
                mat_nb=mat_nb,
                vel_n=vel,
                f_b=s.f_b_mps2,
                omega_ib_b=omega,
                los_n=los_n,
                key=f"segments[{i}]",
            )
        )
    return tuple(out)
