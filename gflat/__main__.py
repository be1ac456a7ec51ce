"""``python -m gflat``: the ``gflat`` command line (:func:`harness.cli.main`, also the console script)."""

import sys

from harness.cli import main

__all__ = ["main"]

if __name__ == "__main__":
    sys.exit(main())
