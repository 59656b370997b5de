r"""The glove chain's per-sample work in one function: a ``mote`` frame in, the OSC datagram out.

For every frame of a read, :func:`chain_frames` does what the nodes of the glove chain do for one sample,
in their order and with their own functions, so that the two ways give the same bits:

============== =======================================================================================
node           here
============== =======================================================================================
offset         the nine counts less their nulls (``Offset.on_adc``, its steady state)
scaling        times the resolutions; the soft-iron and misalignment matrices where the file has them
tqt            :func:`pointat.maths.scalar.time_step`, then :func:`pointat.maths.tqt.step.robust_step`
reference      ``normalize(multiply(offset, q))``
azi_ele        :func:`pointat.maths.scalar.azimuth_elevation` of the pointing axis, the last azimuth held
roll_distance  the same of the hand's x, :func:`pointat.maths.scalar.roll`, then
               :func:`pointat.maths.fusion.roll_distance_step`
osc_out        the profile's fields (:mod:`pointat.osc_bridge.profiles`) as big-endian float32 into the
               message's template (address and type tags encoded once)
============== =======================================================================================

numba compiles it, with every function it calls, into one loop (:mod:`pointat.compiled.build`); run as
plain Python it is the same arithmetic, which the tests use.  The layouts of the arrays are the ``G_*``
(a glove's constants), ``C_*`` (its state beside the filter's) and ``O_*`` (one frame's values, for nodes
outside the chain that listen to it) indices below; :mod:`pointat.compiled` fills and reads them.
"""

from __future__ import annotations

import math

import numpy as np

from pointat.maths.fusion import R_AZ, R_DIST, R_MODE, R_SIZE, roll_distance_step
from pointat.maths.scalar import azimuth_elevation, multiply, roll, time_step
from pointat.maths.tqt.step import F_REST, S_INIT, robust_step
from pointat.osc_bridge.profiles import Source, field_dist, field_dist01, field_el, field_spread, wrap180

__all__ = ["FIELD_CODES", "chain_frames", "field_value"]

# -- a glove's constants (one row of P) -------------------------------------------------------------------
G_NULLS = 0  # 9: offset's nulls
G_FACTOR = 9  # 9: scaling's factors
G_SOFT = 18  # 9: soft-iron matrix, row major
G_ACCM = 27  # 9: accelerometer misalignment
G_GYROM = 36  # 9: gyro misalignment
G_HAS_SOFT, G_HAS_ACCM, G_HAS_GYROM = 45, 46, 47  # 1.0: the matrix applies
G_NOMINAL, G_MAX_GAP = 48, 49  # tqt's clock: 1 / rate, and the longest gap taken as a step
G_REF = 50  # 4: reference's offset quaternion
G_AXIS = 54  # 3: azi_ele's pointing axis
G_DIR_POLE = 57
G_ENTER, G_LEAVE, G_GAIN, G_MAX_EL, G_ROLL_POLE = 58, 59, 60, 61, 62  # roll_distance's
G_RADIUS = 63  # osc_out's radius (dist_m)
G_SIZE = 64

# -- a glove's state beside the filter's (one row of S) ---------------------------------------------------
C_LAST_T = 0  # tqt's last stamp (NaN: none)
C_BITS = 1  # the flags tqt last reported (rest apart)
C_DIR_AZ = 2  # azi_ele's last azimuth (NaN: none)
C_ROLL_AZ = 3  # roll_distance's last pointing azimuth (NaN: none)
C_ROLL = 4  # R_SIZE: roll_distance's state
C_OUT = C_ROLL + R_SIZE  # 4: osc_out's azimuth, elevation, distance, spread
C_FLAGS = C_OUT + 4  # the filter's flags of the last frame
C_SIZE = C_FLAGS + 1

# -- one frame's values (one row of R) ---------------------------------------------------------------------
O_ADC = 0  # 9: offset's output
O_GYRO, O_ACCEL, O_MAG = 9, 12, 15  # 3 each: scaling's
O_QUAT = 18  # 4: tqt's
O_REL = 22  # 4: reference's
O_DIR_AZ, O_DIR_EL = 26, 27  # azi_ele's
O_ROLL_AZ, O_ROLL_DIST = 28, 29  # roll_distance's
O_SIZE = 30

# -- what happened to a frame (bits of ev) -----------------------------------------------------------------
EV_OUT = 1  # the filter is initialised: the frame went all the way (a direction sent)
EV_FLAGS = 2  # tqt's flags changed
EV_MODE = 4  # roll_distance's mode changed
EV_BAD = 8  # a value osc_out refuses (not finite): nothing sent

NOT_REST = ~F_REST

#: osc_out's fields the chain encodes, by the codes the templates use (the others: node by node).
FIELD_CODES = {"az": 1, "az_right": 2, "az360": 3, "el": 4, "dist": 5, "dist01": 6, "dist_m": 7, "spread": 8}


def field_value(code, s):  # type: ignore[no-untyped-def]
    """The field ``code`` (:data:`FIELD_CODES`) of the update ``s``, as :data:`pointat.osc_bridge.profiles.FIELDS`
    works it out."""
    if code == 1:
        return wrap180(s.az)
    if code == 2:
        return wrap180(-s.az)
    if code == 3:
        return s.az % 360.0
    if code == 4:
        return field_el(s)
    if code == 5:
        return field_dist(s)
    if code == 6:
        return field_dist01(s)
    if code == 7:
        return s.radius * field_dist01(s)
    return field_spread(s)


def _matrix(v, p, at, x, y, z):  # type: ignore[no-untyped-def]
    """``v[0:3] = M (x, y, z)`` for the row-major matrix at ``p[at:at + 9]``, as scaling writes it out."""
    v[0] = p[at] * x + p[at + 1] * y + p[at + 2] * z
    v[1] = p[at + 3] * x + p[at + 4] * y + p[at + 5] * z
    v[2] = p[at + 6] * x + p[at + 7] * y + p[at + 8] * z


def chain_frames(idx, counts, times, spread, P, S, TS, TP, R, ev, flags, buf, tmpl, tlen, slot, code):  # type: ignore[no-untyped-def]
    """Frames ``f`` of gloves ``idx[f]`` (``counts`` (F, 9), ``times`` (F,), and osc_out's ``spread`` as
    it was when the frame came), in order, through the chain.

    ``P`` (G, :data:`G_SIZE`) a glove's constants, ``S`` (G, :data:`C_SIZE`), ``TS`` and ``TP`` (the
    filter's state and parameters) its state, changed in place.  Out per frame: ``R`` (F, :data:`O_SIZE`)
    the values between the nodes, ``ev`` (F,) the ``EV_*`` bits, ``flags`` (F,) the filter's flags, and
    ``buf[f, :tlen[g]]`` the datagram: the glove's template ``tmpl[g]`` with each field ``code[g, k]`` at
    byte ``slot[g, k]`` (-1 ends them).
    """
    f32 = np.zeros(1, np.float32)
    u32 = f32.view(np.uint32)
    v = np.zeros(3)
    for f in range(idx.shape[0]):
        g = idx[f]
        p = P[g]
        st = S[g]
        r = R[f]
        e = 0
        c = counts[f]
        for i in range(9):  # offset
            r[O_ADC + i] = c[i] - p[G_NULLS + i]
        d = r[O_ADC : O_ADC + 9]
        mx, my, mz = d[6] * p[G_FACTOR + 6], d[7] * p[G_FACTOR + 7], d[8] * p[G_FACTOR + 8]  # scaling
        if p[G_HAS_SOFT] != 0.0:
            _matrix(v, p, G_SOFT, mx, my, mz)
            mx, my, mz = v[0], v[1], v[2]
        ax, ay, az = d[3] * p[G_FACTOR + 3], d[4] * p[G_FACTOR + 4], d[5] * p[G_FACTOR + 5]
        if p[G_HAS_ACCM] != 0.0:
            _matrix(v, p, G_ACCM, ax, ay, az)
            ax, ay, az = v[0], v[1], v[2]
        gx, gy, gz = d[0] * p[G_FACTOR], d[1] * p[G_FACTOR + 1], d[2] * p[G_FACTOR + 2]
        if p[G_HAS_GYROM] != 0.0:
            _matrix(v, p, G_GYROM, gx, gy, gz)
            gx, gy, gz = v[0], v[1], v[2]
        r[O_MAG], r[O_MAG + 1], r[O_MAG + 2] = mx, my, mz
        r[O_ACCEL], r[O_ACCEL + 1], r[O_ACCEL + 2] = ax, ay, az
        r[O_GYRO], r[O_GYRO + 1], r[O_GYRO + 2] = gx, gy, gz
        t = times[f]  # tqt
        dt = time_step(st[C_LAST_T], t, p[G_NOMINAL], p[G_MAX_GAP])
        st[C_LAST_T] = t
        s = TS[g]
        fl = robust_step(s, TP[g], gx, gy, gz, ax, ay, az, mx, my, mz, dt)
        flags[f] = fl
        st[C_FLAGS] = fl
        bits = fl & NOT_REST
        if bits != st[C_BITS]:
            st[C_BITS] = bits
            e |= EV_FLAGS
        if s[S_INIT] == 0.0:
            ev[f] = e
            continue
        q = (s[0], s[1], s[2], s[3])
        r[O_QUAT], r[O_QUAT + 1], r[O_QUAT + 2], r[O_QUAT + 3] = q
        w, x, y, z = multiply((p[G_REF], p[G_REF + 1], p[G_REF + 2], p[G_REF + 3]), q)  # reference
        n = math.sqrt(w * w + x * x + y * y + z * z)
        if not (n > 0.0 and math.isfinite(n)):
            ev[f] = e | EV_BAD
            continue
        rel = (w / n, x / n, y / n, z / n)
        r[O_REL], r[O_REL + 1], r[O_REL + 2], r[O_REL + 3] = rel
        prev = st[C_DIR_AZ]  # azi_ele
        daz, el = azimuth_elevation(
            rel, (p[G_AXIS], p[G_AXIS + 1], p[G_AXIS + 2]), 0.0 if prev != prev else prev, p[G_DIR_POLE]
        )
        st[C_DIR_AZ] = daz
        r[O_DIR_AZ], r[O_DIR_EL] = daz, el
        prev = st[C_ROLL_AZ]  # roll_distance
        raz, rel_el = azimuth_elevation(rel, (1.0, 0.0, 0.0), 0.0 if prev != prev else prev, p[G_ROLL_POLE])
        st[C_ROLL_AZ] = raz
        rs = st[C_ROLL : C_ROLL + R_SIZE]
        mode = rs[R_MODE]
        roll_distance_step(
            rs, raz, math.degrees(roll(rel)), rel_el, p[G_ENTER], p[G_LEAVE], p[G_GAIN], p[G_MAX_EL]
        )
        if rs[R_MODE] != mode:
            e |= EV_MODE
        az_out, dist = rs[R_AZ], rs[R_DIST]
        r[O_ROLL_AZ], r[O_ROLL_DIST] = az_out, dist
        if not math.isfinite(az_out + el + dist):  # osc_out refuses it; the last good values stay
            ev[f] = e | EV_BAD
            continue
        st[C_OUT], st[C_OUT + 1], st[C_OUT + 2], st[C_OUT + 3] = az_out, el, dist, spread[f]  # osc_out
        src = Source(0, az_out, el, dist, spread[f], p[G_RADIUS])
        b = buf[f]
        b[: tlen[g]] = tmpl[g, : tlen[g]]
        for k in range(slot.shape[1]):
            at = slot[g, k]
            if at < 0:
                break
            f32[0] = field_value(code[g, k], src)
            bits32 = u32[0]
            b[at] = (bits32 >> 24) & 255
            b[at + 1] = (bits32 >> 16) & 255
            b[at + 2] = (bits32 >> 8) & 255
            b[at + 3] = bits32 & 255
        ev[f] = e | EV_OUT


def crc16(b, start, stop):  # type: ignore[no-untyped-def]
    """CRC-16/CCITT-FALSE of ``b[start:stop]`` (:func:`pointat.devices.mote_frame.crc16_ccitt_false`)."""
    crc = 0xFFFF
    for j in range(start, stop):
        crc ^= np.int64(b[j]) << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1021) & 0xFFFF if crc & 0x8000 else (crc << 1) & 0xFFFF
    return crc


def scan_plain(b, pos, end, last, held, plain_of, clock, rate, idx, counts, times, per_mote, n0):  # type: ignore[no-untyped-def]
    """Take the plain binary mote frames at ``b[pos:end]`` into the fused chains' arrays, up to the first
    that is not plain; returns (frames taken, the position after them).

    Plain: a whole frame (sync bytes, checksum, zero padding) of a mote ``m`` whose chain takes it
    (``plain_of[m]``, -1 for none), its packet counter the parser's last one plus one (``last[m]``, -1 for
    a mote not seen yet), its clock started.  What :class:`~pointat.devices.mote_frame.FrameParser` and
    the ``mote`` node do with such a frame, for it: ``last`` and the mote's clock (``clock`` rows t0,
    count, last counter; :class:`nodes.sensors._MoteClock`) move on, the frame's chain, counts and time
    go to ``idx``, ``counts``, ``times`` from ``n0`` on, and ``per_mote[m]`` counts it.  Anything else
    (a lost packet, a restart, a new or unknown mote, a damaged frame) is left to them, and so are the
    frames of a mote the parser ``held`` (one of its frames went the parser's way in this read already)."""
    k = 0
    cap = idx.shape[0]
    while pos + 21 <= end and n0 + k < cap:
        if b[pos] != 0xA5 or b[pos + 1] != 0x5A:
            break
        if crc16(b, pos + 2, pos + 19) != (np.int64(b[pos + 19]) << 8 | np.int64(b[pos + 20])):
            break
        if b[pos + 17] & 0xF0:
            break
        m = np.int64(b[pos + 2])
        g = plain_of[m]
        n = np.int64(b[pos + 3]) << 8 | np.int64(b[pos + 4])
        t0 = clock[0, m]
        if g < 0 or held[m] or last[m] < 0 or n != ((last[m] + 1) & 0xFFFF) or t0 != t0:
            break
        last[m] = n
        count = clock[1, m] + ((n - np.int64(clock[2, m])) & 0xFFFF)
        clock[1, m] = count
        clock[2, m] = n
        f = n0 + k
        idx[f] = g
        times[f] = t0 + count / rate
        c = counts[f]
        for i in range(4):
            j = pos + 5 + 3 * i
            b0, b1, b2 = np.int64(b[j]), np.int64(b[j + 1]), np.int64(b[j + 2])
            c[2 * i] = (b0 << 4) | (b1 >> 4)
            c[2 * i + 1] = ((b1 & 15) << 8) | b2
        c[8] = ((np.int64(b[pos + 17]) & 15) << 8) | np.int64(b[pos + 18])
        per_mote[m] += 1
        k += 1
        pos += 21
    return k, pos
