"""Models of tracked-robot motion: kinematic (nominal, MPP, MICR, MVIR)."""

from mjtrack.models.kinematic import MICR as MICR
from mjtrack.models.kinematic import MODELS as MODELS
from mjtrack.models.kinematic import MPP as MPP
from mjtrack.models.kinematic import MVIR as MVIR
from mjtrack.models.kinematic import KinematicModel as KinematicModel
from mjtrack.models.kinematic import Nominal as Nominal
from mjtrack.models.kinematic import integrate as integrate
from mjtrack.models.kinematic import integrate_twist as integrate_twist
