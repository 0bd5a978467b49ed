"""The scene parts that both track models share: solver options, suspension travel, idlers, terrain.

Used by the one robot builder (:mod:`mjtrack.sim.chassis`), so that the roller chain
(:mod:`mjtrack.sim.builder`) and the surfacevel row (:mod:`mjtrack.sim.surfacevel`) sit on the same
terrain with the same contact pairs (:func:`add_ground`), the same limited suspension travel
(:func:`suspension_range`), the same idlers (:func:`add_idlers`) and the same solver settings
(:func:`apply_solver_options`). Imports none of them (no import circle).
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from mjtrack.errors import InputError
from mjtrack.io.robot import Robot
from mjtrack.sim.config import SimConfig
from mjtrack.sim.terrain import Terrain, add_terrain

SIDES = ("left", "right")
ELEMENT_KINDS = ("roller", "track", "wheel")  # contact element names <kind>_<side>_<i> of the track models

_INTEGRATORS = {
    "Euler": mujoco.mjtIntegrator.mjINT_EULER,
    "RK4": mujoco.mjtIntegrator.mjINT_RK4,
    "implicit": mujoco.mjtIntegrator.mjINT_IMPLICIT,
    "implicitfast": mujoco.mjtIntegrator.mjINT_IMPLICITFAST,
}

def suspension_range(config: SimConfig) -> list[float]:
    """Travel of a roller's slide relative to its nominal position [m]: r/2 down, r up (a roller
    cannot sink through a step edge or hang below the track; both limits are inactive in
    driving on a plane, where the travel stays within a few static deflections)."""
    return [-config.roller_radius / 2, config.roller_radius]


STEP_CLEARANCE = 0.02  # [m] a step edge must be this far beyond the robot's ends at the start
IDLER_CLEARANCE = 0.5  # idler bottom this many roller radii above the ground plane


IDLER_MASS_FRACTION = 0.005  # mass of one idler / robot mass (taken from the chassis)


def needs_idlers(terrain: Terrain | None) -> bool:
    """Idlers are built where they can touch something: on steps and height fields."""
    return terrain is not None and (bool(terrain.steps) or terrain.hfield is not None)


def add_idlers(chassis, robot: Robot, config: SimConfig) -> None:
    """Front and rear idlers: free-spinning cylinders of the sprocket radius across the track
    ends (centre x = +-L/2, bottom ``IDLER_CLEARANCE`` r above the ground), the raised ends of a
    real track that let it climb an edge higher than a roller radius (a 3 cm roller alone stops
    at a 4 cm step). Built only on terrain they can touch (:func:`needs_idlers`: on a plane they
    are above the ground), so the robot on a plane is unchanged. Their mass comes out of the
    chassis' (total mass and centre of mass unchanged); contacts carry the mean track μ."""
    Rs, r = robot.sprocket_radius, config.roller_radius
    m = IDLER_MASS_FRACTION * robot.mass
    m_chassis, com = chassis.mass, np.array(chassis.ipos, dtype=float)
    z = Rs + IDLER_CLEARANCE * r
    for name, x in (("front", robot.track_length / 2), ("rear", -robot.track_length / 2)):
        body = chassis.add_body(name=f"idler_{name}", pos=[x, 0, z])
        body.explicitinertial = True
        body.mass = m
        body.ipos = [0, 0, 0]
        body.inertia = [0.5 * m * Rs**2] * 3
        body.add_joint(name=f"idler_{name}", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 1, 0])
        body.add_geom(name=f"idler_{name}", type=mujoco.mjtGeom.mjGEOM_CYLINDER,
                      size=[Rs, (robot.track_gauge + robot.track_width) / 2, 0],
                      quat=[math.sqrt(0.5), math.sqrt(0.5), 0, 0], contype=0, conaffinity=0, density=0,
                      rgba=[0.15, 0.15, 0.15, 1])
        com = (m_chassis * com - m * np.array([x, 0.0, z])) / (m_chassis - m)
        m_chassis -= m
    chassis.mass, chassis.ipos = m_chassis, com

def apply_solver_options(spec: mujoco.MjSpec, config: SimConfig) -> mujoco.MjOption:
    """The solver settings of ``config`` that both track models share (time step, integrator,
    cone, impratio, noslip, solver, iterations, tolerance, Jacobian); returns the option."""
    opt = spec.option
    opt.timestep = config.timestep
    opt.integrator = _INTEGRATORS[config.integrator]
    opt.cone = mujoco.mjtCone.mjCONE_ELLIPTIC if config.cone == "elliptic" else mujoco.mjtCone.mjCONE_PYRAMIDAL
    opt.impratio = config.impratio
    opt.noslip_iterations = config.noslip_iterations
    opt.noslip_tolerance = config.noslip_tolerance
    opt.iterations = config.iterations
    opt.tolerance = config.tolerance
    opt.solver = {"Newton": mujoco.mjtSolver.mjSOL_NEWTON, "PGS": mujoco.mjtSolver.mjSOL_PGS,
                  "CG": mujoco.mjtSolver.mjSOL_CG}[config.solver]
    opt.jacobian = mujoco.mjtJacobian.mjJAC_SPARSE if config.jacobian == "sparse" else mujoco.mjtJacobian.mjJAC_DENSE
    return opt

def track_contacts(spec: mujoco.MjSpec, robot: Robot) -> list[tuple[str, float]]:
    """(geom name, μ) of the track contact elements of a robot spec: the rollers, surfacevel
    elements or wheels (``roller_<side>_<i>`` / ``track_<side>_<i>`` / ``wheel_<side>_<i>``), then
    the idlers (mean track μ)."""
    mu = {"left": robot.friction_left, "right": robot.friction_right}
    out = []
    for side in SIDES:
        out += [(g.name, mu[side]) for g in spec.geoms
                if g.name.startswith(tuple(f"{kind}_{side}_" for kind in ELEMENT_KINDS))]
    return out + [(g.name, (mu["left"] + mu["right"]) / 2) for g in spec.geoms if g.name.startswith("idler_")]


def add_ground(spec: mujoco.MjSpec, robot: Robot, terrain: Terrain, contacts: list[tuple[str, float]],
               pair_options: dict) -> mujoco.MjSpec:
    """The scene both track models share: terrain geoms, contact pairs, the robot's initial pose on
    the terrain (at the origin, aligned with the ground, on its highest point under the tracks),
    a light. Idlers touch only steps and height fields (they are above a plane: no pairs there)."""
    reach = robot.contact_length / 2 + robot.sprocket_radius  # front/rear idler ends (wheels' fronts)
    for st in terrain.steps:
        if abs(st.x) <= reach + STEP_CLEARANCE:
            # measured: a robot spawned across an edge can be launched (20 kg, step 4 cm at x 0.3 m)
            raise InputError(f"terrain={terrain.spec!r}: the step edge at x = {st.x:g} m lies under the robot's "
                             f"start footprint (|x| <= {reach + STEP_CLEARANCE:.3g} m); put it farther from the origin")
    if terrain.hfield is None and not terrain.steps:
        contacts = [c for c in contacts if not c[0].startswith("idler_")]
    add_terrain(spec, terrain, contacts, nominal_mu=robot.mu, pair_options=pair_options)
    if not terrain.is_flat:
        chassis = spec.body("chassis")
        h = terrain.height_under(robot.contact_length / 2 + robot.sprocket_radius,
                                 (robot.track_gauge + robot.track_width) / 2)
        q = terrain.quat
        lift = np.zeros(3)
        mujoco.mju_rotVecQuat(lift, np.array([0.0, 0.0, h + 0.002]), q)
        chassis.pos = lift
        chassis.quat = q
    spec.worldbody.add_light(name="sun", pos=[0, 0, 5], dir=[0, 0, -1], type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL)
    return spec
