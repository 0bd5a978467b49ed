"""mjtrack: a testbed for tracked (skid-steer) robots.

Subpackages: ``mjtrack.sim`` (the MuJoCo robot), ``mjtrack.models`` (kinematic models, the
rigid-track Coulomb reference, simplified dynamics, wheeled robots), ``mjtrack.estimation``
(slip, ICR and virtual-robot filters), ``mjtrack.validate``, ``mjtrack.diagnose``,
``mjtrack.calibrate``, ``mjtrack.control``, ``mjtrack.render``, ``mjtrack.thesis``,
``mjtrack.io``. The names below are the public API (:mod:`mjtrack.api` holds the functions that
do a whole job). They load on first use (``mjtrack.Robot``), so importing this package loads
nothing heavy (not NumPy, not MuJoCo) and the command line can take Ctrl-C from its first moment.
"""

from mjtrack.errors import InputError as InputError
from mjtrack.errors import MjtrackError as MjtrackError
from mjtrack.errors import SingularMotionError as SingularMotionError

# name -> module it comes from (loaded on first access, PEP 562)
_LAZY = {
    **dict.fromkeys(("calibrate_robot", "coulomb_steady_state", "diagnose_log", "log_icrs", "mujoco_steady_state",
                     "simulate_log", "validate_models"), "mjtrack.api"),
    **dict.fromkeys(("ICR", "icr_from_twist", "twist_from_icr", "virtual_robot_from_twist"), "mjtrack.icr"),
    **dict.fromkeys(("DriveLog", "Robot", "read_log", "read_log_with_robot", "read_robot", "write_log",
                     "write_robot"), "mjtrack.io"),
    **dict.fromkeys(("MICR", "MPP", "MVIR", "Nominal", "integrate"), "mjtrack.models.kinematic"),
}

__version__ = "0.3.0"
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
