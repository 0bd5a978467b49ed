"""The one robot builder: the chassis that both track models share, with the track model plugged in.

A robot spec is built by :func:`build_robot_spec` from a :class:`~mjtrack.io.robot.Robot`, a
:class:`SimConfig` and a :class:`TrackModel`: the roller chain
(:data:`mjtrack.sim.builder.ROLLER_CHAIN`) or the ``geom/surfacevel`` rows
(:class:`mjtrack.sim.surfacevel.SurfacevelTracks`). This module builds what they share; the track
model adds the contact elements of each track, its drive and its solver settings. :func:`add_scene`
puts the robot on its terrain, :func:`build_robot_model` does both and compiles.

Derivation of the shared part (``assets/README.md`` gives the measurements):

Derivation and measurements: docs/theory/simulator.md, "The chassis".
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping

import mujoco
import numpy as np

from mjtrack.errors import InputError
from mjtrack.io.robot import G, Robot
from mjtrack.sim.config import SimConfig, sim_config
from mjtrack.sim.scene import add_ground, add_idlers, apply_solver_options, needs_idlers, suspension_range, track_contacts
from mjtrack.sim.terrain import Terrain

CHASSIS_HEIGHT = 0.15  # [m] height of the box whose inertia the chassis is given


def element_positions(robot: Robot, n: int) -> np.ndarray:
    """x of the contact elements along a side, (n,) [m]: on tracks the midpoints of n equal cells
    of L; on wheels the axles (:meth:`mjtrack.io.robot.Robot.axle_positions`, n = wheels_per_side)."""
    if robot.traction == "wheels":
        x = np.asarray(robot.axle_positions(), dtype=float)
        if x.size != n:
            raise InputError(f"wheels: {n} contact elements per side for {x.size} wheels")
        return x
    return -robot.track_length / 2 + (np.arange(n) + 0.5) * robot.track_length / n


def chassis_mass_properties(robot: Robot, config: SimConfig, tracks: "TrackModel") -> tuple[float, np.ndarray, np.ndarray]:
    """(mass [kg], centre of mass (3,) [m], full inertia (ixx, iyy, izz, ixy, ixz, iyz) [kg m^2])
    of the chassis body: the robot less its 2N elements (point masses at (x_i, +-T/2, r)), placed
    so that the total centre of mass is the robot's, with the box inertia of the module docstring
    plus the products of inertia that make the whole robot's products about its centre of mass
    zero (the elements' own inertias are diagonal in the body axes); where that tensor would not be
    physical (A + B < C: a flat, wide chassis with the cg far off-centre), every principal moment
    gets the same addition, C - A - B + 1 % of C. InputError when the elements are too heavy."""
    n, r = tracks.elements(config), config.roller_radius
    m_el = tracks.element_mass(robot, config)
    m_unsprung = 2 * n * m_el
    extra = tracks.frame_masses(robot, config)
    m_chassis = robot.mass - m_unsprung - sum(m for m, _ in extra)
    if m_chassis <= 0.2 * robot.mass:
        raise InputError(f"{tracks.name}: elements weigh {m_unsprung:.3g} kg of {robot.mass:.3g} kg; "
                         "reduce the unsprung mass")
    T, L, w = robot.track_gauge, robot.contact_length, robot.track_width
    cg = np.array([robot.cg_x, robot.cg_y, robot.cg_z])
    ipos = (robot.mass * cg - m_unsprung * np.array([0.0, 0.0, r])
            - sum((m * np.asarray(p, float) for m, p in extra), np.zeros(3))) / m_chassis
    xs = element_positions(robot, n)
    points = np.array([[x, y, r] for y in (T / 2, -T / 2) for x in xs]) - cg
    second = m_el * points.T @ points + m_chassis * np.outer(ipos - cg, ipos - cg)  # sum m d d^T
    for m, p in extra:
        d = np.asarray(p, float) - cg
        second += m * np.outer(d, d)
    ly, lz = T + w, CHASSIS_HEIGHT
    box = m_chassis / 12 * np.array([ly**2 + lz**2, L**2 + lz**2, L**2 + ly**2])
    if not config.principal_axes:  # a plain box (the earlier form, kept as an option)
        return m_chassis, ipos, np.array([*box, 0.0, 0.0, 0.0])
    # products of inertia are -sum m d_a d_b; the chassis takes +sum m d_a d_b to cancel them
    full = np.array([*box, second[0, 1], second[0, 2], second[1, 2]])
    tensor = np.diag(box) + (second - np.diag(np.diag(second)))
    a, b, c = np.linalg.eigvalsh(tensor)
    # a flat, wide box is near the triangle limit (A + B = C for a plate): where the products
    # rotate it past that, every moment gets the same delta (products unchanged)
    delta = max(0.0, c - a - b, -a)
    if delta > 0.0:
        delta += 0.01 * c
        full[:3] += delta
    return m_chassis, ipos, full


def set_body_inertia(model: mujoco.MjModel, body: int, full: np.ndarray) -> None:
    """A compiled body's inertia from its full tensor (ixx, iyy, izz, ixy, ixz, iyz), in place, as
    the compiler stores it: principal moments ``body_inertia`` and their frame ``body_iquat``."""
    ixx, iyy, izz, ixy, ixz, iyz = (float(v) for v in full)
    moments, axes = np.linalg.eigh(np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]]))
    if np.linalg.det(axes) < 0:
        axes[:, 2] = -axes[:, 2]
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, axes.flatten())
    model.body_inertia[body] = moments
    model.body_iquat[body] = quat


def suspension_stiffness(robot: Robot, config: SimConfig, n: int) -> float:
    """k = m g / (2 N d) [N/m] of n elements per track: the static deflection under an equal
    load share is d."""
    return robot.weight / (2 * n * config.suspension_deflection)


def rest_loads(robot: Robot, n: int, *, level: bool = True) -> dict[str, np.ndarray]:
    """Static load [N] of each of the n elements per track (``{"left": (n,), "right": (n,)}``).

    A rigid chassis on equal springs carries a load linear in the elements' positions whose
    resultant is the weight at the centre of mass: N_i = W/(2n) (1 + c_x x_i / mean(x^2) +
    c_y y_i / (T/2)^2) (Wong's linear distribution and lever rule). ``level``: these loads, the
    springs' preloads then holding the chassis level at rest; with a centre of mass so far out
    that some N_i would be negative (|c_x| > mean(x^2)/max|x|, about L/6), or with ``level``
    False: the equal share W/(2n) for every element, the chassis then pitching and rolling on its
    springs until they carry the same linear loads (or lifting the unloaded end).
    """
    x = element_positions(robot, n)
    half = robot.track_gauge / 2
    share = robot.weight / (2 * n)
    mx2 = float(np.mean(x**2))
    if not level or mx2 == 0.0:  # (one element per track: nothing to level)
        return {side: np.full(n, share) for side in ("left", "right")}
    loads = {side: share * (1 + robot.cg_x * x / mx2 + robot.cg_y * y / half**2)
             for side, y in (("left", half), ("right", -half))}
    if min(v.min() for v in loads.values()) <= 0:
        return {side: np.full(n, share) for side in loads}
    return loads


@dataclass(frozen=True)
class Suspension:
    """The sprung elements' slides: stiffness k [N/m], damping c [N s/m], preloads [N] per side
    and element (spring force at q = 0: the element's rest load less its weight,
    :func:`rest_loads`)."""

    k: float
    c: float
    preload: Mapping[str, np.ndarray]

    def add_slide(self, body, side: str, i: int, config: SimConfig) -> None:
        """The vertical slide ``susp_<side>_<i>`` of ``body``, with travel :func:`suspension_range`."""
        body.add_joint(name=f"susp_{side}_{i}", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[0, 0, 1],
                       stiffness=self.k, damping=self.c, springref=-float(self.preload[side][i]) / self.k,
                       limited=mujoco.mjtLimited.mjLIMITED_TRUE, range=suspension_range(config))


def set_rest_springs(model: mujoco.MjModel, robot: Robot, config: SimConfig) -> None:
    """Spring rest positions of a compiled model's slides ``susp_<side>_<i>`` for ``robot``'s
    centre of mass (in place), as :func:`build_robot_spec` sets them: for a model whose centre
    of mass was moved through its fields (``mjtrack.sim.windows``)."""
    n = sum(1 for j in range(model.njnt) if model.joint(j).name.startswith("susp_left_"))
    if n == 0:
        return
    loads = rest_loads(robot, n, level=config.level_chassis)
    for side, values in loads.items():
        for i, load in enumerate(values):
            j = model.joint(f"susp_{side}_{i}")
            body = model.jnt_bodyid[j.id]
            k = float(model.jnt_stiffness[j.id])
            model.qpos_spring[j.qposadr[0]] = -(float(load) - float(model.body_mass[body]) * G) / k


class TrackModel:
    """The pluggable part of a robot: how a track touches the ground and is driven.

    ``name`` is the ``SimConfig.track_model`` it realises (its default settings:
    :func:`mjtrack.sim.config.sim_config`), ``modelname`` the compiled model's name. Subclasses
    implement :meth:`add_track` and may override the other hooks.
    """

    name = ""
    modelname = ""
    idlers = True  # front and rear idlers on terrain they can touch (tracks; wheels climb on their own)

    def default_config(self) -> SimConfig:
        return sim_config(self.name)

    def configure(self, robot: Robot, config: SimConfig) -> SimConfig:
        """The settings the robot is built with (e.g. the drive scaled to the robot's mass)."""
        return config

    def elements(self, config: SimConfig) -> int:
        """Contact elements per track."""
        return config.n_rollers

    def element_mass(self, robot: Robot, config: SimConfig) -> float:
        """Unsprung mass of one element [kg]: ``unsprung_fraction`` of the robot over 2N."""
        return config.unsprung_fraction * robot.mass / (2 * self.elements(config))

    def frame_masses(self, robot: Robot, config: SimConfig) -> list[tuple[float, tuple[float, float, float]]]:
        """Other small masses the track model puts on the robot, (mass [kg], position (x, y, z) in
        the chassis frame [m]), taken from the chassis so that mass and centre of mass stay exact."""
        return []

    def set_options(self, opt: mujoco.MjOption, config: SimConfig) -> None:
        """Solver settings of this track model beyond the shared ones."""

    def check(self, config: SimConfig, suspension: Suspension, element_mass: float) -> None:
        """Refuse settings this model cannot run with (InputError)."""

    def add_track(self, spec: mujoco.MjSpec, chassis, robot: Robot, config: SimConfig, *, side: str, y: float,
                  mu: float, suspension: Suspension) -> None:
        """The contact elements of track ``side`` (at chassis y, friction μ) and their drive."""
        raise NotImplementedError

    def friction_solref(self, config: SimConfig) -> list[float]:
        """``solreffriction`` of the element-terrain contact pairs."""
        raise NotImplementedError

    def hull(self, robot: Robot, config: SimConfig) -> tuple[list[float], list[float]]:
        """(half sizes, position) [m] of the visual hull box: above the tracks."""
        T, L, w, r = robot.track_gauge, robot.track_length, robot.track_width, config.roller_radius
        return [L / 2, max(T / 2 - w, 0.1 * T), 0.04], [0, 0, 2 * r + 0.06]  # narrow robots keep a hull

    def finish_spec(self, spec: mujoco.MjSpec, robot: Robot, config: SimConfig) -> mujoco.MjSpec:
        """Last changes to the robot + scene spec before compiling (e.g. the ground model)."""
        return spec

    def finish_model(self, model: mujoco.MjModel, config: SimConfig) -> mujoco.MjModel:
        """Last changes to the compiled model."""
        return model


def add_contact_sensor(spec: mujoco.MjSpec, side: str) -> None:
    """Sensor ``ground_<side>``: number of ground contacts of the track's elements (the geoms in the
    subtree of body ``<side>_track``; idlers, on the chassis, are not counted).

    One sensor per track, not one per element: a contact sensor scans the whole contact list, so
    N per-element sensors cost N x ncon per step (3 % of the default robot's step, 5 % at 40
    rollers per track; benchmarks/bench_sim.py). The per-element mean in contact is the count / N.
    """
    spec.add_sensor(name=f"ground_{side}", type=mujoco.mjtSensor.mjSENS_CONTACT,
                    objtype=mujoco.mjtObj.mjOBJ_XBODY, objname=f"{side}_track", intprm=[1, 0, 1])


def set_options(spec: mujoco.MjSpec, config: SimConfig, tracks: TrackModel) -> None:
    """The shared solver settings of ``config`` plus the track model's. A diverging simulation
    ends in NaN, not in MuJoCo's silent reset to the initial state (which the surfacevel model
    used to get: rollouts and steady runs then carried on from rest unnoticed)."""
    opt = apply_solver_options(spec, config)
    opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_AUTORESET
    tracks.set_options(opt, config)


def build_robot_spec(robot: Robot, config: SimConfig | None, tracks: TrackModel, *, idlers: bool = False,
                     into: mujoco.MjSpec | None = None) -> mujoco.MjSpec:
    """The robot alone (no floor) with its simulation options, added to ``into`` when given, else
    to a new spec named ``tracks.modelname``; ``idlers``: with the front and rear idlers."""
    config = tracks.configure(robot, config or tracks.default_config())
    spec = into if into is not None else mujoco.MjSpec()
    if into is None:
        spec.modelname = tracks.modelname
    set_options(spec, config, tracks)
    n = tracks.elements(config)
    m_el = tracks.element_mass(robot, config)
    T = robot.track_gauge
    m_chassis, ipos, full = chassis_mass_properties(robot, config, tracks)
    cg = np.array([robot.cg_x, robot.cg_y, robot.cg_z])

    chassis = spec.worldbody.add_body(name="chassis", pos=[0, 0, 0])
    chassis.add_freejoint(name="root")
    chassis.explicitinertial = True
    chassis.mass = m_chassis
    chassis.ipos = ipos
    chassis.fullinertia = full
    chassis.add_site(name="centre", pos=[0, 0, 0], size=[0.01, 0.01, 0.01])
    chassis.add_site(name="cg", pos=cg, size=[0.015, 0.015, 0.015], rgba=[1, 0, 0, 1])
    hull_size, hull_pos = tracks.hull(robot, config)
    chassis.add_geom(  # visual only
        name="hull", type=mujoco.mjtGeom.mjGEOM_BOX, size=hull_size, pos=hull_pos, contype=0, conaffinity=0,
        density=0, rgba=[0.35, 0.4, 0.45, 1],
    )

    k = suspension_stiffness(robot, config, n)
    # critical damping of the element's share of the sprung mass (m_chassis / 2N) on k
    suspension = Suspension(k=k, c=config.suspension_damping_ratio * 2 * math.sqrt(k * m_chassis / (2 * n)),
                            preload={side: v - m_el * G for side, v in rest_loads(robot, n, level=config.level_chassis).items()})
    tracks.check(config, suspension, m_el)
    for side, y, mu in (("left", T / 2, robot.friction_left), ("right", -T / 2, robot.friction_right)):
        tracks.add_track(spec, chassis, robot, config, side=side, y=y, mu=mu, suspension=suspension)
        add_contact_sensor(spec, side)  # contact persistence
    if idlers and tracks.idlers:
        add_idlers(chassis, robot, config)
    if robot.rolling_resistance > 0:
        add_resistance(spec, chassis, robot)
    # velocimeter / gyro: velocity of the site expressed in the site's (= chassis) frame
    for name, stype in (("body_linvel", mujoco.mjtSensor.mjSENS_VELOCIMETER),
                        ("body_angvel", mujoco.mjtSensor.mjSENS_GYRO),
                        ("body_pos", mujoco.mjtSensor.mjSENS_FRAMEPOS),
                        ("body_quat", mujoco.mjtSensor.mjSENS_FRAMEQUAT)):
        spec.add_sensor(name=name, type=stype, objtype=mujoco.mjtObj.mjOBJ_SITE, objname="centre")
    return spec


def add_scene(spec: mujoco.MjSpec, robot: Robot, config: SimConfig | None, terrain: Terrain | None = None, *,
              tracks: TrackModel) -> mujoco.MjSpec:
    """Add the terrain (default flat: ``floor``), the element-terrain contact pairs and a light (in place).

    The elements collide with nothing else (contype = conaffinity = 0): one explicit pair per
    (element, terrain geom) carries the track's friction, the contact softness and the track
    model's friction solref (:meth:`TrackModel.friction_solref`) -- see :class:`SimConfig`.
    """
    config = config or tracks.default_config()
    pair_options = dict(condim=3, solref=config.contact_solref, solimp=config.solimp,
                        solreffriction=tracks.friction_solref(config), margin=config.contact_margin)
    return add_ground(spec, robot, terrain or Terrain(), track_contacts(spec, robot), pair_options)


def build_robot_scene(robot: Robot, config: SimConfig | None, tracks: TrackModel, terrain: Terrain | None = None,
                      **options) -> mujoco.MjSpec:
    """Robot (:func:`build_robot_spec`, with idlers where the terrain needs them) plus scene
    (:func:`add_scene`), ready to compile; ``options`` go to :func:`build_robot_spec`."""
    config = config or tracks.default_config()
    spec = build_robot_spec(robot, config, tracks, idlers=needs_idlers(terrain), **options)
    return tracks.finish_spec(add_scene(spec, robot, config, terrain, tracks=tracks), robot, config)


#: [m/s] speed over which the motion resistance builds up to its full value (a regularised
#: Coulomb law: F = -min(1, |v| / RESIST_EPS) F_max sgn v); small against driving speeds, large
#: enough that the explicit step stays stable (f_r g dt / RESIST_EPS <= 0.6 at f_r 0.6, dt 5 ms)
RESIST_EPS = 0.05
RESIST_SIDES = ("left", "right")


def resistance_forces(robot: Robot, coefficient: float) -> tuple[float, float]:
    """(F_left, F_right) [N]: ``coefficient`` times the weight each side carries at rest on level
    ground (the centre of mass's lateral offset splits it)."""
    share_left = 0.5 + robot.cg_y / robot.track_gauge
    W = robot.mass * G
    return coefficient * W * share_left, coefficient * W * (1.0 - share_left)


def add_resistance(spec: mujoco.MjSpec, chassis, robot: Robot) -> None:
    """The motion resistance of robot key ``rolling_resistance``: per side, a force along the
    chassis x axis at the middle of the side's ground contact (site ``resist_<side>``), opposing
    that point's forward velocity, -F_side sat(v / RESIST_EPS) (:func:`resistance_forces`).
    MuJoCo-native, so rollouts need no callback: an actuator on the site (its velocity is the
    site's velocity along x) whose affine bias is a damper, its force range the saturation."""
    forces = resistance_forces(robot, robot.rolling_resistance)
    for side, y, F in zip(RESIST_SIDES, (robot.track_gauge / 2, -robot.track_gauge / 2), forces):
        chassis.add_site(name=f"resist_{side}", pos=[0, y, 0], size=[0.01, 0.01, 0.01])
        act = spec.add_actuator(name=f"resist_{side}", target=f"resist_{side}", trntype=mujoco.mjtTrn.mjTRN_SITE)
        act.gear[:6] = [1, 0, 0, 0, 0, 0]
        act.gaintype = mujoco.mjtGain.mjGAIN_FIXED
        act.gainprm[0] = 0.0  # no input: a passive force
        act.biastype = mujoco.mjtBias.mjBIAS_AFFINE
        act.biasprm[:3] = [0.0, 0.0, -F / RESIST_EPS]
        act.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
        act.forcerange = [-F, F]


def set_resistance(model: mujoco.MjModel, forces: tuple[float, float]) -> None:
    """Set the resistance actuators of a compiled model to the saturation forces ``forces``
    (F_left, F_right) [N] (0 switches a side off)."""
    for side, F in zip(RESIST_SIDES, forces):
        a = model.actuator(f"resist_{side}").id
        model.actuator_biasprm[a, :3] = (0.0, 0.0, -F / RESIST_EPS)
        model.actuator_forcerange[a] = (-F, F)


def build_robot_model(robot: Robot, config: SimConfig | None, tracks: TrackModel,
                      terrain: Terrain | None = None) -> mujoco.MjModel:
    """Compiled robot + terrain (default flat)."""
    config = tracks.configure(robot, config or tracks.default_config())
    return tracks.finish_model(build_robot_scene(robot, config, tracks, terrain).compile(), config)
