import io
import os

import numpy as np
import pytest

os.environ.setdefault("MPLBACKEND", "Agg")


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


class _Terminal(io.StringIO):
    """A stream that says it is a terminal (the progress displays draw only on one) and keeps what is
    drawn on it (``getvalue()``)."""

    def isatty(self) -> bool:
        return True


@pytest.fixture
def terminal():
    """A factory of terminals: ``terminal()`` gives a new one."""
    return _Terminal
