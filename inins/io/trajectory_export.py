"""Export of a post-processed trajectory with its 1-sigma: CSV, RTKLIB ``.pos`` and GeoJSON.

Each writer takes a :class:`Trajectory` (SI, on GNSS time as the results label it:
:mod:`inins.ekf.gnss_time`) and returns the file's text; the command writes it through
the atomic output contract (temporary name, renamed when every output is complete).

- CSV (one row an epoch, a header row of named columns): ``gps_week``,
  ``gps_sow_s``, ``utc`` (ISO 8601), ``lat_deg``, ``lon_deg``, ``height_m`` (the
  IMU, ellipsoidal height), ``vel_n_mps``, ``vel_e_mps``, ``vel_d_mps``, ``roll_deg``,
  ``pitch_deg``, ``heading_deg``, then the 1-sigma of each (``sigma_`` prefix).
  The attitude 1-sigma are those of the NED tilt errors ``phi_N, phi_E, phi_D``
  rotated to the heading axes (``sigma_roll^2 = cos^2 psi s_N^2 + sin^2 psi
  s_E^2``, ``sigma_pitch^2 = sin^2 psi s_N^2 + cos^2 psi s_E^2``, heading ``s_D``;
  the tilts' correlation and the pitch's effect on roll are left out).
- RTKLIB ``.pos`` (GPST calendar time, ``latitude(deg) longitude(deg) height(m)``,
  ``Q ns sdn sde sdu`` with zero cross terms, ``vn ve vu`` and their sigmas):
  :func:`inins.io.solution_files.read_rtklib_pos` reads it back. ``Q`` is 1 on every
  epoch (RTKLIB has no flag for an INS solution), ``ns`` 0.
- GeoJSON (RFC 7946): a FeatureCollection, one LineString per solution, coordinates
  ``[lon, lat, height]`` (deg, deg, m), properties naming the solution and its start.

UTC is GPS time minus the leap seconds of the first epoch (a run does not cross a
leap second here).
"""

import io
import json
import math
from dataclasses import dataclass

import numpy as np

from inins.core import rotation

WEEK = 604800.0
_GPS_EPOCH = np.datetime64("1980-01-06T00:00:00", "ns")


def _datetime(seconds):
    """datetime64[ns] of seconds since 1980-01-06 (on the GPS or the UTC grid)."""
    return _GPS_EPOCH + np.round(np.asarray(seconds) * 1e9).astype(np.int64).astype(
        "timedelta64[ns]"
    )


@dataclass(frozen=True, eq=False)
class Trajectory:
    """One solution to export: ``name``; ``gps_seconds`` (m,) GPS seconds since the
    GPS epoch; ``leap`` GPS - UTC (s) or None (no UTC column values); ``lla`` (m, 3) rad,
    rad, m; ``vel`` (m, 3) NED m/s; ``quat`` (m, 4) body to NED; ``sigma`` (m, >= 9)
    1-sigma of the error states in the order position NED (m), velocity NED (m/s),
    tilt NED (rad)."""

    name: str
    gps_seconds: np.ndarray
    leap: float | None
    lla: np.ndarray
    vel: np.ndarray
    quat: np.ndarray
    sigma: np.ndarray

    def week_sow(self):
        week = np.floor(self.gps_seconds / WEEK).astype(np.int64)
        return week, self.gps_seconds - week * WEEK

    def euler(self):
        """Roll, pitch, heading (m, 3) rad."""
        return rotation.euler_from_mat(rotation.mat_from_quat(self.quat))

    def attitude_sigma(self):
        """1-sigma of roll, pitch, heading (m, 3) rad (module docstring)."""
        psi = self.euler()[:, 2]
        sn, se, sd = self.sigma[:, 6], self.sigma[:, 7], self.sigma[:, 8]
        c2, s2 = np.cos(psi) ** 2, np.sin(psi) ** 2
        return np.stack(
            [np.sqrt(c2 * sn**2 + s2 * se**2), np.sqrt(s2 * sn**2 + c2 * se**2), sd], -1
        )

    def utc(self):
        """ISO 8601 UTC strings (m,) (ms), empty where the leap seconds are unknown."""
        if self.leap is None:
            return np.full(self.gps_seconds.size, "")
        when = _datetime(self.gps_seconds - self.leap)
        return np.char.add(np.datetime_as_string(when, unit="ms"), "Z")


CSV_COLUMNS = (
    "gps_week,gps_sow_s,utc,lat_deg,lon_deg,height_m,vel_n_mps,vel_e_mps,vel_d_mps,"
    "roll_deg,pitch_deg,heading_deg,sigma_n_m,sigma_e_m,sigma_d_m,sigma_vel_n_mps,"
    "sigma_vel_e_mps,sigma_vel_d_mps,sigma_roll_deg,sigma_pitch_deg,sigma_heading_deg"
).split(",")
"""The CSV's header row."""


def csv_text(traj):
    """The CSV of one solution (module docstring)."""
    week, sow = traj.week_sow()
    deg = np.degrees
    values = np.column_stack(
        [
            deg(traj.lla[:, :2]),
            traj.lla[:, 2],
            traj.vel,
            deg(traj.euler()),
            traj.sigma[:, :6],
            deg(traj.attitude_sigma()),
        ]
    )
    fmt = ["%.9f"] * 2 + ["%.4f"] + ["%.4f"] * 3 + ["%.5f"] * 3 + ["%.4f"] * 6 + ["%.5f"] * 3
    buf = io.StringIO()
    np.savetxt(buf, values, fmt=fmt, delimiter=",")
    rows = buf.getvalue().splitlines()
    utc = traj.utc()
    out = [",".join(CSV_COLUMNS)]
    out += [f"{w},{s:.3f},{u},{r}" for w, s, u, r in zip(week, sow, utc, rows, strict=True)]
    return "\n".join(out) + "\n"


_POS_HEADER = (
    "%  GPST                  latitude(deg) longitude(deg)  height(m)   Q  ns   sdn(m)   "
    "sde(m)   sdu(m)  sdne(m)  sdeu(m)  sdun(m) age(s)  ratio    vn(m/s)    ve(m/s)    "
    "vu(m/s)      sdvn     sdve     sdvu    sdvne    sdveu    sdvun"
)


def pos_text(traj, program="inins"):
    """The RTKLIB ``.pos`` of one solution (module docstring)."""
    when = _datetime(traj.gps_seconds)
    stamp = np.datetime_as_string(when, unit="ms")
    day = np.char.replace(np.char.partition(stamp, "T")[:, 0], "-", "/")
    clock = np.char.partition(stamp, "T")[:, 2]
    lat, lon = np.degrees(traj.lla[:, 0]), np.degrees(traj.lla[:, 1])
    vel = traj.vel * np.array([1.0, 1.0, -1.0])
    s = traj.sigma
    lines = [
        f"% program   : {program} ({traj.name} INS solution, IMU position)",
        "% Q is 1 on every epoch (an INS solution), ns 0; cross terms 0",
        "% (lat/lon/height=WGS84/ellipsoidal,Q=1:fix,2:float,3:sbas,4:dgps,5:single,6:ppp)",
        _POS_HEADER,
    ]
    for k in range(lat.size):
        lines.append(
            f"{day[k]} {clock[k]} {lat[k]:14.9f} {lon[k]:14.9f} {traj.lla[k, 2]:10.4f}"
            f"   1   0 {s[k, 0]:8.4f} {s[k, 1]:8.4f} {s[k, 2]:8.4f}   0.0000   0.0000   0.0000"
            f"   0.00    0.0 {vel[k, 0]:10.5f} {vel[k, 1]:10.5f} {vel[k, 2]:10.5f}"
            f" {s[k, 3]:8.5f} {s[k, 4]:8.5f} {s[k, 5]:8.5f}  0.00000  0.00000  0.00000"
        )
    return "\n".join(lines) + "\n"


def geojson_text(trajectories):
    """A GeoJSON FeatureCollection, one LineString per solution (module docstring)."""
    features = []
    for t in trajectories:
        coords = np.column_stack([np.degrees(t.lla[:, 1]), np.degrees(t.lla[:, 0]), t.lla[:, 2]])
        week, sow = t.week_sow()
        utc = t.utc()
        features.append(
            {
                "type": "Feature",
                "properties": {
                    "solution": t.name,
                    "epochs": int(coords.shape[0]),
                    "start_gps_week": int(week[0]),
                    "start_gps_sow_s": float(sow[0]),
                    "start_utc": str(utc[0]) or None,
                    "end_utc": str(utc[-1]) or None,
                },
                "geometry": {
                    "type": "LineString",
                    "coordinates": [
                        [round(float(v), 9) for v in c[:2]] + [round(float(c[2]), 4)]
                        for c in coords
                    ],
                },
            }
        )
    finite = all(
        math.isfinite(v) for f in features for c in f["geometry"]["coordinates"] for v in c
    )
    if not finite:
        raise ValueError("non-finite coordinate in a trajectory")
    return json.dumps({"type": "FeatureCollection", "features": features}) + "\n"
