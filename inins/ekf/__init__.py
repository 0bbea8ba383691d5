"""Tightly coupled INS/GPS extended Kalman filters of paper 003 (run-ekf).

Pure numerics: imports only ``inins.core`` and ``inins.gnss``.

- :mod:`inins.ekf.flight` — flight plans (ground wait, take-off, climbs, straight
  legs, coordinated bank turns; the plan types live in :mod:`inins.core.flight`)
  as analytic truth, RLG dither, the IMU stream through the sensor error model,
  the gyrocompass initial attitude.
- :mod:`inins.ekf.measurements` — :class:`~inins.ekf.measurements.GnssEpoch`, the
  per-epoch input from the GNSS layer, and the nonlinear measurement model.
- :mod:`inins.ekf.config` — :class:`~inins.ekf.config.FilterConfig` (EKF1/EKF2,
  FF/FB, noise, gating, dither window, outages), :class:`~inins.ekf.config.EpochInput`.
- :mod:`inins.ekf.filter` — :func:`~inins.ekf.filter.run_filter`, the streaming run;
  :class:`~inins.ekf.epoch_log.EpochLog`, what it records per epoch;
  :func:`~inins.ekf.scoring.epoch_errors`, the errors against truth, batch by batch.
- :mod:`inins.ekf.sources` — epoch streams: a simulated flight through the GNSS
  layer's receiver simulation, a recording; levelling and the velocity-heading
  initialisation of a recording.
- :mod:`inins.ekf.recorded` — a recording made ready for the filter: GNSS epochs
  during the IMU record, SPP fixes, initial attitude and the IMU position below the
  antenna's first fix.
- :mod:`inins.ekf.loose`, :mod:`inins.ekf.aiding`, :mod:`inins.ekf.smoother` — the
  loosely coupled filter with vehicle aiding, and the RTS smoother of either filter.
- :mod:`inins.ekf.post` — a recorded drive made ready for the loose filter (time
  mapping, resampling, initial state, outages); :mod:`inins.ekf.scoring` — scores of
  a run against a reference or truth.
- :mod:`inins.ekf.result` — :class:`~inins.ekf.result.EkfResult`,
  :class:`~inins.ekf.result.EkfSummary`.
- :mod:`inins.ekf.kernels`, :mod:`inins.ekf.rows`, :mod:`inins.ekf.step` — compiled per-epoch
  numerics: the error model and update, the measurement rows by kind, the fused epoch.
"""
