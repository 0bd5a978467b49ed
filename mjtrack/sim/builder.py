"""MuJoCo model of a two-track robot as a chain of sprung contact rollers (``mujoco.MjSpec``).

Derivation (what each element stands for; ``assets/README.md`` gives the measurements):

* **Chassis**: one body with a free joint ``root``. Its frame origin is the geometric centre
  of the two contact patches on the ground (site ``centre``), x forward, y left, z up. The
  chassis mass is ``robot.mass`` minus the rollers' (unsprung) mass and sits where it puts
  the total centre of mass at (cg_x, cg_y, cg_z); its inertia is a uniform box
  L x (T + width) x ``CHASSIS_HEIGHT``.
* **Track contact** (issue 3): the ground contact of a rigid track of length L is a uniform
  line load along x. Each track is N spheres of radius r at the midpoints
  x_i = -L/2 + (i + 1/2) L/N (midpoint rule: the N point loads integrate a linear load over
  [-L/2, L/2] exactly). A rigid chassis on 2N point contacts is statically indeterminate and
  MuJoCo's solver then spreads the normal load arbitrarily (measured: 0 to 119 N where 8 N
  were due). Each roller therefore rides on a vertical slide ``susp_<side>_<i>`` with a
  spring of stiffness k = m g / (2 N d) (d: static deflection) preloaded so that q = 0 at
  the nominal load: the loads are then k times the chassis' (linear) deflection at each
  roller, i.e. Wong's linear load distribution from the cg offset, and determinate.
* **Track motion**: a roller's contact point must move backwards relative to the chassis at
  the track speed V. Default (``coupling="servo"``): every roller hinge ``roll_<side>_<i>``
  (axis +y; positive = forward driving) has its own velocity servo ``drive_<side>_<i>`` on
  the track command (gear r, so ctrl and speed are in m/s of track), gain kv/N, force limit
  torque_limit/(R_s N), and armature track_mass r^2/N: the track's reflected drivetrain
  inertia. Alternative (``coupling="equality"``): roller hinges tied to one sprocket hinge by
  joint equalities q_roll = (R_s/r) q_sprocket, one servo on the sprocket.
* **Track speed**: fixed tendon ``track_<side>`` = (r/N) sum q_roll (mean roller surface
  speed; R_s q_sprocket with the equality coupling); sensor ``track_speed_<side>`` [m/s].
* **Friction** (the causes measured in ``assets/README.md``): sphere-plane point contacts,
  condim 3 (sliding friction; a point has no spin moment to resist), one explicit pair per
  roller carrying the track's mu. MuJoCo solves contacts as a convex problem in which a
  sliding contact on its friction cone gets a *separating* normal acceleration mu |y_t|
  (y_t: the friction rows' residual, about b_t |slip|): sliding rollers hop. Therefore the
  main solve sees nearly no friction (``impratio`` 1e-4: friction rows 10^4 times softer than
  the normal row, so they never reach the cone), and the friction comes from the noslip
  pass, which solves the friction rows with the normal forces fixed and no regularisation
  (hard Coulomb, no lift); its short friction time constant (2 dt) makes it oppose the slip
  *velocity*. Elliptic cone: the Coulomb cone is isotropic.
* **Drivetrain and integration**: the servos make every roller of a track run at the track
  speed to within F_i / (kv/N); a soft servo lets the rollers of one track differ by cm/s,
  which moves the ICRs of gentle turns (slips of mm/s). Hence a heavy reflected drivetrain
  inertia (``track_mass``) and a stiff kv. Constraint forces are computed with M alone, so
  damping that an implicit integrator adds afterwards (servo kv, suspension c) is invisible
  to the friction solve; it bends the friction away from the slip unless kv dt << armature.
  Semi-implicit Euler with MuJoCo's implicit joint damping switched off keeps every damper an
  explicit, known force; stability then needs kv dt / track_mass and c dt / m_roller below
  1.5 (checked, InputError otherwise).
* **Sensors**: body twist of ``centre`` in its own frame (``body_linvel`` velocimeter,
  ``body_angvel`` gyro), its pose (``body_pos``, ``body_quat``), track speeds
  (``track_speed_<side>``, m/s), ground contact of each roller (``ground_<side>_<i>``, 0/1).
* MjSpec pitfall: a body with ``explicitinertial`` must be given ``ipos``; left unset the
  centre of mass was compiled at the body's offset from its parent (the spinning rollers
  then orbited an eccentric axis: several newtons of spurious vertical force, micro-hops).
"""

from __future__ import annotations

import logging
import math

import mujoco
import numpy as np

from mjtrack.errors import InputError
from mjtrack.io.robot import G, Robot
from mjtrack.sim.config import SimConfig
from mjtrack.sim.drivetrain import drive_of
from mjtrack.sim.ground import apply_ground, require_supported
from mjtrack.sim.scene import (CHASSIS_HEIGHT, add_ground, add_idlers, apply_solver_options, needs_idlers,
                               suspension_range, track_contacts)
from mjtrack.sim.surfacevel import build_surfacevel_model
from mjtrack.sim.terrain import Terrain

logger = logging.getLogger(__name__)





def roller_positions(robot: Robot, config: SimConfig) -> np.ndarray:
    """x of the roller centres along a track, (n_rollers,) [m] (midpoint rule over L)."""
    n = config.n_rollers
    return -robot.track_length / 2 + (np.arange(n) + 0.5) * robot.track_length / n


def suspension_stiffness(robot: Robot, config: SimConfig) -> float:
    """k = m g / (2 N d) [N/m]: the static deflection under an equal load share is d."""
    return robot.weight / (2 * config.n_rollers * config.suspension_deflection)


def build_spec(robot: Robot, config: SimConfig | None = None, *, idlers: bool = False) -> mujoco.MjSpec:
    """The robot alone (no floor) as an ``MjSpec``, with simulation options set; ``idlers``: with
    the front and rear idlers (:func:`add_idlers`)."""
    config = (config or SimConfig()).for_robot_mass(robot.mass)  # drive scaled to the robot
    drive = drive_of(robot, config)  # the robot's drivetrain keys (mjtrack.sim.drivetrain)
    spec = mujoco.MjSpec()
    spec.modelname = "tracked_robot"
    _set_options(spec, config)
    n, r = config.n_rollers, config.roller_radius
    mr = config.roller_mass(robot.mass)
    T, L, Rs = robot.track_gauge, robot.track_length, robot.sprocket_radius
    m_rollers = 2 * n * mr
    m_chassis = robot.mass - m_rollers
    cg = np.array([robot.cg_x, robot.cg_y, robot.cg_z])
    chassis_com = (robot.mass * cg - m_rollers * np.array([0.0, 0.0, r])) / m_chassis
    ly, lz = T + robot.track_width, CHASSIS_HEIGHT
    inertia = m_chassis / 12 * np.array([ly**2 + lz**2, L**2 + lz**2, L**2 + ly**2])

    chassis = spec.worldbody.add_body(name="chassis", pos=[0, 0, 0])
    chassis.add_freejoint(name="root")
    chassis.explicitinertial = True
    chassis.mass = m_chassis
    chassis.ipos = chassis_com
    chassis.inertia = inertia
    chassis.add_site(name="centre", pos=[0, 0, 0], size=[0.01, 0.01, 0.01])
    chassis.add_site(name="cg", pos=cg, size=[0.015, 0.015, 0.015], rgba=[1, 0, 0, 1])
    chassis.add_geom(
        name="hull", type=mujoco.mjtGeom.mjGEOM_BOX, size=[L / 2, max(T / 2 - robot.track_width, 0.1 * T), 0.04],  # visual only; narrow robots keep a hull
        pos=[0, 0, 2 * r + 0.06], contype=0, conaffinity=0, density=0, rgba=[0.35, 0.4, 0.45, 1],
    )

    k = suspension_stiffness(robot, config)
    # critical damping of the roller's share of the sprung mass (m_chassis / 2N) on k
    c = config.suspension_damping_ratio * 2 * math.sqrt(k * m_chassis / (2 * n))
    _check_explicit_stability(config, c, mr)
    preload = robot.weight / (2 * n) - mr * G  # spring force at q = 0 (nominal share)
    x_rollers = roller_positions(robot, config)
    for side, y, mu in (("left", T / 2, robot.friction_left), ("right", -T / 2, robot.friction_right)):
        equality = config.coupling == "equality"
        if equality:
            _add_sprocket(chassis, side, robot, config, y)
        for i, x in enumerate(x_rollers):
            roller = chassis.add_body(name=f"roller_{side}_{i}", pos=[x, y, r])
            roller.explicitinertial = True
            roller.mass = mr
            roller.ipos = [0, 0, 0]  # MjSpec leaves ipos unset otherwise (not on the spin axis)
            roller.inertia = [0.4 * mr * r**2] * 3
            roller.add_joint(
                name=f"susp_{side}_{i}", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[0, 0, 1],
                stiffness=k, damping=c, springref=-preload / k,
                limited=mujoco.mjtLimited.mjLIMITED_TRUE, range=suspension_range(config),
            )
            roller.add_joint(
                name=f"roll_{side}_{i}", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 1, 0],
                armature=0.0 if equality else config.track_mass * r**2 / n,
            )
            roller.add_geom(
                name=f"roller_{side}_{i}", type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[r, 0, 0],
                friction=[mu, 0.0, 0.0], condim=3, contype=0, conaffinity=0, density=0,
                rgba=[0.1, 0.1, 0.1, 1],
            )
            # number of ground contacts of this roller (0 or 1): contact persistence
            spec.add_sensor(name=f"ground_{side}_{i}", type=mujoco.mjtSensor.mjSENS_CONTACT,
                            objtype=mujoco.mjtObj.mjOBJ_GEOM, objname=f"roller_{side}_{i}",
                            intprm=[1, 0, 1])
            if equality:
                spec.add_equality(
                    name=f"couple_{side}_{i}", type=mujoco.mjtEq.mjEQ_JOINT, name1=f"roll_{side}_{i}",
                    name2=f"sprocket_{side}", data=[0, Rs / r] + [0] * 10,
                    solref=config.coupling_solref, solimp=[0.99, 0.999, 0.001, 0.5, 2],
                )
            else:
                _add_servo(spec, f"drive_{side}_{i}", f"roll_{side}_{i}", mujoco.mjtTrn.mjTRN_JOINT,
                           gear=r, kv=drive.kv / n, fmax=drive.force_limit / n, lag=drive.lag)
        tendon = spec.add_tendon(name=f"track_{side}")
        if equality:
            tendon.wrap_joint(f"sprocket_{side}", Rs)
            _add_servo(spec, f"drive_{side}", f"track_{side}", mujoco.mjtTrn.mjTRN_TENDON,
                       gear=1.0, kv=drive.kv, fmax=drive.force_limit, lag=drive.lag)
        else:  # mean surface speed of the rollers
            for i in range(n):
                tendon.wrap_joint(f"roll_{side}_{i}", r / n)
        spec.add_sensor(name=f"track_speed_{side}", type=mujoco.mjtSensor.mjSENS_TENDONVEL,
                        objtype=mujoco.mjtObj.mjOBJ_TENDON, objname=f"track_{side}")
    if idlers:
        add_idlers(chassis, robot, config)
    # velocimeter / gyro: velocity of the site expressed in the site's (= chassis) frame
    for name, stype in (("body_linvel", mujoco.mjtSensor.mjSENS_VELOCIMETER),
                        ("body_angvel", mujoco.mjtSensor.mjSENS_GYRO)):
        spec.add_sensor(name=name, type=stype, objtype=mujoco.mjtObj.mjOBJ_SITE, objname="centre")
    spec.add_sensor(name="body_pos", type=mujoco.mjtSensor.mjSENS_FRAMEPOS,
                    objtype=mujoco.mjtObj.mjOBJ_SITE, objname="centre")
    spec.add_sensor(name="body_quat", type=mujoco.mjtSensor.mjSENS_FRAMEQUAT,
                    objtype=mujoco.mjtObj.mjOBJ_SITE, objname="centre")
    return spec


def _check_explicit_stability(config: SimConfig, damping: float, roller_mass: float) -> None:
    """Explicit dampers need c dt / m < 2: suspension on the roller, servo on the track inertia."""
    if config.integrator != "Euler" or config.implicit_damping:
        return
    dt = config.timestep
    if damping * dt / roller_mass >= 1.5:
        raise InputError(
            f"sim config: suspension damping {damping:.3g} N s/m is unstable with explicit Euler at "
            f"dt = {dt} s and roller mass {roller_mass:.3g} kg (needs c dt / m < 1.5)"
        )
    if config.coupling == "servo" and config.kv * dt / config.track_mass >= 1.5:
        raise InputError(
            f"sim config: servo gain kv = {config.kv} is unstable with explicit Euler at dt = {dt} s "
            f"and track_mass {config.track_mass} kg (needs kv dt / track_mass < 1.5)"
        )


def _set_options(spec: mujoco.MjSpec, config: SimConfig) -> None:
    opt = apply_solver_options(spec, config)
    # Constraint forces are computed with M alone; damping that an implicit step adds later
    # (joint dampers, servo kv) is invisible to the friction solve and bends the friction
    # direction away from the slip (assets/README.md). Euler without implicit damping keeps
    # every damper an explicit, known force.
    if config.integrator == "Euler" and not config.implicit_damping:
        opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_EULERDAMP
    opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_AUTORESET  # divergence -> NaN, not a silent reset


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


def control_matrix(model: mujoco.MjModel) -> np.ndarray:
    """B, (nu, 2): ctrl = B @ (v_left_cmd, v_right_cmd) -- every drive of a side gets its command."""
    B = np.zeros((model.nu, 2))
    for a in range(model.nu):
        name = model.actuator(a).name
        B[a, 0 if name.startswith("drive_left") else 1] = 1.0
    return B


def add_scene(spec: mujoco.MjSpec, robot: Robot, config: SimConfig, terrain: Terrain | None = None
              ) -> mujoco.MjSpec:
    """Add the terrain (default flat), the roller-terrain contact pairs and a light (in place).

    The rollers collide with nothing else (contype = conaffinity = 0): one explicit pair per
    (roller, terrain geom) carries the track's friction, the contact softness and a separate,
    weak friction solref (``friction_timeconst``) -- see :class:`SimConfig`.
    """
    pair_options = dict(condim=3, solref=config.contact_solref, solimp=config.solimp,
                        solreffriction=[config.friction_timeconst or 2.0 * config.timestep, 1.0],
                        margin=config.contact_margin)
    return add_ground(spec, robot, terrain or Terrain(), track_contacts(spec, robot), pair_options)


def build_model(robot: Robot, config: SimConfig | None = None, terrain: Terrain | None = None) -> mujoco.MjModel:
    """Compiled robot + terrain (default flat), the model every rollout uses."""
    config = config or SimConfig()
    if config.track_model == "surfacevel":
        require_supported(robot, config)
        return build_surfacevel_model(robot, config, terrain=terrain)
    spec = add_scene(build_spec(robot, config, idlers=needs_idlers(terrain)), robot, config, terrain)
    return apply_ground(spec, robot, config).compile()
