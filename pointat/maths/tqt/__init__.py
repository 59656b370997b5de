r"""The Tuneable Quaternion Tracker (TQT): McGhee / Bachmann's Gauss-Newton MARG filter, with robust extensions.

One MARG sensor (gyro, accelerometer, magnetometer) in, one unit quaternion (sensor -> earth, NWU) out.
Conventions are those of :mod:`pointat.maths`; the gravity reference is *up* ``m = (0, 0, 1)``, which the
accelerometer measures as ``+g`` at rest, and the magnetic reference is ``n = (cos dip, 0, -sin dip)``.

Sources
-------
* McGhee, Bachmann, Yun, Zyda (2000), *Real-time tracking ... Part I: Theory*, NPS-MV-01-001 ("Theory"):
  rate quaternion Eq. 17, Gauss-Newton Eq. 32, the 4-column X matrix Eqs. 39-42, the Orthogonal Quaternion
  Theorem Eqs. 44-51, Table 1, the magnetometer weight rho Eq. 57, the crossover frequency Eq. 59.
* Bachmann, McGhee, Yun, Zyda (2001), VRST ("VRST"): the filter loop Eqs. 13-15, the reduced X Eqs. 20-27,
  accelerometer / magnetometer only tracking §4.4.
* Bachmann et al., US patent 7,089,148 (2006) ("Patent"): the 3x3 X matrix of Eq. 29, rho Eq. 30 and the
  "time weighted summing" of accelerations (col. 4).

The filter (Theory Fig. 1, VRST Eq. 15)
----------------------------------------
.. math::
    \dot{\hat q} = \tfrac12\,\hat q \otimes (0, p, q, r) + k\,\Delta q_{full}, \qquad
    \Delta q_{full} = \hat q \otimes (0, \Delta v), \qquad
    \Delta v = (X^T X)^{-1} X^T \varepsilon(\hat q)

With the reduced (orthogonal) correction both terms are :math:`\hat q \otimes (\text{pure vector})`, so the
whole right-hand side is a body rate :math:`\tfrac12 \hat q \otimes (0, \omega + 2k\Delta v)`; this module
integrates it *exactly* over one sample (zero-order hold), :math:`\hat q_{n+1} = \hat q_n \otimes
\exp\big(\tfrac{\Delta t}{2}(\omega + 2k\Delta v)\big)`, instead of the seeds' Euler step plus
normalisation.  The correction then turns the estimate by :math:`\alpha\theta` per step
(:math:`\alpha = k\Delta t`, VRST Eq. 14), so errors decay as :math:`e^{-kt}` and the complementary
crossover is :math:`f_c = k / 2\pi` Hz (Theory Eq. 59; in robust mode, which low-passes the acceleration
first, it is lower: :attr:`TQTFilter.crossover`).

Corrections of the seeds (see also the project's REFERENCE §7)
---------------------------------------------------------------
* Accelerometers measure the *reaction* to gravity, ``+g`` along the axis pointing up; the seeds compare the
  normalised accelerometer with "down" ``m = (0, 0, 0, 1)`` (VRST Eq. 5), which taken literally converges
  upside down.  Here the reference is up.
* VRST Eq. 26 / Patent Eq. 27 miss a transpose: :math:`\Delta v = (X_v^T X_v)^{-1} X_v^T \varepsilon`.
* Weighting the magnetometer residuals by :math:`\rho` (Theory Eq. 57) scales the magnetometer rows of X by
  :math:`\rho`, not :math:`\rho^2` (VRST §2.3, Patent col. 12).
* Theory Eqs. 35-38 are derivatives of :math:`q^*`, not of :math:`q^{-1}` (equal for unit q only).
* Patent Eq. 23 reads :math:`\partial y/\partial y_1` for :math:`\partial y/\partial v_1`.
* Theory Table 1 is captioned "RMS error" but, as its text says, is the *mean* error length over 100
  trials; it reproduces (``tests/maths/test_tqt.py``, with the numpy form of these equations in
  ``tests/maths/mcghee_reference.py``) with the 4-column X of Eqs. 39-42 (``jacobian_full``), starts
  ``q_true + U(±0.1)`` per component not normalised, no normalisation between cycles
  (``gauss_newton(..., reduced=False, normalize=False)``) and a dip of about 62° (Monterey): every cell
  lies within the sampling spread of a 100-trial mean.  The 3x3 form's first cycles land closer than the
  table's; it matches the noise-limited cells only.  The noiseless 3-cycle cell (9.3e-8) is float32
  round-off; float64 stays below 1e-8.

The package
-----------
* :mod:`~pointat.maths.tqt.step` -- robust mode's step on a flat state vector, plain floats: the one
  implementation :class:`TQTFilter`, :class:`TQTBank` and the compiled bank all run.
* :mod:`~pointat.maths.tqt.paper` -- paper mode's step (the reduced Gauss-Newton on floats) and the
  crossover of a gain, :func:`gain_from_crossover` / :func:`crossover_from_gain`.
* :mod:`~pointat.maths.tqt.params` -- :class:`TQTFlags`, :data:`K_NO_GYRO` and the settings both classes
  share.
* :mod:`~pointat.maths.tqt.filter` -- :class:`TQTFilter`, one sensor.
* :mod:`~pointat.maths.tqt.bank` -- :class:`TQTBank`, many sensors.
* :mod:`~pointat.maths.tqt.compiled` -- the bank's robust loop compiled by numba (imported by a bank that
  runs it, not here: numba costs a quarter of a second and ~50 MB to import).

McGhee's equations in numpy, broadcasting over many quaternions (``measurement_model``,
``jacobian_full``, ``gauss_newton``...), are the tests' reference, not the library's:
``tests/maths/mcghee_reference.py``.

>>> f = TQTFilter()
>>> for _ in range(3):
...     q = f.update((0.0, 0.0, 0.0), (0.0, 0.0, 9.81), (20.0, 0.0, -40.0), 0.01)
>>> [round(c, 9) for c in q]                  # level, facing magnetic north: the identity
[1.0, 0.0, 0.0, 0.0]
"""

from __future__ import annotations

from pointat.maths.tqt.bank import TQTBank
from pointat.maths.tqt.filter import TQTFilter
from pointat.maths.tqt.paper import crossover_from_gain, gain_from_crossover
from pointat.maths.tqt.params import K_NO_GYRO, TQTFlags
from pointat.maths.tqt.step import ACC_LIMIT, ACC_RELEARN

__all__ = [
    "ACC_LIMIT",
    "ACC_RELEARN",
    "K_NO_GYRO",
    "gain_from_crossover",
    "crossover_from_gain",
    "TQTFlags",
    "TQTFilter",
    "TQTBank",
]
