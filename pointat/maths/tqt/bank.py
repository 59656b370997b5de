"""The TQT filter for many sensors at once: :class:`TQTBank`, one array of states and one update for all.

Every sensor runs the step of :class:`~pointat.maths.tqt.TQTFilter`: a Python loop over the rows, or the
robust step compiled by numba into one loop (:mod:`pointat.maths.tqt.compiled`, imported when a bank
asks for it, so that numba loads only where a bank runs).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from pointat.maths.quaternion import quat_normalize
from pointat.maths.tqt import step
from pointat.maths.tqt.params import _TQTParams

__all__ = ["TQTBank"]


class TQTBank(_TQTParams):
    r""":class:`~pointat.maths.tqt.TQTFilter` for ``n`` sensors at once (a body suit: ~15), same parameters,
    same results.

    State is one row per sensor; :meth:`update` takes ``(n, 3)`` arrays and one ``dt`` and returns ``(n, 4)``
    quaternions (sensor -> NWU); :meth:`update_batch` takes a block of samples, ``(t, n, 3)``, in one call
    (a recording replayed), with the very results of ``t`` calls of :meth:`update`.  Every sensor runs the very step of :class:`~pointat.maths.tqt.TQTFilter`
    (:mod:`pointat.maths.tqt.step`), so a bank agrees with ``n`` independent filters to the last bit.

    Two ways to run it (``backend``): ``numba`` runs the robust step compiled, as one loop over the sensors
    (:mod:`pointat.maths.tqt.compiled`), well under a microsecond per sensor; ``python`` loops over the
    sensors in Python, a few microseconds each.  ``auto`` (default) takes numba in robust mode (numba
    compiles robust mode only).

    Parameters
    ----------
    n : int
        Number of sensors.
    k, **params
        As :class:`~pointat.maths.tqt.TQTFilter`.
    backend : {"auto", "numba", "python"}
        How the update runs (the results agree).

    >>> bank = TQTBank(2)
    >>> acc = np.array([[0.0, 0.0, 9.81], [0.0, 0.0, 0.0]])           # sensor 1: accelerometer dropped out
    >>> q = bank.update(np.zeros((2, 3)), acc, np.tile([20.0, 0.0, -40.0], (2, 1)), 0.01)
    >>> np.round(q, 9).tolist()
    [[1.0, 0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]]
    >>> from pointat.maths.tqt import TQTFlags
    >>> bank.flags.tolist() == [0, TQTFlags.ACC_INVALID | TQTFlags.UNINITIALISED]
    True
    """

    def __init__(self, n: int, k: float | None = None, *, backend: str = "auto", **params: object) -> None:
        if int(n) != n or n < 1:
            raise ValueError(f"n must be a positive integer, got {n!r}")
        self.n = int(n)
        from pointat.maths.tqt import compiled  # here, not at the top: numba loads only with a bank

        if backend not in ("auto", "numba", "python"):
            raise ValueError(f"backend must be 'auto', 'numba' or 'python', got {backend!r}")
        super().__init__(k, **params)  # type: ignore[arg-type]
        if backend == "numba" and self.mode != "robust":
            raise ValueError(f"backend='numba' runs mode='robust' only, got mode {self.mode!r}")
        numba = backend == "numba" or (backend == "auto" and self.mode == "robust")
        self.backend = "numba" if numba else "python"
        self._kernel = compiled.bank_kernel() if numba else None
        self._all = np.ones(self.n, dtype=bool)  # present: every sensor (read only)
        self._p = np.array(self._p) if numba else self._p
        if numba and not compiled.compiled():
            # numba compiles the kernel (or loads it from its cache) on its first call, up to a second or
            # two: here, where a patch loads, not on the first update, where it would stall a live one
            zeros = np.zeros((self.n, 3))
            self.update(zeros, zeros, zeros, 0.01)
            self.reset()

    def reset(self, q: ArrayLike | None = None) -> None:
        """Forget everything (all sensors); start from ``q`` or from each sensor's next valid acc / mag pair.

        Parameters
        ----------
        q : array_like, shape (4,) or (n, 4), optional
            Known orientations (sensor -> NWU); normalised here.
        """
        qs = [None] * self.n if q is None else np.broadcast_to(quat_normalize(q), (self.n, 4)).tolist()
        self._s = np.array([step.new_state(qi, self.dip) for qi in qs])
        self._flags = np.full(self.n, 0 if q is not None else step.F_UNINITIALISED, dtype=np.int64)

    @property
    def q(self) -> np.ndarray:
        """Current orientations, shape (n, 4), sensor -> NWU (a copy)."""
        return self._s[:, :4].copy()

    @property
    def flags(self) -> np.ndarray:
        """Per-sensor :class:`TQTFlags` bits of the last update, int array of shape (n,)."""
        return self._flags.copy()

    @property
    def initialised(self) -> np.ndarray:
        """Per-sensor bool, shape (n,)."""
        return self._s[:, step.S_INIT] != 0.0

    @property
    def bias(self) -> np.ndarray:
        """Gyro biases learned at rest, shape (n, 3), rad/s (robust mode)."""
        return self._s[:, step.S_BIAS : step.S_BIAS + 3].copy()

    @property
    def magnetic_dip(self) -> np.ndarray:
        """Dip references in radians, shape (n,) (NaN until learned)."""
        known = (self._s[:, step.S_MAG_KNOWN] != 0.0) | (self.dip is not None)
        return np.where(known, self._s[:, step.S_DIP], np.nan)

    def update(
        self, gyro: ArrayLike, acc: ArrayLike, mag: ArrayLike, dt: float, present: ArrayLike | None = None
    ) -> np.ndarray:
        """Advance all sensors by one sample.

        Parameters
        ----------
        gyro : array_like, shape (n, 3)
            Angular rates, rad/s.
        acc : array_like, shape (n, 3)
            Specific forces (+g up at rest).
        mag : array_like, shape (n, 3)
            Magnetic fields.
        dt : float
            Seconds since the previous sample (common to all sensors).
        present : array_like of bool, shape (n,), optional
            Which sensors have a sample in this update (default: all).  An absent sensor is left exactly
            as it was, its flags included: a lost packet is not a bad sample (which, as in
            :class:`~pointat.maths.tqt.TQTFilter`, also ends a rest).

        Returns
        -------
        numpy.ndarray, shape (n, 4)
            Orientations ``(w, x, y, z)``, sensor -> NWU; never NaN.
        """
        shape = (self.n, 3)
        g = np.ascontiguousarray(gyro, dtype=float)  # (the very array when it is one already)
        a = np.ascontiguousarray(acc, dtype=float)
        m = np.ascontiguousarray(mag, dtype=float)
        if g.shape != shape or a.shape != shape or m.shape != shape:
            raise ValueError(
                f"gyro, acc and mag must have shape {shape}, got {g.shape}, {a.shape}, {m.shape}"
            )
        if present is None:
            here = self._all
        else:
            here = np.asarray(present, dtype=bool)
            if here.shape != (self.n,):
                raise ValueError(f"present must have shape ({self.n},), got {here.shape}")
        dt = float(dt)
        if self._kernel is not None:
            self._kernel(g, a, m, dt, here, self._s, self._p, self._flags)
            return self._s[:, :4].copy()
        run, p = self._step, self._p
        for i, (gi, ai, mi) in enumerate(zip(g.tolist(), a.tolist(), m.tolist(), strict=True)):
            if here[i]:
                s = self._s[i].tolist()
                self._flags[i] = run(s, p, *gi, *ai, *mi, dt)
                self._s[i] = s
        return self._s[:, :4].copy()

    def update_batch(
        self,
        gyro: ArrayLike,
        acc: ArrayLike,
        mag: ArrayLike,
        dt: ArrayLike,
        present: ArrayLike | None = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Advance all sensors by a block of ``t`` samples (a recording replayed): exactly what ``t`` calls
        of :meth:`update` give, to the bit, in one compiled call with numba (see
        :func:`pointat.maths.tqt.step.robust_batch`; compiled, or loaded from the cache, at the first call of a
        process: meant for replaying, not for a live patch's first sample).

        Parameters
        ----------
        gyro, acc, mag : array_like, shape (t, n, 3)
            As :meth:`update`, one row a sample.
        dt : float or array_like of shape (t,)
            Seconds since the previous sample: one for all, or each sample's own.
        present : array_like of bool, shape (t, n), optional
            As :meth:`update`'s, one row a sample (default: all).

        Returns
        -------
        q : numpy.ndarray, shape (t, n, 4)
            Every sample's orientations, as :meth:`update` returns them.
        flags : numpy.ndarray of int, shape (t, n)
            Every sample's :attr:`flags`.
        """
        g = np.ascontiguousarray(gyro, dtype=float)
        a = np.ascontiguousarray(acc, dtype=float)
        m = np.ascontiguousarray(mag, dtype=float)
        if g.ndim != 3 or g.shape[1:] != (self.n, 3) or a.shape != g.shape or m.shape != g.shape:
            raise ValueError(
                f"gyro, acc and mag must have one shape (t, {self.n}, 3), got {g.shape}, {a.shape}, {m.shape}"
            )
        t = g.shape[0]
        dts = np.asarray(dt, dtype=float)
        dts = np.full(t, float(dts)) if dts.ndim == 0 else np.ascontiguousarray(dts)
        if dts.shape != (t,):
            raise ValueError(f"dt must be a number or have shape ({t},), got {dts.shape}")
        if present is None:
            here = np.ones((t, self.n), dtype=bool)
        else:
            here = np.ascontiguousarray(present, dtype=bool)
            if here.shape != (t, self.n):
                raise ValueError(f"present must have shape ({t}, {self.n}), got {here.shape}")
        q = np.empty((t, self.n, 4))
        flags = np.empty((t, self.n), dtype=np.int64)
        if self._kernel is not None:
            from pointat.maths.tqt import compiled

            compiled.batch_kernel()(g, a, m, dts, here, self._s, self._p, self._flags, q, flags)
            return q, flags
        for i in range(t):
            q[i] = self.update(g[i], a[i], m[i], dts[i], here[i])
            flags[i] = self._flags
        return q, flags
