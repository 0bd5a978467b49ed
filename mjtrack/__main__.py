"""``python -m mjtrack``: the command line (same as the ``mjtrack`` console script)."""

import sys

from mjtrack.cli import main

if __name__ == "__main__":  # guarded: dask's worker processes (spawn) import this module again
    sys.exit(main())
