"""``python -m pointat.cli``: the ``pointat`` command."""

import sys

from . import main

if __name__ == "__main__":
    sys.exit(main())
