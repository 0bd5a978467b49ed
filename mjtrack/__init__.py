"""mjtrack: a testbed for tracked (skid-steer) robots.

Subpackages: ``mjtrack.sim`` (the MuJoCo robot), ``mjtrack.models`` (kinematic models, the
rigid-track Coulomb reference, simplified dynamics, wheeled robots), ``mjtrack.estimation``
(slip, ICR and virtual-robot filters), ``mjtrack.validate``, ``mjtrack.diagnose``,
``mjtrack.calibrate``, ``mjtrack.control``, ``mjtrack.render``, ``mjtrack.thesis``,
``mjtrack.io``. The names below are the public API (:mod:`mjtrack.api` holds the functions that
do a whole job); importing this package does not load MuJoCo.
"""

from mjtrack.api import calibrate_robot as calibrate_robot
from mjtrack.api import coulomb_steady_state as coulomb_steady_state
from mjtrack.api import diagnose_log as diagnose_log
from mjtrack.api import log_icrs as log_icrs
from mjtrack.api import mujoco_steady_state as mujoco_steady_state
from mjtrack.api import simulate_log as simulate_log
from mjtrack.api import validate_models as validate_models
from mjtrack.errors import InputError as InputError
from mjtrack.errors import MjtrackError as MjtrackError
from mjtrack.errors import SingularMotionError as SingularMotionError
from mjtrack.icr import ICR as ICR
from mjtrack.icr import icr_from_twist as icr_from_twist
from mjtrack.icr import twist_from_icr as twist_from_icr
from mjtrack.icr import virtual_robot_from_twist as virtual_robot_from_twist
from mjtrack.io import DriveLog as DriveLog
from mjtrack.io import Robot as Robot
from mjtrack.io import read_log as read_log
from mjtrack.io import read_log_with_robot as read_log_with_robot
from mjtrack.io import read_robot as read_robot
from mjtrack.io import write_log as write_log
from mjtrack.io import write_robot as write_robot
from mjtrack.models.kinematic import MICR as MICR
from mjtrack.models.kinematic import MPP as MPP
from mjtrack.models.kinematic import MVIR as MVIR
from mjtrack.models.kinematic import Nominal as Nominal
from mjtrack.models.kinematic import integrate as integrate

__version__ = "0.1.0"
