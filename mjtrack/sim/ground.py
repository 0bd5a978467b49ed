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
* ``shear`` (shear_modulus K): Janosi-Hanamoto friction. MuJoCo's contact is Coulomb; the
  contact elements sit at fixed body points (the surface-velocity track's elements, the roller
  chain's rollers, the wheels' axles), so the belt element over each is known, and its pair
  friction is set to mu (1 - exp(-j/K)) (eq. S1 of :mod:`mjtrack.models.shear`), j the shear
  displacement (S2) of the belt element over it in the steady turn of the body's present twist:
  exact in a steady turn, quasi-steady in a transient. The surfacevel model's step loop does so
  before every step (:class:`ShearFriction`, the twist low-passed over ``TWIST_FILTER_S``); the
  roller chain and the wheels, which run through ``mujoco.rollout``, before every chunk of
  ``SHEAR_UPDATE_S``, each rollout on its own model copy (:class:`ShearChunks`; a wheel's pair
  takes the mean over its tyre's contact patch, S3). With ``lateral_shear_ratio`` rho_K != 1 the
  friction builds up with modulus K along the track or tyre and rho_K K across it (S6): each pair
  gets (mu (1 - exp(-j/(rho_K K))), mu (1 - exp(-j/K))) on the tangent frame of the anisotropic
  ground's capsules (:func:`track_frames`), whose elliptic cone gives the maximum-dissipation
  force on that ellipse.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from mjtrack.errors import InputError
from mjtrack.io.robot import G, Robot
from mjtrack.models.shear import (DEFAULT_PATCH_LENGTH, PATCH_POINTS, lateral_shear_ratio_of, shear_displacement,
                                  shear_factor)
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
#: [s] how often the roller chain's and the wheels' shear ground sets its friction again: each
#: rollout runs in chunks this long (:class:`ShearChunks`; the surfacevel step loop: every step)
SHEAR_UPDATE_S = 0.02
#: [m/s] a side of the roller chain or the wheels slower than this is stopped (S2: its elements
#: have slid for ever, full friction). Its drive holds it near, not at, 0 (measured: 1 mm/s in a
#: pivot about it, with excursions beyond); at such speeds an element stays under the body for
#: tens of seconds, and its steady-turn displacement (S2) is a chord of a circle it went round
#: many times, set by the exact speed, not by the ground (the reference has no steady state
#: there for K = 0.1 m between 0.1 and 1 mm/s)
STOPPED_SPEED = 1e-2


def load_shares(robot: Robot, roller_x: np.ndarray) -> np.ndarray:
    """w (n,): roller i (at ``roller_x[i]`` [m] along the track, evenly spaced) carries w_i / n of
    a track's static load; all ones unless the ground is ``road_wheels`` (module docstring)."""
    return robot.ground.load_shares(roller_x, robot.track_length)


def require_supported(robot: Robot, config: SimConfig) -> None:
    """Refuse a ground model that the chosen track model does not realise (surfacevel: coulomb and
    isotropic shear; the roller chain and the wheels: all)."""
    if robot.ground.model == "shear":
        if config.track_model != "rollers" and robot.ground["lateral_shear_ratio"] != 1.0:
            raise InputError(f"robot: the shear ground's lateral_shear_ratio != 1 is built for the roller chain and the "
                             f"wheels only (track model {config.track_model!r} has the isotropic shear ground)")
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
    elif model == "shear" and framed(robot):
        track_frames(spec, robot, config)
    return spec


def framed(robot: Robot) -> bool:
    """Whether the robot's contact pairs need the track's tangent frame (:func:`track_frames`):
    an anisotropic ground, or a shear ground whose moduli differ along and across."""
    g = robot.ground
    return g.model == "anisotropic" or (g.model == "shear" and g["lateral_shear_ratio"] != 1.0)


def track_frames(spec: mujoco.MjSpec, robot: Robot, config: SimConfig) -> None:
    """Turn each roller (wheel) into a capsule of the same radius along its spin axis, so that its
    pair's first tangent is across the track (module docstring, ``anisotropic``)."""
    r = config.roller_radius  # (the wheel radius on a wheeled robot: its configured SimConfig)
    element = "wheel" if robot.traction == "wheels" else "roller"
    for side in SIDES:
        for i in range(config.n_rollers):
            geom = spec.geom(f"{element}_{side}_{i}")
            geom.type = mujoco.mjtGeom.mjGEOM_CAPSULE
            geom.size = [r, CAPSULE_HALF, 0.0]
            geom.quat = [math.sqrt(0.5), math.sqrt(0.5), 0.0, 0.0]  # capsule z-axis -> body y


def framed_robot(robot: Robot) -> Robot:
    """The robot to compile when variants may set a ``lateral_shear_ratio``: on a shear ground of
    its own K (Coulomb: K = 0) with the track's contact frames (a ratio marks it; each variant's
    friction is set per chunk by :class:`ShearChunks`, which reads its ratio from the variant or
    from the robot itself, never from this build)."""
    if framed(robot):
        return robot
    if robot.ground.model not in ("shear", "coulomb"):
        raise InputError(f"robot: a lateral_shear_ratio needs the shear or the Coulomb ground, not {robot.ground.model!r}")
    K = robot.ground["shear_modulus"] if robot.ground.model == "shear" else 0.0
    return robot.replace(ground={"model": "shear", "shear_modulus": K, "lateral_shear_ratio": 2.0})


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
    track_frames(spec, robot, config)
    for side, mu in (("left", robot.friction_left), ("right", robot.friction_right)):
        for i in range(config.n_rollers):
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


class ShearChunks:
    """The shear ground on the roller chain or the wheels, for batched rollouts: before each chunk
    of :data:`SHEAR_UPDATE_S`, each rollout's own model copy gets pair friction mu_side (1 -
    exp(-j/K)) (at least ``FRICTION_FLOOR`` mu_side), j the shear displacement (S2 of
    :mod:`mjtrack.models.shear`) in the steady turn of that rollout's present body twist and side
    speeds: quasi-steady, updated every chunk. A roller is a point of the track at its x (the track's
    ends its entry points); a wheel's pair takes the mean over its tyre's contact patch
    (``DEFAULT_PATCH_LENGTH`` centred under the axle, entered at its front), as the reference's (S3).

    ``model``: the compiled robot (or a variant: its pair friction is the Coulomb mu_side);
    ``shear_modulus``: K [m] (default the robot's ground parameter); ``lateral_shear_ratio``: the
    modulus across over the one along (default the robot's ground parameter, 1 on another ground);
    other than 1 it needs a model with the track's contact frames (:func:`framed_robot`).
    """

    def __init__(self, model: mujoco.MjModel, robot: Robot, shear_modulus: float | None = None,
                 lateral_shear_ratio: float | None = None) -> None:
        n = sum(model.pair(i).name.startswith("contact_left_") for i in range(model.npair))  # elements a side
        self.K = float(robot.ground["shear_modulus"] if shear_modulus is None else shear_modulus)
        self.ratio = lateral_shear_ratio_of(robot, lateral_shear_ratio)
        element = "wheel" if robot.traction == "wheels" else "roller"
        if self.ratio != 1.0 and model.geom(f"{element}_left_0").type != mujoco.mjtGeom.mjGEOM_CAPSULE:
            raise InputError("windows: a lateral_shear_ratio other than 1 needs a robot built with the track's "
                             "contact frames (mjtrack.sim.ground.framed_robot)")
        self.every = max(1, int(round(SHEAR_UPDATE_S / model.opt.timestep)))
        self.pairs = np.array([model.pair(f"contact_{s}_{i}").id for s in SIDES for i in range(n)])
        self.mu = model.pair_friction[self.pairs, 1].copy()  # the longitudinal (isotropic) Coulomb mu
        x = np.concatenate([element_positions(robot, n)] * 2)
        left = np.arange(2 * n) < n
        if robot.traction == "wheels":
            lp = DEFAULT_PATCH_LENGTH
            s = ((np.arange(PATCH_POINTS) + 0.5) / PATCH_POINTS - 0.5) * lp
            self.x = (x[:, None] + s[None]).ravel()
            self.x_entry = np.stack([np.repeat(x + lp / 2, PATCH_POINTS), np.repeat(x - lp / 2, PATCH_POINTS)], -1)
            self.points = PATCH_POINTS
        else:
            L = robot.track_length
            self.x, self.x_entry, self.points = x, np.tile([L / 2, -L / 2], (2 * n, 1)), 1
        self.left = np.repeat(left, self.points)
        self.y = np.where(self.left, robot.track_gauge / 2, -robot.track_gauge / 2)
        root = model.joint("root")
        q0, v0 = 1, 1 + model.nq  # qpos and qvel in an mjSTATE_FULLPHYSICS state (after the time)
        self.quat = q0 + int(root.qposadr[0]) + 3 + np.arange(4)
        self.lin = v0 + int(root.dofadr[0]) + np.arange(2)
        self.wz = v0 + int(root.dofadr[0]) + 5
        self.spin = [v0 + np.array([int(model.joint(f"roll_{s}_{i}").dofadr[0]) for i in range(n)]) for s in SIDES]
        self.radius = float(model.geom(f"{element}_left_0").size[0])  # the roller's (wheel's) radius

    def friction(self, states: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(M, npairs) the pairs' friction across and along the track for rollouts at ``states`` (M,
        nstate) (the same array twice when the moduli are equal)."""
        q = states[:, self.quat]
        yaw = np.arctan2(2 * (q[:, 0] * q[:, 3] + q[:, 1] * q[:, 2]), 1 - 2 * (q[:, 2] ** 2 + q[:, 3] ** 2))
        c, s = np.cos(yaw), np.sin(yaw)
        vw = states[:, self.lin]
        vx, vy = c * vw[:, 0] + s * vw[:, 1], -s * vw[:, 0] + c * vw[:, 1]
        wz = states[:, self.wz]
        side = np.stack([states[:, d].mean(axis=1) for d in self.spin], -1) * self.radius  # (M, 2)
        side = np.where(np.abs(side) < STOPPED_SPEED, 0.0, side)
        V = np.where(self.left[None], side[:, :1], side[:, 1:])
        j = shear_displacement(self.x, self.y, self.x_entry, V, (vx[:, None], vy[:, None], wz[:, None]))

        def mu_of(K):
            build = shear_factor(j, K).reshape(len(states), -1, self.points).mean(axis=2)
            return self.mu[None] * np.maximum(build, FRICTION_FLOOR)

        along = mu_of(self.K)
        return (along if self.ratio == 1.0 else mu_of(self.ratio * self.K)), along

    def apply(self, models, states: np.ndarray) -> None:
        """Set each of ``models`` (one per rollout, copies) to the friction of its state (first
        tangent: across the track on the capsules of :func:`track_frames`; equal on a sphere)."""
        across, along = self.friction(states)
        for m, a, b in zip(models, across, along):
            m.pair_friction[self.pairs, 0] = a
            m.pair_friction[self.pairs, 1] = b


class _Grounds:
    """Per-rollout grounds of a batch as one: each group of rollouts that shares a ground is set by it."""

    def __init__(self, grounds: list) -> None:
        self.groups: list[tuple[ShearChunks, list[int]]] = []
        for k, g in enumerate(grounds):
            if g is None:
                continue
            for have, idx in self.groups:
                if have is g:
                    idx.append(k)
                    break
            else:
                self.groups.append((g, [k]))
        self.every = min(g.every for g, _ in self.groups)

    def apply(self, models, states: np.ndarray) -> None:
        for g, idx in self.groups:
            g.apply([models[k] for k in idx], states[idx])


def batch_ground(grounds, nbatch: int):
    """What a batch of ``nbatch`` rollouts sets before each chunk (:func:`mjtrack.sim.rollout.aligned_rollout`):
    ``grounds`` one per rollout, or one for all (each None or a :class:`ShearChunks`); None when none is."""
    grounds = list(grounds) if isinstance(grounds, (list, tuple)) else [grounds]
    if len(grounds) == 1:
        grounds = grounds * nbatch
    if len(grounds) != nbatch:
        raise ValueError(f"batch_ground: {len(grounds)} grounds for {nbatch} rollouts")
    return _Grounds(grounds) if any(g is not None for g in grounds) else None


def chunk_ground(model: mujoco.MjModel, robot: Robot, config: SimConfig,
                 shear_modulus: float | None = None, lateral_shear_ratio: float | None = None) -> ShearChunks | None:
    """The roller chain's or the wheels' per-chunk ground update of ``model`` (None: nothing to set):
    the shear ground of the robot, or of a variant's ``shear_modulus`` K > 0 (K = 0: Coulomb), with
    the variant's ``lateral_shear_ratio`` (default the robot's)."""
    if config.track_model != "rollers":
        return None
    if shear_modulus is not None and not (math.isfinite(shear_modulus) and shear_modulus >= 0.0):
        raise InputError(f"windows: shear_modulus must be a number >= 0 [m], got {shear_modulus!r}")
    if shear_modulus is None:
        return ShearChunks(model, robot, None, lateral_shear_ratio) if robot.ground.model == "shear" else None
    return ShearChunks(model, robot, shear_modulus, lateral_shear_ratio) if shear_modulus > 0 else None


def ground_stepper(model: mujoco.MjModel, robot: Robot, config: SimConfig) -> ShearFriction | None:
    """What a surfacevel step loop must call before each step for the robot's ground (None: nothing)."""
    return ShearFriction(model, robot, config) if robot.ground.model == "shear" else None
