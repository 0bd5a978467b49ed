"""The surrogate baselines of a diagnosis and their fit: cheap models of the robot's skid-steer
response that a diagnosis extends by effects.

:mod:`.response` the first-order Coulomb response of a robot (quasi-static ICRs, inertial and
slope response, friction-limited transients); :mod:`.model` the surrogate's body twist under the
logged commands extended by the effects; :mod:`.fit` the least-squares fit of an effect;
:mod:`.baseline` the :class:`SurrogateBaseline` (Coulomb surrogate or kinematic model) and the
problem it is diagnosed on. Nothing here imports MuJoCo.
"""

from mjtrack.diagnose.surrogate.baseline import MODEL_REL as MODEL_REL
from mjtrack.diagnose.surrogate.baseline import SurrogateBaseline as SurrogateBaseline
from mjtrack.diagnose.surrogate.model import Surrogate as Surrogate
from mjtrack.diagnose.surrogate.response import GroundResponse as GroundResponse
from mjtrack.diagnose.surrogate.response import accel_limited as accel_limited
from mjtrack.diagnose.surrogate.response import centripetal as centripetal
from mjtrack.diagnose.surrogate.response import friction_limited as friction_limited
from mjtrack.diagnose.surrogate.response import ground_response as ground_response
from mjtrack.diagnose.surrogate.response import static_table as static_table
from mjtrack.diagnose.surrogate.response import twist_from_q as twist_from_q

__all__ = ["MODEL_REL", "GroundResponse", "Surrogate", "SurrogateBaseline", "accel_limited", "centripetal",
           "friction_limited", "ground_response", "static_table", "twist_from_q"]
