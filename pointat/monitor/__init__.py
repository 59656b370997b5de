"""The monitor: what a running patch is doing, told to people (``pointat run --monitor``).

* :mod:`~pointat.monitor.observe`: the :class:`Observer`, which watches a runtime from a thread of its own
  (sensor streams, pointers, flags, health) for the console's status lines and the page;
* :mod:`~pointat.monitor.webserver`: the :class:`MonitorServer`, the page and its WebSocket (the
  websockets library) and OSCQuery on one port;
* :mod:`~pointat.monitor.webaccess`: who may connect (Host, Origin, allow-list, token);
* :mod:`~pointat.monitor.oscquery`: the patch's OSC address space as OSCQuery describes it;
* ``index.html``, ``monitor.js``, ``monitor.css``: the page.

What each shows of a node comes from the node's declarations (:attr:`pointat.node.Node.role`,
:attr:`~pointat.node.Node.readings`, :meth:`~pointat.node.Node.health`), never from its type's name.
"""

from .observe import Observer
from .webserver import MonitorServer

__all__ = ["MonitorServer", "Observer"]
