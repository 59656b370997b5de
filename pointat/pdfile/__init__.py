r"""Pure Data files (``.pd``): read a Pd patch into a :class:`~pointat.spec.PatchSpec`, write one, write stubs.

**Reading** (:func:`read_pd`).  A Pd file is a list of records, each ending at an unescaped ``;`` (a record
may span lines).  ``\,`` ``\;`` ``\$1`` and ``\ `` are escapes; an unescaped ``,`` inside a record starts
a trailing message such as Pd's box width ``, f 40``, which is ignored.  A token is a number only when it
has no escape and reads as one (``-3``, ``0.5``, ``1e+10``); ``+5``, ``inf`` and ``0x10`` are symbols.

* ``#X obj x y CLASS args...`` is a node of type CLASS.  Atoms ``key=value`` (whose ``=`` is not escaped) are
  pointat's named parameters, the value read by :func:`~pointat.patchfile.parse_value`; the other atoms
  are positional.  A ``[print]`` box's atoms are its prefix, joined as Pd joins them (``[print my label]``
  prints ``my label: ...``; ``a=b`` is a word of it), but for ``time=...`` and ``prefix=...``, and for two
  atoms of which the second is 0 or 1: the prefix and ``time``, the form pointat writes.
* ``#X msg x y content...`` is a node of type ``msg``; an escaped ``,`` / ``;`` stays a ``","`` / ``";"``
  atom, ``\$1`` becomes ``"$1"``.
* ``#X floatatom``, ``symbolatom``, ``listbox``, ``#X scalar`` and GUI objects (``bng``, ``tgl``, ``hsl``...)
  become nodes of that type, so that :func:`pointat.loader.check` reports every one of them (all at once)
  as an unknown node type, with ``file:line (box N)``.
* ``#X text`` comments and ``[declare]`` boxes make no node, but every box counts in the 0-based indices of
  ``#X connect src outlet dst inlet``.  ``#X coords``, ``#X declare``, ``#X f``, ``#X array``, ``#A`` (and
  other data records such as cyclone's ``#C``) are not boxes and are skipped.  Wires keep the order of the connect records: it is Pd's fan-out
  order.
* A subpatch, ``#N canvas ...;`` ... ``#X restore x y pd NAME;``, is one box of its parent.  It is
  flattened: its boxes become nodes named ``NAME/...``; its ``[inlet]`` and ``[outlet]`` objects, ordered
  by x position as in Pd, wire straight through (a wire into inlet k of the subpatch box reaches whatever
  the k-th ``[inlet]`` feeds, in that order).  An array (``#X restore x y graph;``) is one box of type
  ``graph``, which pointat does not know.  ``[inlet]``/``[outlet]`` objects of the top canvas (a Pd
  abstraction file) lead nowhere.

**Comments.**  The comments of the top canvas (all but the ``@name`` ones), read top to bottom, become the
patch's header comment (:attr:`~pointat.spec.PatchSpec.doc`), which a native patch writes as its leading
``#`` lines; comments inside subpatches are left out.

**Node names.**  A comment ``@name NODENAME`` names the next box of its canvas (pointat writes one just
above each box).  A box without one is named ``TYPE_INDEX`` (``metro_1``, ``osc_3`` for ``osc~``); a
subpatch is named by its ``pd NAME``.  Names are reduced to letters, digits and ``_`` (``/`` separates
subpatch levels) and made unique with a ``_2``, ``_3``... suffix.

**Writing** (:func:`write_pd`).  Box 0 is ``[declare -path pointat-stubs]`` (Pd then finds the stub
abstractions written by :func:`write_stubs` next to the patch).  The patch's header comment is drawn above
the nodes, a comment a line (blank lines dropped; written after the nodes' boxes, so that it moves no box
index).  Each node is a ``@name`` comment and,
20 px below it, the node's box.  Columns follow the topological depth of the wires (sources on the
left), at least 160 px apart and wider for long boxes; within a column, rows 50 px apart are ordered by
the mean row of each node's inputs.  Pd's own types (metro, delay, trigger, pack, unpack, route, send,
receive, loadbang, print, msg, change) get positional atoms only, as Pd expects (a ``print`` prefix of
plain words as one atom a word: Pd's ``print`` joins them again, and reading a ``.pd`` file does the
same with a ``[print]`` box's atoms); pointat's other types get
``key=value`` atoms for every parameter that the patch gives or that differs from its default.  Such a value is one symbol atom,
so a float keeps its full precision (Pd writes number atoms with 6 significant digits: a positional float
that would lose digits is logged as a warning).  Symbols that would read as a number or as ``key=value``
are escaped (``\12``, ``a\=b``); Pd keeps that while the patch is open but drops it when it saves.

**Stubs** (:func:`write_stubs`).  One ``TYPE.pd`` abstraction per pointat-only node type, with its inlets
and outlets (for the default parameters, or the type's ``stub_values``) and its doc line, so Pd's editor draws and connects the boxes.

>>> spec = parse_pd("#N canvas 0 50 450 300 12;\n#X obj 10 10 metro 100;\n#X text 10 40 @name out;\n"
...                 "#X obj 10 60 print tick;\n#X connect 0 0 2 0;\n", "t.pd")
>>> [(n.name, n.type, n.args) for n in spec.nodes], [str(w) for w in spec.wires]
([('metro_0', 'metro', [100]), ('out', 'print', ['tick'])], ['metro_0.0 -> out.0'])
"""

from __future__ import annotations

from .common import STUB_FOLDER, VANILLA
from .reading import decode, parse_pd, read_pd
from .writing import write_pd, write_stubs

__all__ = ["STUB_FOLDER", "VANILLA", "decode", "parse_pd", "read_pd", "write_pd", "write_stubs"]
