"""mjtrack: a testbed for tracked (skid-steer) robots.

Subpackages: ``mjtrack.sim`` (the MuJoCo robot), ``mjtrack.models`` (kinematic models, the
rigid-track Coulomb reference, simplified dynamics, wheeled robots), ``mjtrack.estimation``
(slip, ICR and virtual-robot filters), ``mjtrack.validate``, ``mjtrack.diagnose``,
``mjtrack.control``, ``mjtrack.render``, ``mjtrack.thesis``, ``mjtrack.io``. The names below
are the ones most scripts need; they load on first use (``mjtrack.Robot``), so importing this
package loads nothing heavy (not NumPy, not MuJoCo) and the command line can take Ctrl-C from
its first moment on.
"""

from mjtrack.errors import InputError as InputError
from mjtrack.errors import MjtrackError as MjtrackError
from mjtrack.errors import SingularMotionError as SingularMotionError

# name -> module it comes from (loaded on first access, PEP 562)
_LAZY = {
    "ICR": "mjtrack.icr", "icr_from_twist": "mjtrack.icr", "twist_from_icr": "mjtrack.icr",
    "virtual_robot_from_twist": "mjtrack.icr",
    "DriveLog": "mjtrack.io", "Robot": "mjtrack.io", "read_log": "mjtrack.io", "read_robot": "mjtrack.io",
    "write_log": "mjtrack.io",
    "MICR": "mjtrack.models.kinematic", "MPP": "mjtrack.models.kinematic", "MVIR": "mjtrack.models.kinematic",
    "Nominal": "mjtrack.models.kinematic", "integrate": "mjtrack.models.kinematic",
}

__version__ = "0.1.0"
__all__ = ["InputError", "MjtrackError", "SingularMotionError", *_LAZY, "__version__"]


def __getattr__(name: str):
    if name in _LAZY:
        import importlib

        value = getattr(importlib.import_module(_LAZY[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'mjtrack' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))
