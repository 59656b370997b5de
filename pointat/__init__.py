"""pointat: a dataflow toolkit for pointing with a hand-worn IMU (placeholder, filled in below)."""

__version__ = "0.1.0"
