"""Live control by address: ``/pointat/NODE/PARAM value``, ``/pointat/NODE/METHOD args``, ``/pointat/NODE
values``, ``/pointat/preset/save NAME`` / ``recall NAME`` and ``/pointat/patch/reload``.  One function for
every way in (``osc_in``, the OSCQuery server's OSC port and WebSocket), run on the scheduler thread.  What it did is told on the
console (:class:`Told`): a press acknowledged at once, a fader's stream a line a second.
"""

from __future__ import annotations

from typing import Any

from .errors import did_you_mean
from .message import make

__all__ = ["PREFIX", "Told", "control"]

PREFIX = "/pointat/"


def control(rt: Any, address: str, args: list[Any], time: float) -> str | None:
    """Carry out one live-control message on ``rt`` (scheduler thread); ``None`` when done, else why it
    was refused.  ``address`` starts with :data:`PREFIX`; NODE may be an abstraction's inner node
    (``left/dir``)."""
    # OSC's floats are float32: 0.2 arrives as 0.20000000298...; a setting means the 0.2 that was typed
    args = [float(f"{a:.7g}") if type(a) is float else a for a in args]
    rest = address[len(PREFIX) :]
    if rest.startswith("preset/") and "preset" not in rt.nodes:
        return _preset(rt, rest[len("preset/") :], args)
    if rest.startswith("patch/") and "patch" not in rt.nodes:
        return _patch(rt, rest[len("patch/") :], args)
    name, selector = rest, None
    if rest not in rt.nodes:  # not values for a node's left inlet: /pointat/NODE/SELECTOR
        name, _, selector = rest.rpartition("/")
        if name not in rt.nodes or not selector:
            why = (
                f"no parameter or method after node '{name}'"
                if name in rt.nodes
                else f"no node '{name or rest}'" + did_you_mean(name or rest, rt.nodes)
            )
            return why + "; expected /pointat/NODE/PARAM value or /pointat/NODE/METHOD"
    node = rt.nodes[name]
    if selector is None and not node.in_specs:
        return (
            f"node '{name}' has no inlets to take values; send /pointat/{name}/PARAM value or "
            f"/pointat/{name}/METHOD"
        )
    handler = node._handlers[0] if selector is None else getattr(node, "do_" + selector, None)
    if args and getattr(handler, "names_path", False):  # the rule: live control names no path
        return (
            f"node '{name}': live control names no files or devices (the patch does): send "
            f"/pointat/{name}/{selector or ''} with no arguments"
            if selector
            else f"node '{name}': live control names no files or devices (the patch does)"
        )
    try:  # on the scheduler thread already: straight to the node, nothing queued or lost
        if selector is None:
            msg = make(None if not args else args[0] if len(args) == 1 else tuple(args))
        else:
            msg = rt.message(selector, *args)
        node.receive(0, msg._replace(time=time))
    except Exception as exc:  # a blob where a number belongs, an unknown method, a refused value
        return f"node '{name}': {exc}"
    told = getattr(rt, "told", None)  # the runtime's, made at its first live control
    if told is None:
        told = rt.told = Told(rt)
    told.tell(address, args)
    return None


class Told:
    """Live control acknowledged on the console (``rt.console``), on the scheduler thread: the first
    message at an address at once (``live control: /pointat/press/bang``), then at most one line every
    :attr:`EVERY` s there, the last value with how many came (a fader sends dozens a second).  A burst's
    last value is told when its second is up, so the console ends on what the patch now holds."""

    #: Seconds between two lines about one address.
    EVERY = 1.0

    def __init__(self, rt: Any):
        self.rt = rt
        self._at: dict[str, list[Any]] = {}  # address -> [told at (rt time), held since, last text, timer]

    def tell(self, address: str, args: list[Any]) -> None:
        text = " ".join([address, *(_word(a) for a in args)])
        now = self.rt.clock.now()
        entry = self._at.get(address)
        if entry is None or (entry[1] == 0 and now - entry[0] >= self.EVERY):
            self._at[address] = [now, 0, text, None]
            self.rt.console(f"live control: {text}")
            return
        entry[1] += 1
        entry[2] = text
        if entry[3] is None:  # the rest of this second's messages, told when it is up
            entry[3] = self.rt.call_at(entry[0] + self.EVERY, None, self._flush, address)
            entry[3].daemon = True  # keeps no ended patch running

    def _flush(self, address: str) -> None:
        entry = self._at[address]
        held, entry[1], entry[3] = entry[1], 0, None
        entry[0] = self.rt.clock.now()
        self.rt.console(
            f"live control: {entry[2]}" + (f" (the last of {held} in {self.EVERY:g} s)" if held > 1 else "")
        )


def _word(a: Any) -> str:
    """An argument as it was meant: 0.05, not 0.05000000074505806 (OSC floats are float32)."""
    return f"{a:.7g}" if isinstance(a, float) else repr(a) if isinstance(a, str) and " " in a else str(a)


def _preset(rt: Any, verb: str, args: list[Any]) -> str | None:
    presets = getattr(rt, "presets", None)
    if presets is None:
        return "presets are kept for a patch run from a file (pointat run PATCH)"
    if verb not in ("save", "recall", "delete") or len(args) != 1 or not isinstance(args[0], (str, int)):
        return (
            "expected /pointat/preset/save NAME, /pointat/preset/recall NAME or /pointat/preset/delete NAME"
        )
    try:
        getattr(presets, verb)(str(args[0]))
    except (KeyError, ValueError, OSError) as exc:
        return f"preset {verb} {args[0]}: {exc}"
    return None


def _patch(rt: Any, verb: str, args: list[Any]) -> str | None:
    """``/pointat/patch/reload``: the patch's file read again and swapped in (:mod:`pointat.reload`), by
    the reloader's thread: the check and the nodes' preparing never hold the scheduler up."""
    reloader = getattr(rt, "reloader", None)
    if verb != "reload" or args:
        return "expected /pointat/patch/reload (no arguments)"
    if reloader is None:
        return "reload is for a patch run from a file (pointat run PATCH)"
    reloader.request()
    return None
