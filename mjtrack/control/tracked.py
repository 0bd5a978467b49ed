"""A tracked-robot kinematic model (mjtrack.models.kinematic) as a plant for the controllers.

:class:`TrackedKinematic` wraps any :class:`~mjtrack.models.kinematic.KinematicModel`
(nominal, MPP, MICR, MVIR) in the wheeled-model interface of
:mod:`mjtrack.models.wheeled.base`: state (x, y, yaw) of the geometric centre, input the
track speeds (V_L, V_R) [m/s], derivative = (Rot(yaw) (vx, vy), wz) with the model's twist
(2.3).  :func:`~mjtrack.control.interface.adapter_for` pairs it with the
:class:`~mjtrack.control.interface.TrackSpeedAdapter` V_L = v - w T/2, V_R = v + w T/2, so
every controller of this package drives it unchanged (and, the same way, the MuJoCo robot).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mjtrack.errors import InputError
from mjtrack.models.kinematic import KinematicModel
from mjtrack.models.wheeled.base import PlanarKinematic


@dataclass(frozen=True)
class TrackedKinematic(PlanarKinematic):
    """Kinematic tracked robot: ``model`` gives the twist, ``track_gauge`` T [m] the adapter's gauge."""

    model: KinematicModel
    track_gauge: float

    n_input = 2
    input_names = ("v_left [m/s]", "v_right [m/s]")

    def __post_init__(self) -> None:
        if not (math.isfinite(self.track_gauge) and self.track_gauge > 0):
            raise InputError(f"TrackedKinematic: 'track_gauge' must be positive, got {self.track_gauge!r}")

    def body_twist(self, u) -> tuple[float, float, float]:
        """The kinematic model's twist for track speeds u = (V_L, V_R) [m/s]."""
        vx, vy, wz = np.asarray(self.model.twist(u[0], u[1]), dtype=float)
        return float(vx), float(vy), float(wz)
