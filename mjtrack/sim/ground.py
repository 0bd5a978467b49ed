"""Ground models beyond rigid-track isotropic Coulomb, applied to the MuJoCo robot's ``MjSpec``.

The robot key ``ground`` (:class:`mjtrack.io.robot.Ground`) names the model; :func:`apply_ground`
is the one hook the builder calls, after the robot and its scene are in the spec. It changes
named elements only (springs ``susp_<side>_<i>``, geoms ``roller_<side>_<i>``, contact pairs
``contact_<side>_<i>``), so the rest of the robot is the same for every ground. Derivations and
measurements: ``assets/README.md`` ("Ground models").

* ``coulomb``: nothing changes (the builder's ground).
* ``road_wheels`` (wheels n_w, concentration c, span s): the share of the weight that roller i
  carries at rest is w_i / N with w_i = (1 - c) + c N a_i, where a_i is the part of the n_w
  equal wheel loads at X_j = s (-L/2 + (j + 1/2) L / n_w) that falls on roller i by linear
  interpolation between the two rollers around X_j (a hat function on the roller grid: it keeps
  each wheel's load and its moment about the track centre). sum w_i = N. The roller's spring
  gets stiffness w_i k and preload w_i W / (2N) - m_r g (static deflection unchanged), so the
  chassis still deflects as a rigid plane and roller i carries w_i k delta_i: the shape w times
  Wong's linear distribution from the cg offset. Damping is left at the builder's value (a
  stiffer roller would otherwise break the explicit-damper limit c dt / m_r < 1.5).
* ``anisotropic`` (lateral_ratio rho): friction mu along the track, rho mu across it, in the
  track's frame. MuJoCo orients the tangent frame of a sphere-plane contact by the plane
  (world axes), but that of a capsule-plane contact by the capsule's axis (measured:
  tests/test_ground.py). Each roller becomes a capsule of the same radius whose axis is the
  roller's spin axis (chassis y, unchanged by its rolling) and whose half-length is
  ``CAPSULE_HALF`` (two contact points 2 mm apart, one on each side of the track line); its
  pair gets friction (rho mu, mu): the first tangent is the capsule axis. A wheeled robot's wheels
  (``wheel_<side>_<i>``, the same spheres on their axles) get the same: lateral tyre friction
  rho mu, longitudinal mu. The elliptic cone
  (f_lat / (rho mu))^2 + (f_long / mu)^2 <= f_n^2 with the noslip pass's hard friction gives the
  maximum-dissipation force on that ellipse, f = -f_n M^2 u / |M u|, M = diag(mu, rho mu).
* ``shear`` (shear_modulus K): Janosi-Hanamoto friction, on the surface-velocity track model
  only (its contact elements sit at fixed body points, so the belt element over each is known).
  MuJoCo's contact is Coulomb; :class:`ShearFriction` sets each element's pair friction before
  every step to mu (1 - exp(-j/K)) (eq. S1 of :mod:`mjtrack.models.shear`), j the shear
  displacement (S2) of the belt element over it in the steady turn of the body's present twist
  (low-passed over ``TWIST_FILTER_S``): exact in a steady turn, quasi-steady in a transient.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from mjtrack.errors import InputError
from mjtrack.io.robot import G, Robot
from mjtrack.models.shear import shear_displacement, shear_factor
from mjtrack.sim.chassis import element_positions, suspension_stiffness
from mjtrack.sim.config import SimConfig
from mjtrack.sim.scene import SIDES

CAPSULE_HALF = 0.001  # [m] half-length of an anisotropic roller's capsule (across the track)
#: [s] low-pass of the twist the shear displacement is computed from: it keeps the friction from
#: following the contact solver's step-to-step jitter; 10 steps of the surfacevel model
TWIST_FILTER_S = 0.02
#: friction floor of a contact whose shear has not built up, as a share of mu (a zero friction
#: coefficient on a condim-3 pair is a degenerate cone)
FRICTION_FLOOR = 1e-4


def load_shares(robot: Robot, roller_x: np.ndarray) -> np.ndarray:
    """w (n,): roller i (at ``roller_x[i]`` [m] along the track, evenly spaced) carries w_i / n of
    a track's static load; all ones unless the ground is ``road_wheels`` (module docstring)."""
    return robot.ground.load_shares(roller_x, robot.track_length)


def require_supported(robot: Robot, config: SimConfig) -> None:
    """Refuse a ground model that the chosen track model does not realise (surfacevel: coulomb and
    shear; the roller chain: all but shear)."""
    if robot.ground.model == "shear":
        if config.track_model != "surfacevel" or robot.traction == "wheels":
            raise InputError("robot: ground model 'shear' is built for the surfacevel track model of a tracked "
                             "robot only (simulator track_model \"surfacevel\"); its reference is "
                             "mjtrack.models.shear")
        return
    if config.track_model != "rollers" and not robot.ground.is_default:
        raise InputError(f"robot: ground model {robot.ground.model!r} is built for the roller chain only "
                         f"(track model {config.track_model!r} has the coulomb ground)")


def apply_ground(spec: mujoco.MjSpec, robot: Robot, config: SimConfig) -> mujoco.MjSpec:
    """Realise ``robot.ground`` in a roller-chain spec that has its scene (in place; returned)."""
    require_supported(robot, config)
    model = robot.ground.model
    if model == "coulomb":
        return spec
    if model == "road_wheels":
        _road_wheels(spec, robot, config)
    elif model == "anisotropic":
        _anisotropic(spec, robot, config)
    return spec


def _road_wheels(spec: mujoco.MjSpec, robot: Robot, config: SimConfig) -> None:
    n = config.n_rollers
    w = load_shares(robot, np.array([spec.body(f"roller_left_{i}").pos[0] for i in range(n)]))
    k = suspension_stiffness(robot, config, n)
    m_r = config.roller_mass(robot.mass)
    for side in SIDES:
        for i in range(n):
            joint = spec.joint(f"susp_{side}_{i}")
            preload = w[i] * robot.weight / (2 * n) - m_r * G
            joint.stiffness = [w[i] * k, 0.0, 0.0]
            joint.springref = -preload / (w[i] * k)


def _anisotropic(spec: mujoco.MjSpec, robot: Robot, config: SimConfig) -> None:
    rho = robot.ground["lateral_ratio"]
    r = config.roller_radius  # (the wheel radius on a wheeled robot: its configured SimConfig)
    element = "wheel" if robot.traction == "wheels" else "roller"
    for side, mu in (("left", robot.friction_left), ("right", robot.friction_right)):
        for i in range(config.n_rollers):
            geom = spec.geom(f"{element}_{side}_{i}")
            geom.type = mujoco.mjtGeom.mjGEOM_CAPSULE
            geom.size = [r, CAPSULE_HALF, 0.0]
            geom.quat = [math.sqrt(0.5), math.sqrt(0.5), 0.0, 0.0]  # capsule z-axis -> body y
            pair = spec.pair(f"contact_{side}_{i}")
            pair.friction = [rho * mu, mu, 0.0, 0.0, 0.0]


class ShearFriction:
    """The shear ground on a surfacevel model: call :meth:`update` before every ``mj_step``.

    Each track element's pair ``contact_<side>_<i>`` gets friction mu_side (1 - exp(-j/K)) from the
    shear displacement j of the belt element over it (module docstring), at least
    ``FRICTION_FLOOR`` mu_side. Elements at the cell midpoints of L (the surfacevel model's).
    """

    def __init__(self, model: mujoco.MjModel, robot: Robot, config: SimConfig) -> None:
        n = config.n_rollers
        self.model, self.K = model, robot.ground["shear_modulus"]
        self.pairs = np.array([model.pair(f"contact_{s}_{i}").id for s in SIDES for i in range(n)])
        xe = element_positions(robot, n)
        self.x = np.concatenate([xe, xe])
        self.left = np.arange(2 * n) < n
        self.y = np.where(self.left, robot.track_gauge / 2, -robot.track_gauge / 2)
        L = robot.track_length
        self.x_entry = np.tile([L / 2, -L / 2], (2 * n, 1))
        self.mu = np.where(self.left, robot.friction_left, robot.friction_right)
        self.lin = int(model.sensor("body_linvel").adr[0])
        self.ang = int(model.sensor("body_angvel").adr[0])
        self.alpha = 1.0 - math.exp(-model.opt.timestep / TWIST_FILTER_S)
        self.twist: np.ndarray | None = None

    def update(self, data: mujoco.MjData, v_left: float, v_right: float) -> None:
        """Set the pairs' friction for the next step, the tracks running at v_left, v_right [m/s]."""
        s = data.sensordata
        now = np.array([s[self.lin], s[self.lin + 1], s[self.ang + 2]])
        self.twist = now if self.twist is None else self.twist + self.alpha * (now - self.twist)
        V = np.where(self.left, v_left, v_right)
        mu = self.mu * np.maximum(shear_factor(shear_displacement(self.x, self.y, self.x_entry, V, self.twist),
                                               self.K), FRICTION_FLOOR)
        self.model.pair_friction[self.pairs, 0] = mu
        self.model.pair_friction[self.pairs, 1] = mu


def ground_stepper(model: mujoco.MjModel, robot: Robot, config: SimConfig) -> ShearFriction | None:
    """What a surfacevel step loop must call before each step for the robot's ground (None: nothing)."""
    return ShearFriction(model, robot, config) if robot.ground.model == "shear" else None
