"""Models of tracked-robot motion: kinematic (nominal, MPP, MICR, MVIR), the rigid-track Coulomb
reference, the shear-displacement ground reference and the simplified tracked dynamics (2.4)–(2.6)."""

from mjtrack.models.kinematic import MICR as MICR
from mjtrack.models.kinematic import MODELS as MODELS
from mjtrack.models.kinematic import MPP as MPP
from mjtrack.models.kinematic import MVIR as MVIR
from mjtrack.models.kinematic import KinematicModel as KinematicModel
from mjtrack.models.kinematic import Nominal as Nominal
from mjtrack.models.kinematic import integrate as integrate
from mjtrack.models.kinematic import integrate_twist as integrate_twist
from mjtrack.models.coulomb import CoulombRollout as CoulombRollout
from mjtrack.models.coulomb import PivotTurn as PivotTurn
from mjtrack.models.coulomb import SteadyState as SteadyState
from mjtrack.models.coulomb import contact_wrench as contact_wrench
from mjtrack.models.coulomb import normal_loads as normal_loads
from mjtrack.models.coulomb import pivot_turn_closed_form as pivot_turn_closed_form
from mjtrack.models.coulomb import rollout as coulomb_rollout  # noqa: F401 (re-exported under a longer name)
from mjtrack.models.coulomb import steady_state as steady_state
from mjtrack.models.dynamics import TrackedDynamics as TrackedDynamics
from mjtrack.models.dynamics import lateral_friction_force as lateral_friction_force
from mjtrack.models.dynamics import simulate as simulate_dynamics  # noqa: F401 (re-exported under a longer name)
from mjtrack.models.dynamics import turning_resistance_moment as turning_resistance_moment
