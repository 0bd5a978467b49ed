"""Wheeled-robot models of the wheeled-robot thesis (Jonszta 2008; docs/theory/wheeled.md).

Differential drive: kinematic (1.1)-(1.4), dynamic model 1 (1.5)-(1.8), dynamic model 2
(1.9)-(1.15); four-wheel skid steer (1.16)-(1.20); Ackermann kinematics (1.21)-(1.23).
All share the interface of :class:`~mjtrack.models.wheeled.base.WheeledModel` and integrate
with the fixed-step RK4 of :func:`~mjtrack.models.wheeled.base.rk4_step`.
"""

from mjtrack.models.wheeled.ackermann import Ackermann as Ackermann
from mjtrack.models.wheeled.ackermann import steering_angles as steering_angles
from mjtrack.models.wheeled.base import WheeledModel as WheeledModel
from mjtrack.models.wheeled.base import rk4 as rk4
from mjtrack.models.wheeled.base import rk4_step as rk4_step
from mjtrack.models.wheeled.base import simulate as simulate
from mjtrack.models.wheeled.base import wheel_friction as wheel_friction
from mjtrack.models.wheeled.diffdrive import DiffDriveKinematic as DiffDriveKinematic
from mjtrack.models.wheeled.diffdrive import body_speeds as body_speeds
from mjtrack.models.wheeled.diffdrive import wheel_speeds as wheel_speeds
from mjtrack.models.wheeled.dynamic1 import DiffDriveDynamic1 as DiffDriveDynamic1
from mjtrack.models.wheeled.dynamic2 import DiffDriveDynamic2 as DiffDriveDynamic2
from mjtrack.models.wheeled.skidsteer4 import SkidSteer4 as SkidSteer4
