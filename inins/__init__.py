"""inins — calibration and analysis of strapdown inertial navigation systems.

Conventions (written once, followed everywhere)
===============================================

Frames
------
``i``  inertial.
``e``  Earth-centred Earth-fixed, WGS84.
``n``  local level, **North-East-Down** inside the core. Papers written in ENU
       (000) are mapped to NED next to the code that uses them.
``b``  body = accelerometer triad: x along the x accelerometer, y in the plane
       of the x and y accelerometers, z completing a right-handed triad. The
       accelerometer misalignments alpha_xy, alpha_xz, alpha_yz are therefore
       zero by definition (000 Fig. 1, 003 eqs. 2-5).
``t``  rate-table platform (moves with the innermost gimbal).
``m``  mount / IMU case on the anti-vibration mount.

Names
-----
``vec_a`` (or ``omega_ab_c``) is a vector in frame ``a`` (``c``); ``mat_ab``
maps frame ``b`` to frame ``a``: ``vel_n = mat_nb @ vel_b``, so chains cancel
(``mat_ac = mat_ab @ mat_bc``). ``omega_ab_c`` is the rate of frame ``b``
relative to frame ``a`` expressed in ``c``. Quaternions are scalar first,
``quat_nb = [w, x, y, z]`` with ``v_n = quat_nb * v_b * conj(quat_nb)``.
Euler angles are roll, pitch, heading of ``mat_nb`` in z-y-x order,
``mat_nb = Rz(heading) @ Ry(pitch) @ Rx(roll)``, heading clockwise from north.
Time series are stacked on the leading axis: ``(n, 3)``, ``(n, 3, 3)``.

Units
-----
SI and radians inside the core (``rad``, ``rad/s``, ``m/s``, ``m/s^2``, ``s``).
Lab units appear only at the edges (scenario YAML, reports, summary.json), with
the unit as a key suffix: ``_deg``, ``_dph`` (deg/h), ``_deg_rth`` (deg/sqrt(h)),
``_ug``, ``_mg``, ``_ppm``, ``_arcsec``, ``_s``, ``_hz``, ``_m``. Named
conversion constants live in :mod:`inins.core.units` (``DPH`` is one deg/h in
rad/s, so ``bias_rad_s = bias_dph * DPH``).

Errors
------
Attitude error is the phi angle, a nav-frame tilt:
``mat_nb_est = (I - [phi x]) @ mat_nb_true``. Sensor errors are measured minus
true. Navigation errors are estimated minus true. Paper 000 states its
equations with a psi angle in ENU; :mod:`inins.calibration` maps them and a
test proves the mapping on simulated data.

Layers
------
``inins.core`` is pure numerics (numpy, scipy, numba) with no I/O; it never
imports typer, rich, yaml or h5py. Method packages (``table``,
``calibration``) build on it. ``inins.io`` reads and writes scenarios, HDF5,
reports and summaries. ``inins.cli`` is a thin Typer layer: it parses
arguments, calls one plain function and writes its result.
"""

__version__ = "0.1.0"
