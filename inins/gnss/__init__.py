"""GNSS measurement layer (spec §6a, docs/gnss.md): broadcast orbits of GPS, GLONASS,
Galileo and BeiDou, signal propagation, pseudorange and range-rate models, single-point
positioning and receiver simulation.

Pure numerics like :mod:`inins.core`: no file I/O, no CLI; imports only
``inins.core`` (and :mod:`inins.exceptions`). Readers of RINEX, the PSINS tc
file and the recorded-flight HDF5 layout live in :mod:`inins.io`
(``rinex_obs``, ``rinex_nav``, ``psins_tc``, ``flight_layout``); they return
plain arrays whose names match the structures below.

Modules
-------
gpstime        GPS (week, seconds of week), calendar conversion, +-302400 s wrap
systems        satellite numbers (100 * system + PRN), per-system GM, Earth rate, carriers
timescales     GST, BDT, GLONASST (UTC(SU) + 3 h, leap seconds) to and from GPS time
glonass        GLONASS state vectors integrated by RK4 (PZ-90.11), clock, selection
broadcast      :class:`~inins.gnss.broadcast.Navigation` of all systems, mixed selection
ephemeris      :class:`~inins.gnss.ephemeris.Ephemeris` (one row per broadcast set), ``select``
orbit          satellite position, velocity, clock and drift (IS-GPS-200 Table 20-IV;
               Galileo, BeiDou incl. the GEO rotation)
propagation    Sagnac, range / range rate / line of sight, elevation and azimuth,
               Saastamoinen troposphere, Klobuchar, ionosphere-free combination
measurements   :class:`~inins.gnss.measurements.Observations` and
               :class:`~inins.gnss.measurements.GnssEpochs` (below), ``attach_satellites``
spp            single-point positioning with fault exclusion, PDOP, velocity
constellation  nominal 24-satellite Walker constellation as ephemeris sets
simulate       receiver on a trajectory: pseudorange, range rate, TCXO clock, lever arm

Measurement structure (what SPP and the EKF consume)
----------------------------------------------------
Measurements of all epochs are stacked row-wise; the rows of epoch ``k`` are
``start[k]:start[k + 1]`` (an epoch may have any number of satellites, none
included). :class:`~inins.gnss.measurements.Observations`:

=============  ===============  ======  =============================================
name           shape            unit    meaning
=============  ===============  ======  =============================================
week           (n_epochs,)      week    GPS week of the epoch
time           (n_epochs,)      s       receive time tag, GPS seconds of week, as the
                                        receiver clock reads it (true time + dt_rx)
start          (n_epochs + 1,)  -       row offsets of each epoch
prn            (m,)             -       satellite number, 100 * system + PRN/slot
                                        (GPS PRNs unchanged; :mod:`~inins.gnss.systems`)
pseudorange    (m,)             m       L1 (C/A or P1) or ionosphere-free P1/P2
signal         (m,)             -       :class:`~inins.gnss.measurements.Signal`:
                                        1 L1 (TGD, ionosphere model), 2 iono-free
range_rate     (m,)             m/s     positive when the range grows; NaN if absent
                                        (Doppler in Hz = -range_rate / LAMBDA_L1)
sigma          (m,)             m       pseudorange 1-sigma stated by the source
snr            (m,)             dB-Hz   NaN if absent
=============  ===============  ======  =============================================

:func:`~inins.gnss.measurements.attach_satellites` adds, per row, the
satellite state at the transmit time ``t_tx = time - P / c - dt_sv``
(:class:`~inins.gnss.measurements.GnssEpochs`): ``sat_pos`` (m, 3) m and
``sat_vel`` (m, 3) m/s in the ECEF frame *of transmit time*, ``sat_clock``
(m,) m = ``c dt_sv`` with the relativistic term and, on L1 rows, ``- c TGD``,
``sat_drift`` (m,) m/s, and ``eph_index`` (rows without a healthy ephemeris
are left out and counted in ``dropped_prn``, ``dropped_count``). A filter
predicts every row with :func:`~inins.gnss.measurements.predict` at its
antenna position ``r`` and velocity ``v`` (ECEF), which is::

    rho, rate, los, s = geometry(sat_pos, sat_vel, r, v)
    P_hat    = rho + b - sat_clock + T(el, h) + I        # b = c dt_rx (m)
    rate_hat = rate + d - sat_drift                      # d = c dt_rx_dot (m/s)
    dP/dr = -los,  d rate/dv = -s * los,  dP/db = 1,  d rate/dd = 1

with ``rho, rate, los, s`` from :func:`~inins.gnss.propagation.geometry`
(Earth rotation during travel applied), ``T`` from
:func:`~inins.gnss.propagation.troposphere_saastamoinen` and ``I`` zero for
ionosphere-free rows (Klobuchar on L1 rows when the navigation data carry it).
In NED, ``dP/dr_n = -(C_en^T los)``; with a lever arm see spec §6a.

The time tag is the receiver's clock reading: the true reception time is
``time - b / c``. :func:`~inins.gnss.simulate.simulate` tags simulated
measurements the same way, so a simulation and a recording look alike.
"""
