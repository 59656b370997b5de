"""Hot reload: a running patch takes the new version of its file between two samples.

``pointat run PATCH --watch`` looks at the patch file (and the abstractions it uses) a few times a second;
``/pointat/patch/reload`` over OSC asks for the same at once.  A reload goes in two halves:

* **Off the scheduler's thread** the file is read and checked completely, as ``pointat run`` checks it
  before it starts (:func:`pointat.loader.ready`: its files read too).  A file that does not check is
  refused: every problem is logged with its file:line and the patch that runs is left untouched.  Then
  the old and new patch are compared (:func:`plan`), and the nodes that are new or changed are built and
  prepared (a model trained, compiled code loaded), still beside the running patch.
* **On the scheduler's thread**, when the pass being handled is done (after the datagrams of the last
  sample have left: ``osc_out`` sends at the end of a pass), the swap: removed and changed nodes are
  closed (their timers cancelled), new ones take their place, the wires are made anew from the new file,
  the new nodes start and get their loadbang.  No sample is read while it happens, so none is lost or
  sent twice; the next one goes through the new patch.

A node whose name, type and parameters are unchanged keeps its object, and so its state: a filter's
orientation and gyro bias, a calibration, a trained gesture model, an open socket or serial port, a
glove's timer.  A node whose only changes are to *live* parameters (those live control may set) keeps its
object too and is given the new values, as ``/pointat/NODE/PARAM value`` would give them: a filter whose
gain was edited goes on from where it points.  Any other change makes the node anew.  The glove chains
that run compiled (``--compiled``) are handed back to their nodes before the swap, their state written
into them, and compiled again after it from the compiled code already loaded: nothing is recompiled
(a patch that ran node by node, its compiled code not cached yet, goes on node by node until the next
run, so that no reload ever compiles on the scheduler's thread).

What watches the runtime (the console's status lines, the monitor, OSCQuery) is told after each swap
(:meth:`Reloader.listen`).
"""

from __future__ import annotations

import hashlib
import logging
import os
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .checking import Checked, Resolved
from .errors import PatchError, PointatError, Problem

__all__ = ["Plan", "Reloader", "plan"]

log = logging.getLogger("pointat.reload")


@dataclass
class Plan:
    """What a reload does, by node name (the new file's order where there is one)."""

    #: Same name, type and parameters: the object stays as it is.
    keep: list[str] = field(default_factory=list)
    #: Same name and type, only live parameters changed: the object stays and gets these values.
    retune: dict[str, dict[str, Any]] = field(default_factory=dict)
    #: New, or changed beyond its live parameters: made anew.
    make: list[str] = field(default_factory=list)
    #: In the old patch and not kept (removed, or made anew): closed.
    drop: list[str] = field(default_factory=list)

    def describe(self) -> str:
        """One line for the console: ``3 nodes kept, 1 retuned (out), 1 new (x), 1 removed (y)``."""
        made = [n for n in self.make if n not in self.drop]
        changed = [n for n in self.make if n in self.drop]
        removed = [n for n in self.drop if n not in self.make]
        parts = [f"{len(self.keep)} node{'s' * (len(self.keep) != 1)} kept"]
        for what, names in (("retuned", list(self.retune)), ("made anew", changed), ("new", made)):
            if names:
                parts.append(f"{len(names)} {what} ({', '.join(names)})")
        if removed:
            parts.append(f"{len(removed)} removed ({', '.join(removed)})")
        return ", ".join(parts)


def _same(a: Any, b: Any) -> bool:
    """Whether two parameter values are the same setting: NaN (a parameter's "none", such as a dip
    still to learn) is the same as NaN; lists and vectors element by element.

    >>> _same(float("nan"), float("nan")), _same((1, 2.0), [1, 2.0]), _same(0.2, 0.25)
    (True, True, False)
    """
    if isinstance(a, float) and isinstance(b, float) and a != a and b != b:
        return True
    if isinstance(a, (tuple, list)) and isinstance(b, (tuple, list)):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b, strict=True))
    try:
        return bool(a == b)
    except Exception:  # values whose == is not a yes or no (arrays): not the same, made anew
        return False


def plan(old: Checked, new: Checked) -> Plan:
    """Compare two checked versions of a patch: which nodes stay, which take new live values, which are
    made anew and which go.  A node stays when its name, type, ports and parameters are the same; it is
    retuned when the only parameters that differ are live ones."""
    result = Plan()
    for name, r in new.nodes.items():
        was = old.nodes.get(name)
        if was is None:
            result.make.append(name)
            continue
        changed = _changed(was, r)
        if changed is None:
            result.make.append(name)
            result.drop.append(name)
        elif not changed:
            result.keep.append(name)
        else:
            result.retune[name] = changed
    result.drop += [name for name in old.nodes if name not in new.nodes]
    return result


def _changed(was: Resolved, now: Resolved) -> dict[str, Any] | None:
    """The live parameters that differ ({} for none), or None when the node must be made anew."""
    if was.cls is not now.cls or not _same(was.inlets, now.inlets) or not _same(was.outlets, now.outlets):
        return None
    changed = {k: v for k, v in now.values.items() if k not in was.values or not _same(was.values[k], v)}
    if set(was.values) - set(now.values):
        return None
    for key in changed:
        p = now.cls.param(key)
        if p is None or not p.live:
            return None
    return changed


class Reloader:
    """Reloads a running runtime ``rt`` from its file.

    ``checked`` is the patch it runs; ``read()`` reads and checks the file again (raising
    :class:`PatchError`), as the runtime's was.  :meth:`start` a thread that waits for :meth:`request`
    (``/pointat/patch/reload``) and, with ``watch``, looks at the files every :attr:`POLL` seconds;
    :meth:`reload` does one at once (a test on a manual clock calls it between two ``advance``).
    """

    #: Seconds between two looks at the files (``--watch``).
    POLL = 0.1
    #: Seconds a reload waits for the scheduler to make the swap before it gives up (a stopped patch).
    SWAP_WAIT = 10.0

    def __init__(
        self,
        rt: Any,
        checked: Checked,
        read: Callable[[], Checked],
        *,
        path: str | os.PathLike[str] | None = None,
        watch: bool = False,
    ):
        self.rt = rt
        self.checked = checked
        self.read = read
        self.path = Path(path if path is not None else checked.spec.path)
        self.watch = watch
        #: Reloads done, and refused (a file that does not check, a node that cannot be made).
        self.reloads = 0
        self.refused = 0
        #: The problems of the last refused reload (file:line, what), or [].
        self.problems: list[Problem] = []
        #: Seconds the last reload took, from reading the file to the new patch running; and of them, the
        #: swap on the scheduler's thread (what the samples wait for).
        self.seconds = 0.0
        self.swap_seconds = 0.0
        self._listeners: list[Callable[[Plan], None]] = []
        self._wanted = threading.Event()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._lock = threading.Lock()  # one reload at a time (the thread's, or a test's)
        self._loaded = self._fingerprint()
        self._seen = self._stat()  # (a save from here on is a change, even before the thread starts)

    # -- who is told -------------------------------------------------------------------------------
    def listen(self, fn: Callable[[Plan], None]) -> None:
        """Call ``fn(plan)`` on the scheduler's thread after each swap (the observer re-attaches)."""
        self._listeners.append(fn)

    # -- the files ---------------------------------------------------------------------------------
    def files(self) -> list[Path]:
        """The patch file and the abstraction files its nodes come from."""
        found = {self.path}
        for r in self.checked.nodes.values():
            where = r.decl.where
            if where is not None and where.file and not where.file.startswith("<"):
                found.add(Path(where.file))
        return sorted(found)

    def _stat(self) -> tuple[Any, ...] | None:
        """What the files look like from outside (size, time, inode), or None while one is missing (an
        editor saving by rename, between the two steps)."""
        seen = []
        for path in self.files():
            try:
                st = os.stat(path)
            except OSError:
                return None
            seen.append((str(path), st.st_size, st.st_mtime_ns, st.st_ino))
        return tuple(seen)

    def _fingerprint(self) -> str | None:
        """A hash of the files' contents: a save that changes nothing (a touch) reloads nothing."""
        digest = hashlib.sha256()
        for path in self.files():
            try:
                digest.update(str(path).encode() + b"\0" + path.read_bytes() + b"\0")
            except OSError:
                return None
        return digest.hexdigest()

    # -- the thread --------------------------------------------------------------------------------
    def start(self) -> None:
        self._thread = threading.Thread(target=self._run, name="pointat-reload", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        self._wanted.set()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(self.SWAP_WAIT + 1.0)

    def request(self) -> None:
        """Reload as soon as the thread can (any thread: ``/pointat/patch/reload``)."""
        self._wanted.set()

    def _run(self) -> None:
        while self.rt.realtime and self.rt.scheduler_thread is None and not self._stop.is_set():
            self._stop.wait(self.POLL)  # (the swap is the scheduler's: wait for it to run)
        seen = self._seen
        settling = False
        while not self._stop.is_set():
            asked = self._wanted.wait(self.POLL if self.watch else None)
            if self._stop.is_set():
                return
            # (after a reload the files are compared with how they looked before it, not after: a save
            # that lands while it reads and swaps is a change still to see)
            if asked:
                self._wanted.clear()
                seen, settling = self._stat(), False
                self._guarded(force=True)
                continue
            now = self._stat()
            if now is None or now != seen:  # changing, or half-saved: look again next time
                seen, settling = now, now is not None
                continue
            if settling:  # the same twice in a row: saved
                settling = False
                if self._fingerprint() != self._loaded:
                    self._guarded(force=False)

    def _guarded(self, force: bool) -> None:
        try:
            self.reload(force=force)
        except Exception:  # never the patch's end
            log.exception("reload of %s failed; the patch running goes on as it was", self.path)

    # -- one reload --------------------------------------------------------------------------------
    def reload(self, *, force: bool = True) -> bool:
        """Read, check and swap in the file's patch now (from any thread but the scheduler's, or from a
        test driving a manual clock); True when the new patch runs.  Without ``force`` a file whose
        contents are those loaded already is left alone."""
        with self._lock:
            fingerprint = self._fingerprint()
            if not force and fingerprint == self._loaded:
                return False
            began = time.perf_counter()
            try:
                new = self.read()
            except PatchError as exc:
                return self._refuse(exc.problems)
            except PointatError as exc:
                return self._refuse([Problem(None, str(exc))])
            steps = plan(self.checked, new)
            try:
                made = self._make(new, steps)
            except PatchError as exc:
                return self._refuse(exc.problems)
            if not self._on_scheduler(lambda: self._swap(new, steps, made)):
                for node in made.values():
                    node.close()
                return self._refuse([Problem(None, "the patch stopped before the new version could run")])
            self.checked = new
            self._loaded = fingerprint
            self.problems = []
            self.reloads += 1
            self.seconds = time.perf_counter() - began
            return True

    def _refuse(self, problems: list[Problem]) -> bool:
        self.refused += 1
        self.problems = list(problems)
        errors = [p for p in problems if p.severity == "error"] or problems
        log.error(
            "%s not reloaded (%d error%s); the patch running goes on unchanged:",
            self.path,
            len(errors),
            "s" * (len(errors) != 1),
        )
        for problem in problems:
            log.error("  %s", problem)
        return False

    def _make(self, new: Checked, steps: Plan) -> dict[str, Any]:
        """The new and changed nodes built and prepared (beside the running patch; nothing opened)."""
        made: dict[str, Any] = {}
        problems = []
        for name in steps.make:
            r = new.nodes[name]
            try:
                node = r.cls(name, r.values)
                node.where = r.decl.where
                node.rt = self.rt
                made[name] = node
                node.prepare()
            except Exception as exc:
                problems.append(
                    Problem(r.decl.where, f"node '{name}' ({r.decl.type}): cannot be made: {exc}")
                )
        if problems:
            for node in made.values():
                node.close()
            raise PatchError(problems)
        return made

    def _on_scheduler(self, fn: Callable[[], None]) -> bool:
        """Run ``fn`` on the scheduler's thread when its pass is done, and wait for it (at most
        :attr:`SWAP_WAIT`).  False when the runtime stopped first."""
        return self.rt.between_passes(fn, self.SWAP_WAIT)

    # -- the swap, on the scheduler's thread -----------------------------------------------------------
    def _swap(self, new: Checked, steps: Plan, made: dict[str, Any]) -> None:
        began = time.perf_counter()
        try:
            self._swap_nodes(new, steps, made)
        finally:
            self.swap_seconds = time.perf_counter() - began
        self.rt.console(f"reloaded {self.path.name}: {steps.describe()}")

    def _swap_nodes(self, new: Checked, steps: Plan, made: dict[str, Any]) -> None:
        rt = self.rt
        nodes = {}
        for name, r in new.nodes.items():
            node = made.get(name) or rt.nodes[name]
            node.where = r.decl.where
            nodes[name] = node
        for name, node in rt.nodes.items():  # what the file did not make stays (pointat run --mapper's)
            if name not in self.checked.nodes and name not in nodes:
                nodes[name] = node
        rt.swap(nodes, new.wires, retune=steps.retune)
        for fn in list(self._listeners):
            try:
                fn(steps)
            except Exception:  # what watches the patch never stops it
                log.exception("after the reload, a listener failed")
