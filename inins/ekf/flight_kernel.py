"""Compiled truth of a simulated flight: body rates and their quadrature, point by point.

The same equations as :class:`inins.ekf.flight.FlightTruth` and
:class:`inins.ekf.flight.Dithered` (their docstrings), evaluated per time in one
pass instead of as some forty numpy array operations over a block: the
:class:`inins.core.flight.SmoothVelocity` sum over the steps near each time (the
finished ones enter through prefix sums, steps further than 37 time constants
are saturated as in the numpy sum), the bank, flight-path and track angles and
their rates, ``acc_n``, ``omega_ib_b = omega_nb_b + mat_bn (omega_ie_n +
omega_en_n)`` and ``f_b = mat_bn (acc_n + (2 omega_ie_n + omega_en_n) x vel_n -
g_n)``, then the dither rotation. :func:`integrals` sums the Gauss-Legendre
nodes of each sample interval without storing the node rates
(``tests/core/test_flight_truth.py`` compares with the complex-step truth).

Parameter arrays (built by :attr:`inins.ekf.flight.FlightTruth.kernel_params`):
``centres``, ``taus`` (m,) and ``dv`` (m, 3): the velocity steps in centre order;
``prefix`` (m + 1, 6): sums of ``dv_k`` and ``t_k dv_k`` over the steps before;
``plan`` (16,): ``[v0 (3), lat0, lon0, h0, scale (3), heading, aoa, reach, cos aoa,
sin aoa, cos heading, sin heading]``; ``dither`` (10,): ``[amplitude, 2 pi f, phase,
axis (3), lever (3), on]``.
"""

import math

import numpy as np

from inins.core import earth, jit

_SATURATED = 37.0  # as inins.core.flight: |x| > 37, sigma is 0 or 1 in double
_SPEED_FLOOR = 1e-3  # as inins.ekf.flight
_TRACK_FLOOR = 1e-9

_INV_GAMMA_E = 1.0 / earth.GAMMA_E

_gravity_of_sin2 = jit.njit(cache=True)(earth.gravity_of_sin2)


@jit.njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _velocity(t, centres, taus, dv, prefix, plan, kin, position):
    """Velocity sum at ``t`` into ``kin``: ``[disp (3), vel (3), acc (3), jerk (3)]``
    (the displacement only if ``position``)."""
    reach = plan[11]
    lo = np.searchsorted(centres, t - reach)
    hi = np.searchsorted(centres, t + reach)
    # folded constants: every step before lo is finished (as in SmoothVelocity._terms)
    v0n = plan[0] + prefix[lo, 0]
    v0e = plan[1] + prefix[lo, 1]
    v0d = plan[2] + prefix[lo, 2]
    p0n = prefix[lo, 3]
    p0e = prefix[lo, 4]
    p0d = prefix[lo, 5]
    dn = de = dd = 0.0  # displacement terms
    vn = ve = vd = 0.0
    an = ae = ad = 0.0
    jn = je = jd = 0.0
    for k in range(lo, hi):
        tk = centres[k]
        tau = taus[k]
        x = (t - tk) / tau
        sn, se, sd = dv[k, 0], dv[k, 1], dv[k, 2]
        if x > _SATURATED:
            v0n += sn
            v0e += se
            v0d += sd
            p0n += tk * sn
            p0e += tk * se
            p0d += tk * sd
            continue
        if x < -_SATURATED:
            continue
        if x > 0.0:
            e = math.exp(-x)
            inv = 1.0 / (1.0 + e)
            sigma = inv
            lin = x
        else:
            e = math.exp(x)
            inv = 1.0 / (1.0 + e)
            sigma = e * inv
            lin = 0.0
        dsigma = e * inv * inv / tau
        ddsigma = dsigma * (1.0 - 2.0 * sigma) / tau
        if position:
            soft = (lin + math.log1p(e)) * tau
            dn += soft * sn
            de += soft * se
            dd += soft * sd
        vn += sigma * sn
        ve += sigma * se
        vd += sigma * sd
        an += dsigma * sn
        ae += dsigma * se
        ad += dsigma * sd
        jn += ddsigma * sn
        je += ddsigma * se
        jd += ddsigma * sd
    if position:
        kin[0] = t * v0n - p0n + dn
        kin[1] = t * v0e - p0e + de
        kin[2] = t * v0d - p0d + dd
    kin[3], kin[4], kin[5] = vn + v0n, ve + v0e, vd + v0d
    kin[6], kin[7], kin[8] = an, ae, ad
    kin[9], kin[10], kin[11] = jn, je, jd


@jit.njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _body(t, kin, plan, dither, out, row, lat_ref):
    """``omega_ib_b`` into ``out[row, 0:3]`` and ``f_b`` into ``out[row, 3:6]`` at ``t``
    from the velocity sum ``kin`` (:func:`_velocity`). ``lat_ref``: ``[lat, sin lat,
    cos lat]`` of a nearby latitude (NaN: none); within 1e-4 rad of it the sine and
    cosine are its own by the angle sum (series to ``eps^3``, exact to rounding)."""
    disp_n, disp_d = kin[0], kin[2]
    vn, ve, vd = kin[3], kin[4], kin[5]
    an, ae, ad = kin[6], kin[7], kin[8]
    jn, je = kin[9], kin[10]

    # kinematics (FlightTruth._kinematics)
    lat = plan[3] + plan[6] * disp_n
    h = plan[5] + plan[8] * disp_d
    rate0 = plan[6] * vn
    rate1 = plan[7] * ve
    rate2 = plan[8] * vd
    acc0 = plan[6] * an
    acc1 = plan[7] * ae
    acc2 = plan[8] * ad
    ground = math.sqrt(vn * vn + ve * ve + _SPEED_FLOOR**2)
    i_ground = 1.0 / ground  # divisions hoisted: the chain is latency-bound
    turn = vn * ae - ve * an
    # roll atan(u), pitch atan(w) + aoa, heading the track angle of (t_n, t_e): only
    # their sines and cosines enter, in closed form
    u = turn * i_ground * _INV_GAMMA_E
    cr = 1.0 / math.sqrt(1.0 + u * u)
    sr = u * cr
    w = -vd * i_ground
    cw = 1.0 / math.sqrt(1.0 + w * w)
    sw = w * cw
    cp = cw * plan[12] - sw * plan[13]
    sp = sw * plan[12] + cw * plan[13]
    t_n = vn + _TRACK_FLOOR * plan[14]
    t_e = ve + _TRACK_FLOOR * plan[15]
    i_track = 1.0 / math.sqrt(t_n * t_n + t_e * t_e)
    ch, sh = t_n * i_track, t_e * i_track
    d_ground = (vn * an + ve * ae) * i_ground
    du = ((vn * je - ve * jn) - turn * d_ground * i_ground) * i_ground * _INV_GAMMA_E
    dw = (-ad + vd * d_ground * i_ground) * i_ground
    dr = du * cr * cr  # d/dt atan(u) = u' / (1 + u^2)
    dp = dw * cw * cw
    dh = (t_n * ae - t_e * an) * i_track * i_track

    # acc_n and vel_n (FlightTruth.rates)
    eps = lat - lat_ref[0]
    if abs(eps) < 1e-4:
        cos_e = 1.0 - 0.5 * eps * eps
        sin_e = eps - eps * eps * eps / 6.0
        s = lat_ref[1] * cos_e + lat_ref[2] * sin_e
        c = lat_ref[2] * cos_e - lat_ref[1] * sin_e
    else:
        s, c = math.sin(lat), math.cos(lat)
    s2 = s * s
    root = math.sqrt(1.0 - earth.E2 * s2)
    i_root2 = 1.0 / (root * root)
    re = earth.A * root * i_root2
    rn = re * (1.0 - earth.E2) * i_root2
    q = earth.E2 * s * c * i_root2
    d_rn = 3.0 * rn * q * rate0
    d_re = re * q * rate0
    fa0 = (d_rn + rate2) * rate0 + (rn + h) * acc0
    fa1 = ((d_re + rate2) * c - (re + h) * s * rate0) * rate1 + (re + h) * c * acc1
    fa2 = -acc2
    vel0 = (rn + h) * rate0
    vel1 = (re + h) * c * rate1
    vel2 = -rate2

    # mat_nb = Rz(heading) Ry(pitch) Rx(roll) (rotation.mat_from_euler)
    m00, m01, m02 = ch * cp, ch * sp * sr - sh * cr, ch * sp * cr + sh * sr
    m10, m11, m12 = sh * cp, sh * sp * sr + ch * cr, sh * sp * cr - ch * sr
    m20, m21, m22 = -sp, cp * sr, cp * cr

    # omega_nb_b (trajectory.euler_rates_to_body)
    onb0 = dr - dh * sp
    onb1 = dp * cr + dh * sr * cp
    onb2 = -dp * sr + dh * cr * cp

    # body_rates: Earth and transport rate, Coriolis, gravity
    wie0 = earth.RATE * c
    wie2 = -earth.RATE * s
    i_re = 1.0 / (re + h)
    wen0 = vel1 * i_re
    wen1 = -vel0 / (rn + h)
    wen2 = -vel1 * (s / c) * i_re
    wn0, wn1, wn2 = wie0 + wen0, wen1, wie2 + wen2
    om0 = onb0 + m00 * wn0 + m10 * wn1 + m20 * wn2
    om1 = onb1 + m01 * wn0 + m11 * wn1 + m21 * wn2
    om2 = onb2 + m02 * wn0 + m12 * wn1 + m22 * wn2
    cw0, cw1, cw2 = 2.0 * wie0 + wen0, wen1, 2.0 * wie2 + wen2
    g = _gravity_of_sin2(s2, root, h)
    fn0 = fa0 + (cw1 * vel2 - cw2 * vel1)
    fn1 = fa1 + (cw2 * vel0 - cw0 * vel2)
    fn2 = fa2 + (cw0 * vel1 - cw1 * vel0) - g
    f0 = m00 * fn0 + m10 * fn1 + m20 * fn2
    f1 = m01 * fn0 + m11 * fn1 + m21 * fn2
    f2 = m02 * fn0 + m12 * fn1 + m22 * fn2

    if dither[9] == 0.0:
        out[row, 0], out[row, 1], out[row, 2] = om0, om1, om2
        out[row, 3], out[row, 4], out[row, 5] = f0, f1, f2
        return
    # dither (Dithered.rates): back(v) = v cos - sin (u x v) + (1 - cos) (u . v) u
    amp, freq = dither[0], dither[1]
    arg = freq * t + dither[2]
    sa, ca = math.sin(arg), math.cos(arg)
    theta, theta_d, theta_dd = amp * sa, amp * freq * ca, -amp * freq * freq * sa
    ux, uy, uz = dither[3], dither[4], dither[5]
    lx, ly, lz = dither[6], dither[7], dither[8]
    cth, sth = math.cos(theta), math.sin(theta)
    one = 1.0 - cth
    urx, ury, urz = uy * lz - uz * ly, uz * lx - ux * lz, ux * ly - uy * lx
    uux, uuy, uuz = uy * urz - uz * ury, uz * urx - ux * urz, ux * ury - uy * urx
    dot = om0 * ux + om1 * uy + om2 * uz
    out[row, 0] = om0 * cth - sth * (uy * om2 - uz * om1) + one * dot * ux + theta_d * ux
    out[row, 1] = om1 * cth - sth * (uz * om0 - ux * om2) + one * dot * uy + theta_d * uy
    out[row, 2] = om2 * cth - sth * (ux * om1 - uy * om0) + one * dot * uz + theta_d * uz
    dot = f0 * ux + f1 * uy + f2 * uz
    rr = theta_d * theta_d
    out[row, 3] = f0 * cth - sth * (uy * f2 - uz * f1) + one * dot * ux + theta_dd * urx + rr * uux
    out[row, 4] = f1 * cth - sth * (uz * f0 - ux * f2) + one * dot * uy + theta_dd * ury + rr * uuy
    out[row, 5] = f2 * cth - sth * (ux * f1 - uy * f0) + one * dot * uz + theta_dd * urz + rr * uuz


@jit.njit(cache=True, nogil=True, error_model="numpy")
def rates(time, centres, taus, dv, prefix, plan, dither):
    """``[omega_ib_b, f_b]`` (n, 6) (rad/s, m/s^2) at ``time`` (n,) s."""
    out = np.empty((time.size, 6))
    kin = np.empty(12)
    no_ref = np.full(3, np.nan)
    for i in range(time.size):
        _velocity(time[i], centres, taus, dv, prefix, plan, kin, True)
        _body(time[i], kin, plan, dither, out, i, no_ref)
    return out


@jit.njit(cache=True, nogil=True, error_model="numpy")
def states(time, centres, taus, dv, prefix, plan):
    """``[lla (rad, rad, m), vel_n (m/s), roll, pitch, heading (rad)]`` (n, 9) at ``time``
    (n,) s: position ``lla0 + scale p(t)``, ``vel_n = [(R_N + h) lat', (R_E + h) cos(lat)
    lon', -h']``, the bank, flight-path (plus angle of attack) and track angles."""
    out = np.empty((time.size, 9))
    kin = np.empty(12)
    for i in range(time.size):
        _velocity(time[i], centres, taus, dv, prefix, plan, kin, True)
        lat = plan[3] + plan[6] * kin[0]
        h = plan[5] + plan[8] * kin[2]
        out[i, 0], out[i, 1], out[i, 2] = lat, plan[4] + plan[7] * kin[1], h
        vn, ve, vd = kin[3], kin[4], kin[5]
        an, ae = kin[6], kin[7]
        s2 = math.sin(lat) ** 2
        root = math.sqrt(1.0 - earth.E2 * s2)
        re = earth.A / root
        rn = re * (1.0 - earth.E2) / (root * root)
        out[i, 3] = (rn + h) * (plan[6] * vn)
        out[i, 4] = (re + h) * math.cos(lat) * (plan[7] * ve)
        out[i, 5] = -(plan[8] * vd)
        ground = math.sqrt(vn * vn + ve * ve + _SPEED_FLOOR**2)
        out[i, 6] = math.atan((vn * ae - ve * an) / ground / earth.GAMMA_E)
        out[i, 7] = math.atan(-vd / ground) + plan[10]
        t_n = vn + _TRACK_FLOOR * plan[14]
        t_e = ve + _TRACK_FLOOR * plan[15]
        track = math.sqrt(t_n * t_n + t_e * t_e)
        if t_n > 0.0:
            out[i, 8] = 2.0 * math.atan(t_e / (track + t_n))
        else:
            out[i, 8] = math.pi + 2.0 * math.atan(-t_e / (track - t_n))
    return out


@jit.njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _logistic(xi, i_tau):
    """One velocity step's logistic at ``xi = (t - t_k) / tau``: ``exp(-|xi|)``, the step
    fraction ``sigma`` and its first and second time derivatives (``i_tau = 1 / tau``)."""
    e = math.exp(-abs(xi))
    inv = 1.0 / (1.0 + e)
    sigma = inv if xi > 0.0 else e * inv
    dsigma = e * inv * inv * i_tau
    return e, sigma, dsigma, dsigma * (1.0 - 2.0 * sigma) * i_tau


@jit.njit(cache=True, nogil=True, error_model="numpy")
def integrals(start, stop, x, w, centres, taus, dv, prefix, plan, dither, klass, class_taus):
    """Gauss-Legendre integrals ``[dtheta, dv]`` (n, 6) of the rates over
    ``[start_k, stop_k]`` (rule nodes ``x``, weights ``w`` on [-1, 1]).

    Per interval, as :class:`inins.core.flight.SmoothVelocity` does per block: the
    steps saturated over the whole interval are folded into the constant and linear
    parts, the others (``live``) summed at every node. The logistic terms are
    computed at the interval's centre; at a node ``mid + d``, for a step whose centre
    is outside the interval, ``exp(-|x|)`` is the centre's times ``exp(-+d / tau)``
    (one ``exp`` per distinct ``tau`` and node, for every interval of the same
    length: a relative change of a few units in the last place; the few steps
    centred inside the interval are evaluated directly), and the displacement
    (which enters the rates only through gravity, the radii and the Earth and
    transport rates) the Taylor series about the centre to the jerk term
    (remainder ``|snap| d^4 / 24``: < 1e-12 m for 200 Hz samples, below the rounding
    of the displacement itself). ``klass`` (m,) indexes each step's ``tau`` in
    ``class_taus``.
    """
    n, m, nodes = start.size, centres.size, x.size
    reach = plan[11]
    out = np.zeros((n, 6))
    node = np.empty((1, 6))
    kin = np.empty(12)
    mid_kin = np.empty(12)
    lat_ref = np.empty(3)
    acc = np.empty(6)
    i_taus = 1.0 / taus
    # the live steps of an interval that stay on one side of their centre over it,
    # packed: exp(-|x|) at the centre, side (1: x > 0), 1 / tau, dv, node factors
    a_e = np.empty(m)
    a_pos = np.empty(m)
    a_it = np.empty(m)
    a_dv = np.empty((m, 3))
    a_shift = np.empty((m, nodes))
    b_idx = np.empty(m, dtype=np.int64)  # those whose centre is inside the interval
    shift = np.empty((class_taus.size, nodes, 2))  # exp(-d / tau), exp(d / tau)
    shift_half = math.nan
    for k in range(n):
        t0, t1 = start[k], stop[k]
        half = 0.5 * (t1 - t0)
        mid = 0.5 * (t1 + t0)
        if half != shift_half:
            shift_half = half
            for c in range(class_taus.size):
                for j in range(nodes):
                    r = half * x[j] / class_taus[c]
                    shift[c, j, 0] = math.exp(-r)
                    shift[c, j, 1] = math.exp(r)
        lo = np.searchsorted(centres, t0 - reach)
        hi = np.searchsorted(centres, t1 + reach)
        v0n = plan[0] + prefix[lo, 0]
        v0e = plan[1] + prefix[lo, 1]
        v0d = plan[2] + prefix[lo, 2]
        p0n = prefix[lo, 3]
        p0e = prefix[lo, 4]
        p0d = prefix[lo, 5]
        dn = de = dd = 0.0
        vn = ve = vd = 0.0
        an = ae = ad = 0.0
        jn = je = jd = 0.0
        na = nb = 0
        for i in range(lo, hi):
            tk, tau, i_tau = centres[i], taus[i], i_taus[i]
            if (t0 - tk) * i_tau > _SATURATED:
                v0n += dv[i, 0]
                v0e += dv[i, 1]
                v0d += dv[i, 2]
                p0n += tk * dv[i, 0]
                p0e += tk * dv[i, 1]
                p0d += tk * dv[i, 2]
                continue
            if not (t1 - tk) * i_tau > -_SATURATED:
                continue
            # the centre of the interval: exact, with the displacement
            xi = (mid - tk) * i_tau
            e, sigma, dsigma, ddsigma = _logistic(xi, i_tau)
            soft = ((xi if xi > 0.0 else 0.0) + math.log1p(e)) * tau
            sn, se, sd = dv[i, 0], dv[i, 1], dv[i, 2]
            dn += soft * sn
            de += soft * se
            dd += soft * sd
            vn += sigma * sn
            ve += sigma * se
            vd += sigma * sd
            an += dsigma * sn
            ae += dsigma * se
            ad += dsigma * sd
            jn += ddsigma * sn
            je += ddsigma * se
            jd += ddsigma * sd
            if t0 > tk or t1 <= tk:  # one side over the interval: packed
                side = 0 if xi > 0.0 else 1
                a_e[na] = e
                a_pos[na] = 1.0 - side
                a_it[na] = i_tau
                a_dv[na, 0], a_dv[na, 1], a_dv[na, 2] = sn, se, sd
                for j in range(nodes):
                    a_shift[na, j] = shift[klass[i], j, side]
                na += 1
            else:
                b_idx[nb] = i
                nb += 1
        mid_kin[0] = mid * v0n - p0n + dn
        mid_kin[1] = mid * v0e - p0e + de
        mid_kin[2] = mid * v0d - p0d + dd
        mid_kin[3], mid_kin[4], mid_kin[5] = vn + v0n, ve + v0e, vd + v0d
        mid_kin[6], mid_kin[7], mid_kin[8] = an, ae, ad
        mid_kin[9], mid_kin[10], mid_kin[11] = jn, je, jd
        lat_ref[0] = plan[3] + plan[6] * mid_kin[0]
        lat_ref[1], lat_ref[2] = math.sin(lat_ref[0]), math.cos(lat_ref[0])
        acc[:] = 0.0
        for j in range(nodes):
            d = half * x[j]
            if d == 0.0:
                _body(mid, mid_kin, plan, dither, node, 0, lat_ref)
                for c in range(6):
                    acc[c] += w[j] * node[0, c]
                continue
            t = mid + d
            vn = ve = vd = 0.0
            an = ae = ad = 0.0
            jn = je = jd = 0.0
            for q in range(na):
                e = a_e[q] * a_shift[q, j]
                inv = 1.0 / (1.0 + e)
                p = a_pos[q]
                sigma = inv * (p + (1.0 - p) * e)  # inv (x > 0) or e inv, exactly
                dsigma = e * inv * inv * a_it[q]
                ddsigma = dsigma * (1.0 - 2.0 * sigma) * a_it[q]
                vn += sigma * a_dv[q, 0]
                ve += sigma * a_dv[q, 1]
                vd += sigma * a_dv[q, 2]
                an += dsigma * a_dv[q, 0]
                ae += dsigma * a_dv[q, 1]
                ad += dsigma * a_dv[q, 2]
                jn += ddsigma * a_dv[q, 0]
                je += ddsigma * a_dv[q, 1]
                jd += ddsigma * a_dv[q, 2]
            for q in range(nb):
                i = b_idx[q]
                i_tau = i_taus[i]
                xi = (t - centres[i]) * i_tau
                e, sigma, dsigma, ddsigma = _logistic(xi, i_tau)
                vn += sigma * dv[i, 0]
                ve += sigma * dv[i, 1]
                vd += sigma * dv[i, 2]
                an += dsigma * dv[i, 0]
                ae += dsigma * dv[i, 1]
                ad += dsigma * dv[i, 2]
                jn += ddsigma * dv[i, 0]
                je += ddsigma * dv[i, 1]
                jd += ddsigma * dv[i, 2]
            for c in range(3):
                kin[c] = mid_kin[c] + d * (
                    mid_kin[3 + c] + d * (0.5 * mid_kin[6 + c] + d * mid_kin[9 + c] / 6.0)
                )
            kin[3], kin[4], kin[5] = vn + v0n, ve + v0e, vd + v0d
            kin[6], kin[7], kin[8] = an, ae, ad
            kin[9], kin[10], kin[11] = jn, je, jd
            _body(t, kin, plan, dither, node, 0, lat_ref)
            for c in range(6):
                acc[c] += w[j] * node[0, c]
        for c in range(6):
            out[k, c] = half * acc[c]
    return out


def warm_up():
    """Compile (or load from the on-disk cache) the three kernels on a one-step flight,
    with the argument types :class:`inins.ekf.flight.FlightTruth` passes (float64 and
    int64, C-contiguous, writable)."""
    time = np.array([0.0, 1.0])
    centres, taus, dv = np.array([0.5]), np.array([2.0]), np.array([[1.0, 0.0, 0.0]])
    prefix = np.zeros((2, 6))
    prefix[1, :3] = dv[0]
    plan = np.zeros(16)
    plan[3], plan[9], plan[11], plan[12], plan[14] = 0.6, 0.0, 75.0, 1.0, 1.0
    plan[6], plan[7], plan[8] = 1.6e-7, 2.0e-7, -1.0
    dither = np.zeros(10)
    rates(time, centres, taus, dv, prefix, plan, dither)
    states(time, centres, taus, dv, prefix, plan)
    x, w = np.array([-0.5, 0.5]), np.array([1.0, 1.0])
    klass, class_taus = np.zeros(1, dtype=np.int64), np.array([2.0])
    integrals(time[:1], time[1:], x, w, centres, taus, dv, prefix, plan, dither, klass, class_taus)
