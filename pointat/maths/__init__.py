r"""Pure orientation math for pointat: plain functions on floats and numpy arrays.

Nothing in this package imports the engine (``pointat.node``, ``pointat.runtime``...), so the
functions can be used, tested and benchmarked on their own.

Conventions, stated once
------------------------
* Quaternions are **scalar first** ``(w, x, y, z)``, unit, and map the **sensor frame to the earth
  frame**: ``v_earth = q ⊗ (0, v_sensor) ⊗ q*``.  Any other order (ZIG SIM sends ``w`` last) is a named
  conversion at an adapter.
* The **earth frame is NWU**: x north (magnetic north unless a reference pose says otherwise), y west,
  z up.  This is Torre et al.'s frame (x north, y west) made right-handed (their z "down" with x north and
  y west is left-handed).  Gravity at rest reads ``+g`` along earth z; the Earth field points north and
  *down* by the dip angle: ``(cos dip, 0, -sin dip)``.  The seeds' NED form and a data set's ENU form are
  converted at the edges (:func:`pointat.maths.quaternion.nwu_to_enu`).
* The **sensor frame** of the glove is Torre's (u, v, w): x along the hand (the pointing / roll axis),
  y to the left across the back of the hand, z out of the back of the hand.
* Angles are **radians inside**; degrees only where a parameter says so (``degrees=True``) and in
  azimuth / elevation, which follow ADM-OSC: degrees, 0 = front, **positive = left**, -180..180;
  elevation -90..90, positive = up.
* Angular rates are rad/s, accelerations m/s² (specific force), magnetic fields in any consistent unit.
"""
