"""Exceptions of the package.

Every error that mjtrack raises on purpose derives from :class:`MjtrackError`.
The command line maps :class:`InputError` (bad file, bad option, bad parameter)
to exit status 2 and any other :class:`MjtrackError` to exit status 1.
"""

from __future__ import annotations


class MjtrackError(Exception):
    """Base class of every error raised on purpose by mjtrack."""


class InputError(MjtrackError, ValueError):
    """Bad user input: a file, a column, an option or a parameter value.

    The message is one line that names what is wrong (file, column, first bad row).
    """


class SingularMotionError(MjtrackError, ArithmeticError):
    """A quantity is undefined for this motion.

    Raised for instance by the ICR formulas (2.13) when the yaw rate is (near) zero:
    in straight driving the instantaneous centres of rotation lie at infinity.
    """
