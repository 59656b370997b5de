"""Torre et al.'s orientation chain: gyro integration, the accel/mag matrix, and their complementary fusion.

The math is in :mod:`pointat.maths`; these nodes only move messages (conventions, time steps and flags:
:mod:`pointat.nodes.orientation`).
"""

from __future__ import annotations

import math

import numpy as np

from pointat.maths import scalar as sq
from pointat.maths.fusion import ComplementaryFilter, GyroIntegrator
from pointat.message import Message, as_floats, floats
from pointat.node import Inlet, Node, Outlet, Param
from pointat.nodes.orientation import FLAGS, ORIENTATION, RATE, Flagged, SampleClock, as_quat, matrix_message
from pointat.registry import register


@register("gyro_integrator")
class GyroIntegratorNode(SampleClock, Flagged, Node):
    """Integrate the gyro rates into an orientation matrix (Torre §3.2).

    ``mode=torre``: the paper's incremental rotation R(w)·R(v)·R(u) per sample; ``mode=exact``: the
    axis-angle exponential map.  The matrix is re-orthonormalised every ``renormalize`` samples so it
    stays a rotation over hours.  ``reset`` (or a matrix / quaternion at the right inlet) restarts it.
    """

    pure = True

    inlets = (
        Inlet("gyro", ("vector", "list"), "angular rate, rad/s, sensor frame"),
        Inlet("orientation", ORIENTATION, "set the orientation (matrix or quaternion)"),
    )
    outlets = (Outlet("orientation", "vector", "3x3 rotation matrix, sensor -> earth"), FLAGS)
    params = (
        Param(
            "mode",
            "symbol",
            "torre",
            "torre (the paper's product of axis rotations) or exact",
            choices=("torre", "exact"),
            live=True,
        ),
        Param("renormalize", "int", 100, "re-orthonormalise every N samples", minimum=1),
        RATE,
    )

    def setup(self) -> None:
        self.integrator = GyroIntegrator(mode=self.p.mode, renormalize_every=self.p.renormalize)
        self.reset_clock()

    def param_changed(self, name: str) -> None:
        self.integrator = GyroIntegrator(
            self.integrator.R, mode=self.p.mode, renormalize_every=self.p.renormalize
        )

    def on_gyro(self, msg: Message) -> None:
        wx, wy, wz = as_floats(msg, 3)
        try:  # the integrator refuses a NaN, infinite or glitched rate (MAX_RATE); self.step's dt is good
            R = self.integrator.step(wx, wy, wz, self.step(msg.time))
            self.report("ok")
        except ValueError:
            self.report("bad_gyro")
            R = self.integrator.flat
        self.out(0, floats(R, msg.time))

    def on_orientation(self, msg: Message) -> None:
        self.integrator.reset(np.reshape(sq.quat_matrix(as_quat(msg)), (3, 3)))

    def do_reset(self) -> None:
        self.integrator.reset()
        self.reset_clock()


@register("accmag_matrix")
class AccMagMatrix(Flagged, Node):
    """The orientation matrix from gravity and the Earth's magnetic field (Torre §3.3, corrected).

    TRIAD: up from the accelerometer, west = up x field, north = west x up.  Unlike the paper's matrix
    it is a proper rotation whatever the magnetic dip.  Zero, NaN or parallel vectors output nothing and
    raise ``bad_accmag`` on ``flags``.

    The matrix is only right while the hand does not accelerate and the field is the Earth's.  Beyond the
    paper, samples are therefore skipped (``accelerating`` / ``mag_disturbed`` on ``flags``) when |accel|
    is off g by more than ``accel_tolerance``, or the field's strength or dip is off its reference (learned
    from the samples accepted so far) by more than ``mag_tolerance`` or ``dip_tolerance``; a fusion node
    downstream then rides on the gyro.  A tolerance of 0 turns that check off.
    """

    pure = True

    inlets = (
        Inlet("accel", ("vector", "list"), "specific force (+g up at rest), sensor frame"),
        Inlet("mag", ("vector", "list"), "magnetic field, sensor frame"),
    )
    outlets = (Outlet("orientation", "vector", "3x3 rotation matrix, sensor -> earth (NWU)"), FLAGS)
    params = (
        Param("gravity", "float", 9.80665, "the accelerometer's reading at rest", unit="m/s²", above=0.0),
        Param(
            "accel_tolerance",
            "float",
            0.1,
            "skip when | |accel| - g | > this x g (0: never)",
            live=True,
            minimum=0.0,
        ),
        Param(
            "mag_tolerance",
            "float",
            0.1,
            "skip when |field| is off its reference by this fraction (0: never)",
            live=True,
            minimum=0.0,
        ),
        Param(
            "dip_tolerance",
            "float",
            5.0,
            "skip when the dip is off its reference by more (0: never)",
            unit="deg",
            live=True,
            minimum=0.0,
        ),
    )

    #: How fast the field's reference strength and dip follow accepted samples (per sample).
    LEARN = 0.001

    def setup(self) -> None:
        self._norm_ref: float | None = None
        self._dip_ref = 0.0

    def on_accel(self, msg: Message) -> None:
        mag = self.cold.get("mag")
        if mag is None:
            self.report("bad_accmag")
            return
        triad = sq.accmag_triad(as_floats(msg, 3), as_floats(mag, 3))
        if triad is None:
            self.report("bad_accmag")
            return
        C, na, nm, sin_dip = triad
        p = self.p
        if p.accel_tolerance and abs(na - p.gravity) > p.accel_tolerance * p.gravity:
            self.report("accelerating")
            return
        dip = math.degrees(math.asin(sin_dip))
        if self._norm_ref is None:
            self._norm_ref, self._dip_ref = nm, dip
        elif (p.mag_tolerance and abs(nm - self._norm_ref) > p.mag_tolerance * self._norm_ref) or (
            p.dip_tolerance and abs(dip - self._dip_ref) > p.dip_tolerance
        ):
            self.report("mag_disturbed")
            return
        self._norm_ref += self.LEARN * (nm - self._norm_ref)
        self._dip_ref += self.LEARN * (dip - self._dip_ref)
        self.report("ok")
        self.out(0, floats(C, msg.time))


@register("complementary")
class Complementary(SampleClock, Flagged, Node):
    """Fuse the gyro orientation (short term) with the accel/mag orientation (long term), on rotations.

    Each gyro orientation's change since the previous one is applied to the estimate, which is then
    pulled toward the accel/mag orientation by slerp with alpha = dt/(tau + dt), tau = 1/(2 pi crossover):
    a first-order complementary pair crossing at ``crossover`` Hz (Torre §3: "short-term precision of the
    gyroscopes with the long-term precision of accelerometers and magnetometers").
    """

    pure = True

    inlets = (
        Inlet("gyro_orientation", ORIENTATION, "orientation from gyro_integrator (matrix or quaternion)"),
        Inlet("accmag", ORIENTATION, "orientation from accmag_matrix (matrix or quaternion)"),
    )
    outlets = (Outlet("orientation", "vector", "fused 3x3 rotation matrix, sensor -> earth"), FLAGS)
    params = (
        Param(
            "crossover",
            "float",
            0.2,
            "crossover frequency of the complementary pair",
            unit="Hz",
            live=True,
            above=0.0,
        ),
        RATE,
    )
    example = """
node gyro gyro_integrator
node am   accmag_matrix
node fuse complementary crossover=0.2
gyro -> fuse.gyro_orientation
am -> fuse.accmag
"""

    def setup(self) -> None:
        self.filter = ComplementaryFilter(self.p.crossover)
        self._prev_gyro: sq.Quat | None = None
        self.reset_clock()

    def param_changed(self, name: str) -> None:
        self.filter.crossover_hz = self.p.crossover

    def on_gyro_orientation(self, msg: Message) -> None:
        g = as_quat(msg)
        dt = self.step(msg.time)
        am_msg = self.cold.pop("accmag", None)
        am = as_quat(am_msg) if am_msg is not None else None
        prev, self._prev_gyro = self._prev_gyro, g
        f = self.filter
        if not f.initialized and am is None:
            self.report("waiting_accmag")
            return
        # the body-frame increment since the previous gyro orientation (none before the first fused one)
        delta = sq.multiply(sq.conjugate(prev), g) if f.initialized and prev is not None else None
        q = f.fuse(delta, am, dt)
        self.report("ok" if am is not None else "gyro_only")
        self.out(0, matrix_message(q, msg.time))

    def do_reset(self) -> None:
        self.setup()
