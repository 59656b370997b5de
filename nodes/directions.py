"""Where the hand points: a reference pose, azimuth and elevation, and Torre's roll-for-distance gesture.

The math is in :mod:`pointat.maths.scalar` and :mod:`pointat.maths.fusion`; these nodes only move
messages (conventions: :mod:`pointat.nodes.orientation`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from pointat.maths import scalar as sq
from pointat.maths.fusion import RollDistance
from pointat.message import Message, floats
from pointat.node import Inlet, Node, Outlet, Param
from pointat.nodes.orientation import ORIENTATION, POLE, as_quat, check_pole
from pointat.registry import register


@register("reference")
class Reference(Node):
    """Outputs relative to a captured reference pose: "point at the front speaker and press".

    A bang at the right inlet (or ``set`` at the left one, ``/pointat/NODE/set`` over OSC) captures the
    next orientation as the reference; ``clear`` forgets it.  ``mode=heading`` (the default) removes only
    the reference's heading: azimuth 0 is where the hand pointed and elevations stay true to the room.  The
    heading is that of the sensor ``axis`` that points, as ``azi_ele``'s (give both the same ``axis`` when
    the hand's x is not the one that points); pointing within 1 deg of straight up or down there is no
    heading, and the capture waits for the next orientation that has one.  ``mode=full`` removes the whole
    reference orientation: the reference pose becomes the identity, its tilt and roll too, so with a
    reference that is not level every later direction is measured from its tilted horizon (capture a level
    pose, or use heading).

    The offset quaternion is applied in the earth frame, q_rel = q_offset ⊗ q (the reference turns the
    room, not the sensor); Bachmann et al.'s offset quaternions (VRST 2001 Eqs. 32-34) are the sensor-frame
    counterpart, q ⊗ q_offset, which aligns a sensor with the limb it is strapped to.
    """

    pure = True
    fusable = True

    inlets = (
        Inlet("quat", ORIENTATION, "orientation (quaternion or matrix)"),
        Inlet("capture", ("bang",), "capture the next orientation as the reference", hot=False),
    )
    outlets = (Outlet("quat", "vector", "orientation relative to the reference"),)
    params = (
        Param(
            "mode",
            "symbol",
            "heading",
            "heading (remove the reference's heading) or full",
            choices=("heading", "full"),
            live=True,
        ),
        Param("capture_first", "bool", False, "capture the first orientation that arrives"),
        Param(
            "axis",
            "vector",
            (1.0, 0.0, 0.0),
            "the sensor axis that points (heading mode), as azi_ele's",
            size=3,
        ),
    )

    @classmethod
    def validate(cls, values: Mapping[str, Any]) -> None:
        if not math.hypot(*values["axis"]) > 0.0:
            raise ValueError(f"axis must be a non-zero vector, got {list(values['axis'])}")

    def setup(self) -> None:
        self.offset: sq.Quat = (1.0, 0.0, 0.0, 0.0)
        self._capture = self.p.capture_first

    def on_capture(self, msg: Message) -> None:
        self._capture = True

    def do_set(self) -> None:
        self._capture = True

    def do_clear(self) -> None:
        self.offset = (1.0, 0.0, 0.0, 0.0)

    def fused_state(self) -> dict[str, Any] | None:
        """The offset quaternion, when no capture is pending (:mod:`pointat.compiled`)."""
        if self._capture:
            return None
        return {"offset": self.offset}

    def restore_fused(self, state: Mapping[str, Any]) -> None:
        self.offset = tuple(state["offset"])

    def on_quat(self, msg: Message) -> None:
        q = as_quat(msg)
        if self._capture:
            self._take(q)
        # the reference earth frame is the earth frame turned by the reference: q_rel = offset ⊗ q
        self.out(0, floats(sq.normalize(sq.multiply(self.offset, q)), msg.time))

    def _take(self, q: sq.Quat) -> None:
        if self.p.mode == "full":
            self.offset = sq.conjugate(q)
        else:
            # azi_ele's heading, with its pole: within 1 deg of straight up or down it gives back
            # 'previous', here NaN: no heading yet, and the capture waits
            az, _ = sq.azimuth_elevation(q, self.p.axis, previous=math.nan, pole_deg=1.0)
            if math.isnan(az):
                return
            yaw = math.radians(az)
            self.offset = (math.cos(yaw / 2), 0.0, 0.0, -math.sin(yaw / 2))
        self._capture = False


_pointing = sq.azimuth_elevation
_HAND_X = (1.0, 0.0, 0.0)


@register("azi_ele")
class AziEle(Node):
    """Pointing direction -> azimuth and elevation (degrees), ready for VBAP and spatialisers.

    ADM-OSC convention: 0 = front (earth x: north, or the reference pose), positive = left, -180..180;
    elevation positive up.  Pointing straight up or down the azimuth is undefined: the last one is held.
    """

    pure = True
    fusable = True

    inlets = (Inlet("quat", ORIENTATION, "orientation, quaternion or matrix"),)
    outlets = (Outlet("azimuth", "float", "degrees, + left"), Outlet("elevation", "float", "degrees, + up"))
    params = (
        Param("axis", "vector", (1.0, 0.0, 0.0), "the sensor axis that points (the hand's x)", size=3),
        POLE,
    )

    @classmethod
    def validate(cls, values: Mapping[str, Any]) -> None:
        check_pole(values["pole"])

    def setup(self) -> None:
        self._az: float | None = None

    def fused_state(self) -> dict[str, Any]:
        """The azimuth last given (None: none yet), held at the poles (:mod:`pointat.compiled`)."""
        return {"azimuth": self._az}

    def restore_fused(self, state: Mapping[str, Any]) -> None:
        self._az = state["azimuth"]

    def on_quat(self, msg: Message) -> None:
        self._az, el = _pointing(as_quat(msg), self.p.axis, self._az, self.p.pole)
        self.out(1, el)  # right to left, as emit does (written out: a call less per sample)
        self.out(0, self._az)


@register("roll_distance")
class RollDistanceNode(Node):
    """Torre §5.2: roll the hand 90 deg and the azimuth becomes a distance, 0 (far) .. 90 (near).

    Hysteresis: distance mode starts at |roll| >= ``enter`` and ends below ``leave``.  In distance mode
    the azimuth output holds, and sweeping the rolled hand left brings the source closer.  When the
    hand unrolls, the azimuth goes to where the hand points in one step; for a receiver that does not
    glide, put a ``smooth wrap=true`` between this node and it.  The roll is only read while
    the hand points within ``max_elevation`` of the horizon: pointing (nearly) straight up or down, its
    roll is its heading and jitters wildly, so the mode stays as it is.
    """

    pure = True
    fusable = True

    inlets = (Inlet("quat", ORIENTATION, "orientation, quaternion or matrix"),)
    outlets = (
        Outlet("azimuth", "float", "degrees (held in distance mode)"),
        Outlet("distance", "float", "0 far .. 90 near"),
        Outlet("mode", "symbol", "azimuth or distance, when it changes"),
    )
    params = (
        Param("enter", "float", 70.0, "|roll| that starts distance mode", unit="deg", live=True),
        Param("leave", "float", 45.0, "|roll| below which it ends", unit="deg", live=True),
        Param("gain", "float", 1.0, "distance per degree of azimuth", live=True),
        Param("distance", "float", 0.0, "initial distance, 0..90"),
        Param(
            "max_elevation",
            "float",
            75.0,
            "above this |elevation| the roll is not read (the mode holds)",
            unit="deg",
            live=True,
        ),
        POLE,
    )

    @classmethod
    def validate(cls, values: Mapping[str, Any]) -> None:
        """What a live change must keep too: leave below enter, angles in their ranges."""
        RollDistance.check(values["enter"], values["leave"], values["max_elevation"])
        check_pole(values["pole"])

    def setup(self) -> None:
        self.state = RollDistance(
            self.p.enter, self.p.leave, self.p.gain, self.p.distance, self.p.max_elevation
        )
        self._mode = self.state.mode
        self._az: float | None = None

    def param_changed(self, name: str) -> None:
        self.state.enter_deg, self.state.leave_deg, self.state.gain = self.p.enter, self.p.leave, self.p.gain
        self.state.max_elevation_deg = self.p.max_elevation

    def fused_state(self) -> dict[str, Any]:
        """The gesture's state vector (:class:`~pointat.maths.fusion.RollDistance`'s ``s``) and settings,
        the pointing azimuth last found (None: none yet) and the mode last told (:mod:`pointat.compiled`)."""
        rd = self.state
        return {
            "roll": list(rd.s),
            "enter": rd.enter_deg,
            "leave": rd.leave_deg,
            "gain": rd.gain,
            "max_elevation": rd.max_elevation_deg,
            "azimuth": self._az,
            "mode": self._mode,
        }

    def restore_fused(self, state: Mapping[str, Any]) -> None:
        """The state vector and azimuth moved on; the mode is the vector's (the chain told each change)."""
        self.state.s[:] = state["roll"]
        self._mode = self.state.mode
        self._az = state["azimuth"]

    def on_quat(self, msg: Message) -> None:
        q = as_quat(msg)
        self._az, el = _pointing(q, _HAND_X, self._az, self.p.pole)
        mode, az_out, dist = self.state.update(self._az, math.degrees(sq.roll(q)), el)
        self.tell_mode(mode)
        self.out(1, dist)  # right to left, as emit does
        self.out(0, az_out)

    def tell_mode(self, mode: str) -> None:
        """The gesture's mode of this sample, told when it changes (:mod:`pointat.compiled` tells it too)."""
        if mode != self._mode:
            self._mode = mode
            self.out(2, mode)
