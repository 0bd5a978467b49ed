"""MuJoCo model of a two-track robot as a chain of sprung contact rollers (``mujoco.MjSpec``).

The roller chain is the default track model (:data:`ROLLER_CHAIN`) plugged into the one robot
builder of :mod:`mjtrack.sim.chassis` (chassis, suspension, sensors, scene: derivations there);
:func:`build_model` builds either track model (``SimConfig.track_model``).

Derivation of the roller chain (what each element stands for; ``assets/README.md`` gives the
measurements):

Derivation and measurements: docs/theory/simulator.md, "The roller chain".
"""

from __future__ import annotations

import logging
import math

import mujoco
import numpy as np

from mjtrack.errors import InputError
from mjtrack.io.robot import Robot
from mjtrack.sim.chassis import Suspension, TrackModel, build_robot_model, build_robot_spec, element_positions
from mjtrack.sim.config import SimConfig
from mjtrack.sim.drivetrain import drive_of
from mjtrack.sim.ground import apply_ground, require_supported
from mjtrack.sim.scene import SIDES
from mjtrack.sim.surfacevel import SurfacevelTracks, build_surfacevel_model
from mjtrack.sim.terrain import Terrain

logger = logging.getLogger(__name__)


class RollerChain(TrackModel):
    """Each track a chain of N sprung spherical rollers driven by velocity servos (module docstring)."""

    name = "rollers"
    modelname = "tracked_robot"
    element = "roller"  # contact elements: bodies and geoms <element>_<side>_<i>
    element_rgba = (0.1, 0.1, 0.1, 1.0)
    spin_inertia_share = 1.0  # an element's body inertia about its axle / a solid sphere's (0.4 m r^2)

    def configure(self, robot: Robot, config: SimConfig) -> SimConfig:
        return config.for_robot_mass(robot.mass)  # drive scaled to the robot

    def frame_masses(self, robot: Robot, config: SimConfig) -> list[tuple[float, tuple[float, float, float]]]:
        """The belt joints' bodies, at the track frames (0, +-T/2, 0)."""
        if config.coupling != "servo" or config.belt_timeconst is None:
            return []
        return [(BELT_BODY_MASS, (0.0, side * robot.track_gauge / 2, 0.0)) for side in (1.0, -1.0)]

    def set_options(self, opt: mujoco.MjOption, config: SimConfig) -> None:
        # Constraint forces are computed with M alone; damping that an implicit step adds later
        # (joint dampers, servo kv) is invisible to the friction solve and bends the friction
        # direction away from the slip (assets/README.md). Euler without implicit damping keeps
        # every damper an explicit, known force.
        if config.integrator == "Euler" and not config.implicit_damping:
            opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_EULERDAMP

    def check(self, config: SimConfig, suspension: Suspension, element_mass: float) -> None:
        """Explicit dampers need c dt / m < 2: suspension on the roller, servo on the track inertia."""
        if config.integrator != "Euler" or config.implicit_damping:
            return
        dt = config.timestep
        if suspension.c * dt / element_mass >= 1.5:
            raise InputError(
                f"sim config: suspension damping {suspension.c:.3g} N s/m is unstable with explicit Euler at "
                f"dt = {dt} s and roller mass {element_mass:.3g} kg (needs c dt / m < 1.5)"
            )
        if config.coupling == "servo" and config.belt_timeconst is not None:
            # fastest belt mode: the belt joint against its rollers, w^2 = (1/(1-s) + 1/s) / tau^2
            # (s = BELT_MASS_SHARE); symplectic Euler needs w dt < 2, kept below 1.5
            w_dt = dt * math.sqrt(1 / (1 - BELT_MASS_SHARE) + 1 / BELT_MASS_SHARE) / config.belt_timeconst
            if w_dt >= 1.5:
                raise InputError(
                    f"sim config: belt_timeconst {config.belt_timeconst} s is unstable with explicit Euler at "
                    f"dt = {dt} s (needs dt < {1.5 / (w_dt / dt):.4g} s)")
        if config.coupling == "servo" and config.kv * dt / config.track_mass >= 1.5:
            raise InputError(
                f"sim config: servo gain kv = {config.kv} is unstable with explicit Euler at dt = {dt} s "
                f"and track_mass {config.track_mass} kg (needs kv dt / track_mass < 1.5)"
            )

    def add_track(self, spec: mujoco.MjSpec, chassis, robot: Robot, config: SimConfig, *, side: str, y: float,
                  mu: float, suspension: Suspension) -> None:
        drive = drive_of(robot, config)  # the robot's drivetrain keys (mjtrack.sim.drivetrain)
        lag = drive.lags[SIDES.index(side)]
        n, r = config.n_rollers, config.roller_radius
        mr = self.element_mass(robot, config)
        Rs = robot.sprocket_radius
        equality = config.coupling == "equality"
        if equality:
            _add_sprocket(chassis, side, robot, config, y)
        track = chassis.add_body(name=f"{side}_track", pos=[0, y, 0])  # no joint: the rollers' frame
        belted = not equality and config.belt_timeconst is not None
        m_belt = BELT_MASS_SHARE * config.track_mass if belted else 0.0  # of the reflected inertia
        for i, x in enumerate(element_positions(robot, n)):
            roller = track.add_body(name=f"{self.element}_{side}_{i}", pos=[x, 0, r])
            roller.explicitinertial = True
            roller.mass = mr
            roller.ipos = [0, 0, 0]  # MjSpec leaves ipos unset otherwise (not on the spin axis)
            roller.inertia = [0.4 * mr * r**2 * share for share in (1.0, self.spin_inertia_share, 1.0)]
            suspension.add_slide(roller, side, i, config)
            roller.add_joint(
                name=f"roll_{side}_{i}", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 1, 0],
                armature=0.0 if equality else (config.track_mass - m_belt) * r**2 / n,
            )
            roller.add_geom(
                name=f"{self.element}_{side}_{i}", type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[r, 0, 0],
                friction=[mu, 0.0, 0.0], condim=3, contype=0, conaffinity=0, density=0,
                rgba=list(self.element_rgba),
            )
            self.decorate(roller, robot, config)
            if equality:
                spec.add_equality(
                    name=f"couple_{side}_{i}", type=mujoco.mjtEq.mjEQ_JOINT, name1=f"roll_{side}_{i}",
                    name2=f"sprocket_{side}", data=[0, Rs / r] + [0] * 10,
                    solref=config.coupling_solref, solimp=[0.99, 0.999, 0.001, 0.5, 2],
                )
            else:
                _add_servo(spec, f"drive_{side}_{i}", f"roll_{side}_{i}", mujoco.mjtTrn.mjTRN_JOINT,
                           gear=r, kv=drive.kv / n, fmax=drive.force_limit / n, lag=lag)
        tendon = spec.add_tendon(name=f"track_{side}")
        if equality:
            tendon.wrap_joint(f"sprocket_{side}", Rs)
            _add_servo(spec, f"drive_{side}", f"track_{side}", mujoco.mjtTrn.mjTRN_TENDON,
                       gear=1.0, kv=drive.kv, fmax=drive.force_limit, lag=lag)
        else:  # mean surface speed of the rollers
            for i in range(n):
                tendon.wrap_joint(f"roll_{side}_{i}", r / n)
            if belted:
                _add_belt(spec, track, side, n, r, m_belt, (config.track_mass / n) / config.belt_timeconst**2)
        spec.add_sensor(name=f"track_speed_{side}", type=mujoco.mjtSensor.mjSENS_TENDONVEL,
                        objtype=mujoco.mjtObj.mjOBJ_TENDON, objname=f"track_{side}")

    def decorate(self, body, robot: Robot, config: SimConfig) -> None:
        """Visual geoms of an element's body (none: the renderer draws the belts)."""

    def friction_solref(self, config: SimConfig) -> list[float]:
        # friction_timeconst 0: two time steps (SimConfig)
        return [config.friction_timeconst or 2.0 * config.timestep, 1.0]

    def finish_spec(self, spec: mujoco.MjSpec, robot: Robot, config: SimConfig) -> mujoco.MjSpec:
        return apply_ground(spec, robot, config)  # the robot's ground model (mjtrack.sim.ground)

    def finish_model(self, model: mujoco.MjModel, config: SimConfig) -> mujoco.MjModel:
        if config.rest_margin:
            apply_rest_margins(model)
        return model


REST_SETTLE_S = 0.5  # [s] at rest before the penetrations are read (as rollout.settled_state)
SPRUNG_ELEMENTS = ("roller_", "wheel_")  # geoms whose rest penetration becomes their margin


def apply_rest_margins(model: mujoco.MjModel) -> np.ndarray:
    """Move each roller's contact point to the roller radius at rest (in place): every contact
    pair of roller ``roller_<side>_<i>`` (or wheel ``wheel_<side>_<i>``, the same sphere on the
    ground) gets its rest penetration as its margin; returns the
    penetrations [m], one per pair (0 for pairs of other elements, e.g. idlers, left unchanged).

    Why: MuJoCo puts a sphere-plane (and capsule-plane) contact point half-way into the
    penetration d, at r - d/2 from the roller's axis, so a roller turning at V/r moves its
    contact point at V (1 - d/(2r)) while its drive and the track-speed sensor see V. The soft
    contacts (time constant 2 dt) let the default robot rest d = 0.06 mm deep: its straight-line
    speed fell 0.10 % short of the track speed, and in gentle turns, whose track slips are
    0.5-2 mm/s, the 0.1-0.3 mm/s offset moved the ICRs by up to 0.4 T/2 (R 10 m;
    assets/README.md, "Gentle turns"). A margin moves where the contact starts, not the
    constraint's rest position r = dist - margin (same rest forces): with the depth as margin the
    roller rests with its surface on the ground and the contact point at radius r. Loads that
    change in motion (load transfer, the friction of a turn) still move it by a fraction of d.

    The depth is read after :data:`REST_SETTLE_S` at rest with zero command from the model's
    initial state, as ``margin - dist`` (the constraint's own violation, which a margin does not
    change), and becomes the pair's margin (replacing ``SimConfig.contact_margin``): calling this
    again, or after a change of the centre of mass in the model's fields, gives the margins of a
    fresh build. A roller out of contact at rest (terrain) gets the mean depth of its track's
    touching rollers.
    """
    data = mujoco.MjData(model)
    for _ in range(max(1, int(round(REST_SETTLE_S / model.opt.timestep)))):
        mujoco.mj_step(model, data)
    roller = {g: model.geom(g).name for g in range(model.ngeom) if model.geom(g).name.startswith(SPRUNG_ELEMENTS)}
    depth: dict[int, float] = {}
    for i in range(data.ncon):
        c = data.contact[i]
        for g in (c.geom1, c.geom2):
            if g in roller:
                depth[g] = max(depth.get(g, 0.0), float(c.includemargin - c.dist))
    for side in ("left", "right"):
        on_side = tuple(f"{prefix}{side}_" for prefix in SPRUNG_ELEMENTS)
        touching = [v for g, v in depth.items() if roller[g].startswith(on_side)]
        for g, name in roller.items():
            if name.startswith(on_side) and g not in depth:
                depth[g] = float(np.mean(touching)) if touching else 0.0
    out = np.zeros(model.npair)
    for p in range(model.npair):
        for g in (model.pair_geom1[p], model.pair_geom2[p]):
            if g in depth:
                out[p] = depth[g]
                model.pair_margin[p] = depth[g]
    return out


ROLLER_CHAIN = RollerChain()


class WheelSet(RollerChain):
    """A wheeled skid-steer robot (``robot.traction == "wheels"``): each side ``wheels_per_side``
    sprung wheels at the axle positions, driven and tied together like the roller chain's rollers
    (module docstring, "Wheels")."""

    name = "wheels"
    modelname = "wheeled_robot"
    element = "wheel"
    element_rgba = (0.1, 0.1, 0.1, 0.0)  # the contact sphere is not drawn: the tyre is (decorate)
    idlers = False
    # the wheel's spin inertia is the hinge's armature (the reflected drivetrain, joint space: no
    # gyroscopic moment); a body inertia of a solid sphere gave a yawing robot the spinning wheels'
    # roll moment, which neither the description nor the Coulomb reference has (module docstring)
    spin_inertia_share = 0.01
    # most damping of a wheel's spring / critical: at critical damping (c dt / m = 1.24 at 5 ms) the
    # explicit damper let a 280 kg robot's wheels hop once the gyroscopic moment was gone (module docstring)
    max_damping_ratio = 0.5
    # the noslip pass converged at least this far: the wheels of a side wind their belt up against
    # each other (stuck wheels, forces near the cone), and 40 iterations left a yaw creep (docstring)
    min_noslip_iterations = 100
    max_noslip_tolerance = 1e-8

    def configure(self, robot: Robot, config: SimConfig) -> SimConfig:
        """The roller chain's settings with one element per wheel, of the wheel's radius, and the
        wheels' limits on spring damping and the noslip pass's convergence."""
        if robot.traction != "wheels":
            raise InputError("wheels: the robot's traction is 'tracks'")
        if config.track_model != "rollers" or config.coupling != "servo":
            raise InputError(f"wheels: a wheeled robot is built with the roller chain's settings (track_model "
                             f"'rollers', coupling 'servo'), got {config.track_model!r}, {config.coupling!r}")
        return super().configure(robot, config).replace(
            n_rollers=robot.wheels_per_side, roller_radius=robot.wheel_radius,
            suspension_damping_ratio=min(config.suspension_damping_ratio, self.max_damping_ratio),
            noslip_iterations=max(config.noslip_iterations, self.min_noslip_iterations),
            noslip_tolerance=min(config.noslip_tolerance, self.max_noslip_tolerance))

    def decorate(self, body, robot: Robot, config: SimConfig) -> None:
        """A tyre (cylinder of the wheel's radius and the tyre width, axle along y) and three spokes
        that stand out of both faces, so that the wheel is seen to turn; visual only."""
        r, w = config.roller_radius, robot.track_width
        visual = dict(contype=0, conaffinity=0, density=0)
        body.add_geom(name=f"tyre_{body.name.removeprefix('wheel_')}", type=mujoco.mjtGeom.mjGEOM_CYLINDER,
                      size=[r, w / 2, 0], quat=[math.sqrt(0.5), math.sqrt(0.5), 0, 0], rgba=[0.12, 0.12, 0.13, 1],
                      **visual)
        for k in range(3):  # rotated about the axle (body y) by 0, 60, 120 degrees
            a = k * math.pi / 3
            body.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.8 * r, w / 2 + 0.004, 0.07 * r],
                          quat=[math.cos(a / 2), 0, math.sin(a / 2), 0], rgba=[0.95, 0.75, 0.1, 1], **visual)

    def hull(self, robot: Robot, config: SimConfig) -> tuple[list[float], list[float]]:
        """Between the wheels, from the front to the rear wheel's edge, at the axles' height."""
        T, B, w, r = robot.track_gauge, robot.contact_length, robot.track_width, config.roller_radius
        return [B / 2 + 0.6 * r, max(T / 2 - w / 2 - 0.01, 0.1 * T), 0.4 * r], [0, 0, r + 0.2 * r]


WHEELS = WheelSet()


def track_model_for(robot: Robot, config: SimConfig) -> TrackModel:
    """The track model that builds ``robot`` under ``config``: the wheels for a wheeled robot (which
    takes the roller chain's settings), else the roller chain or, with ``config.track_model ==
    "surfacevel"``, the moving contact surfaces."""
    if robot.traction == "wheels":
        if config.track_model != "rollers":
            raise InputError(f"robot: a wheeled robot has wheels, not the {config.track_model!r} track model "
                             "(use the default track model)")
        return WHEELS
    if config.track_model == "surfacevel":
        return SurfacevelTracks()
    return ROLLER_CHAIN


def build_spec(robot: Robot, config: SimConfig | None = None, *, idlers: bool = False) -> mujoco.MjSpec:
    """The roller-chain robot alone (no floor) as an ``MjSpec``, with simulation options set;
    ``idlers``: with the front and rear idlers (:func:`mjtrack.sim.scene.add_idlers`)."""
    return build_robot_spec(robot, config, ROLLER_CHAIN, idlers=idlers)


def _add_sprocket(chassis, side: str, robot: Robot, config: SimConfig, y: float) -> None:
    """Sprocket hinge carrying the track's reflected mass m R_s^2 as armature (no contact)."""
    Rs = robot.sprocket_radius
    sprocket = chassis.add_body(name=f"sprocket_{side}", pos=[robot.track_length / 2, y, Rs])
    sprocket.explicitinertial = True
    sprocket.mass = 0.01
    sprocket.ipos = [0, 0, 0]
    sprocket.inertia = [1e-5, 1e-5, 1e-5]
    sprocket.add_joint(name=f"sprocket_{side}", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 1, 0],
                       armature=config.track_mass * Rs**2)
    sprocket.add_geom(
        name=f"sprocket_{side}", type=mujoco.mjtGeom.mjGEOM_CYLINDER, size=[Rs, robot.track_width / 2, 0],
        quat=[math.sqrt(0.5), math.sqrt(0.5), 0, 0], contype=0, conaffinity=0, density=0,
        rgba=[0.2, 0.2, 0.2, 1],
    )


BELT_MASS_SHARE = 0.25  # share of a track's reflected inertia carried by its belt joint
BELT_BODY_MASS = 1e-6  # [kg] the belt joint's body (MuJoCo needs a mass; taken from the chassis)


def _add_belt(spec: mujoco.MjSpec, track, side: str, n: int, r: float, mass: float, stiffness: float) -> None:
    """The belt of a track: a hinge ``belt_<side>`` (on a 1 mg body of the track frame, axis +y,
    surface radius r: its armature ``mass`` r^2 is the belt's share of the reflected inertia) and
    tendons ``belt_<side>_<i>`` = r (q_roll_i - q_belt), each a spring of ``stiffness`` [N/m] at
    zero length (SimConfig.belt_timeconst): every roller's surface is tied to the belt."""
    body = track.add_body(name=f"belt_{side}", pos=[0, 0, 0])
    body.explicitinertial = True
    body.mass = BELT_BODY_MASS  # a frame for the joint; the belt's inertia is the joint's armature
    body.ipos = [0, 0, 0]
    body.inertia = [1e-12] * 3
    body.add_joint(name=f"belt_{side}", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 1, 0], armature=mass * r**2)
    for i in range(n):
        belt = spec.add_tendon(name=f"belt_{side}_{i}")
        belt.wrap_joint(f"roll_{side}_{i}", r)
        belt.wrap_joint(f"belt_{side}", -r)
        belt.stiffness = [stiffness, 0.0, 0.0]
        belt.springlength = [0.0, 0.0]


def _add_servo(spec: mujoco.MjSpec, name: str, target: str, trntype, *, gear: float, kv: float,
               fmax: float, lag: float) -> None:
    """Velocity servo: force = kv (u - v), |force| <= fmax, v the transmission's speed [m/s].

    ``gear`` converts the target's speed to metres of track per second (roller radius for a
    roller hinge, 1 for the track tendon). With ``lag`` > 0 the set-point u is the command
    passed through du/dt = (ctrl - u)/lag (exact discretisation), else u = ctrl.
    """
    act = spec.add_actuator(name=name, target=target, trntype=trntype)
    act.gear[0] = gear
    act.gaintype = mujoco.mjtGain.mjGAIN_FIXED
    act.biastype = mujoco.mjtBias.mjBIAS_AFFINE
    act.gainprm[0] = kv
    act.biasprm[:3] = [0.0, 0.0, -kv]
    act.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
    act.forcerange = [-fmax, fmax]
    if lag > 0:
        act.dyntype = mujoco.mjtDyn.mjDYN_FILTEREXACT
        act.dynprm[0] = lag
        # the force of a step uses the set-point that step reached: without actearly a filtered
        # drive acts on the previous step's set-point, a dead time of one step that a lag -> 0
        # would keep (a lagged window simulator then ran 5 ms late on a log of an unlagged robot)
        act.actearly = True


def control_matrix(model: mujoco.MjModel) -> np.ndarray:
    """B, (nu, 2): ctrl = B @ (v_left_cmd, v_right_cmd) -- every drive of a side gets its command."""
    B = np.zeros((model.nu, 2))
    for a in range(model.nu):
        name = model.actuator(a).name
        if name.startswith("drive_"):  # (the motion resistance's actuators take no input)
            B[a, 0 if name.startswith("drive_left") else 1] = 1.0
    return B


def build_model(robot: Robot, config: SimConfig | None = None, terrain: Terrain | None = None) -> mujoco.MjModel:
    """Compiled robot + terrain (default flat), the model every rollout uses: the roller chain, the
    wheels of a wheeled robot or, with ``config.track_model == "surfacevel"``,
    :func:`mjtrack.sim.surfacevel.build_surfacevel_model` (:func:`track_model_for`)."""
    config = config or SimConfig()
    tracks = track_model_for(robot, config)
    if isinstance(tracks, SurfacevelTracks):
        require_supported(robot, config)
        return build_surfacevel_model(robot, config, terrain=terrain)
    return build_robot_model(robot, config, tracks, terrain)
