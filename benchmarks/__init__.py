"""pointat's benchmarks: latency and jitter, throughput, accuracy and memory, side by side with peers.

Run ``python -m benchmarks [--quick] [--data DIR] [--out benchmarks/REPORT.md]``; see ``benchmarks/README.md``.

* :mod:`benchmarks.latency` -- a sample in (mote frame into a pseudo-terminal, or OSC over UDP), its OSC
  datagram out, through pointat's chains and through the transport floors (python-osc relay, Pd relay).
  :mod:`benchmarks.work` runs samples through one osc_in path for callgrind to count instructions.
* :mod:`benchmarks.throughput` -- samples per second through the patches on one core, the cost of each
  node, and of the pure filters against ``ahrs``, ``imufusion`` and ``vqf``.
* :mod:`benchmarks.accuracy` -- RMS orientation error on the BROAD recordings with the data set's metric.
* :mod:`benchmarks.memory` -- peak resident memory of a running patch and its growth over time.
* :mod:`benchmarks.report` -- the Markdown report and its SVG figures.
"""
