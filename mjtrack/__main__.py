"""``python -m mjtrack COMMAND ...``: the same as the ``mjtrack`` console script."""

import sys

from mjtrack.cli import main

sys.exit(main())
