"""Tracked robot whose tracks are moving contact surfaces (MuJoCo ``geom/surfacevel``).

The second MuJoCo track model (``SimConfig.track_model = "surfacevel"``), beside the roller
chain of :mod:`mjtrack.sim.builder`, whose names and settings it shares: :class:`SurfacevelTracks`
plugged into the one robot builder (:mod:`mjtrack.sim.chassis`: chassis, suspension, sensors,
scene).

MuJoCo's surface velocity (MuJoCo >= 3.x; docs: XMLreference ``body/geom/surfacevel``).
``geom_surfacevel`` (ngeom x 6) is a velocity field sigma(x) = v + w x (x - p) in the *geom*
frame (p the geom origin). Contacts see the geom's material move with sigma projected on the
contact's tangent plane; the friction rows' velocity (and ``efc_vel``) is taken relative to
that moving material. The field is a model field, writable between steps ("Safe" in the
programming guide); ``mjModel.flg_surfacevel`` must be 1 when any geom moves (this module sets
it). It cannot be driven by an actuator, and the contact force does not act back on any
degree of freedom: the track speed is kinematic. A lag or torque limit is emulated outside
MuJoCo by :class:`TrackDrive` (one step of explicit coupling, see there).

Derivation and measurements: docs/theory/simulator.md, "The surface-velocity track".
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass

import mujoco
import numpy as np

from mjtrack.errors import InputError
from mjtrack.io.robot import Robot
from mjtrack.sim.chassis import (Suspension, TrackModel, build_robot_model, build_robot_spec, element_positions)
from mjtrack.sim.config import SURFACEVEL_SETTINGS, SimConfig, surfacevel_config  # noqa: F401 (this module's API)
from mjtrack.sim.drivetrain import drive_of
from mjtrack.sim.scene import SIDES
from mjtrack.sim.terrain import Terrain

log = logging.getLogger(__name__)

ELEMENTS = ("sphere", "capsule", "box")


def setting_problems(config: SimConfig) -> list[str]:
    """Contact settings measured to distort this model (module docstring, items 3-4), as messages."""
    out = []
    if config.friction_timeconst > 0.01:
        out.append(f"friction_timeconst {config.friction_timeconst:g} s makes the friction creep (noslip cannot undo it)")
    if config.impratio < 1 and config.noslip_iterations == 0:
        out.append(f"impratio {config.impratio:g} without noslip leaves almost no friction")
    if config.solimp[0] > 0.5 and config.impratio >= 1:
        out.append(f"solimp dmin {config.solimp[0]:g} with hard friction rows lets the sliding elements hop")
    return out


class SurfacevelTracks(TrackModel):
    """Each track a row of N contact elements whose surface moves at the track speed (module
    docstring); plugged into the one robot builder (:mod:`mjtrack.sim.chassis`).

    Args:
        element: shape of a contact element: "sphere" (radius ``roller_radius``), "capsule"
            (across the track, like a road wheel) or "box" (an L/N x width cell).
        n_elements: elements per track (default ``config.n_rollers``); 1 with "box" is one box.
        sprung: elements on sprung vertical slides (else bolted to the chassis).
    """

    name = "surfacevel"
    modelname = "tracked_robot_surfacevel"

    def __init__(self, element: str = "sphere", n_elements: int | None = None, sprung: bool = True) -> None:
        if element not in ELEMENTS:
            raise InputError(f"surfacevel: 'element' must be one of {ELEMENTS}, got {element!r}")
        if n_elements is not None and (int(n_elements) != n_elements or n_elements < 1):
            raise InputError(f"surfacevel: 'n_elements' must be an integer >= 1, got {n_elements!r}")
        self.element, self.n_elements, self.sprung = element, n_elements, sprung

    def elements(self, config: SimConfig) -> int:
        return config.n_rollers if self.n_elements is None else self.n_elements

    def element_mass(self, robot: Robot, config: SimConfig) -> float:
        return super().element_mass(robot, config) if self.sprung else 0.0

    def add_track(self, spec: mujoco.MjSpec, chassis, robot: Robot, config: SimConfig, *, side: str, y: float,
                  mu: float, suspension: Suspension) -> None:
        n, r, w = self.elements(config), config.roller_radius, robot.track_width
        m_el = self.element_mass(robot, config)
        track = chassis.add_body(name=f"{side}_track", pos=[0, y, 0])
        track.add_site(name=f"{side}_track", pos=[0, 0, 0], size=[0.01, 0.01, 0.01])
        for i, x in enumerate(element_positions(robot, n)):
            host, gx = track, x
            if self.sprung:
                host = track.add_body(name=f"wheel_{side}_{i}", pos=[x, 0, 0])
                host.explicitinertial = True
                host.mass = m_el
                host.ipos = [0, 0, r]
                host.inertia = [0.4 * m_el * r**2] * 3
                suspension.add_slide(host, side, i, config)
                gx = 0.0
            _add_element(host, self.element, name=f"track_{side}_{i}", x=gx, r=r, cell=robot.track_length / n, width=w)

    def friction_solref(self, config: SimConfig) -> list[float]:
        # friction_timeconst 0: the friction rows use the contact solref (MuJoCo's [0, 0] default)
        return [config.friction_timeconst, 1.0] if config.friction_timeconst > 0 else [0.0, 0.0]

    def finish_model(self, model: mujoco.MjModel, config: SimConfig) -> mujoco.MjModel:
        model.flg_surfacevel = 1
        return model


def robot_spec(
    robot: Robot,
    config: SimConfig | None = None,
    *,
    element: str = "sphere",
    n_elements: int | None = None,
    sprung: bool = True,
    idlers: bool = False,
    into: mujoco.MjSpec | None = None,
) -> mujoco.MjSpec:
    """The robot (no floor) with its solver options, added to ``into`` when given, else to a new
    spec; ``element``, ``n_elements``, ``sprung``: :class:`SurfacevelTracks`."""
    return build_robot_spec(robot, config, SurfacevelTracks(element, n_elements, sprung), idlers=idlers, into=into)


def _add_element(body, element: str, *, name: str, x: float, r: float, cell: float, width: float) -> None:
    """One contact element whose lowest point is at the body's z = 0 (geom frame = body frame axes)."""
    common = dict(name=name, contype=0, conaffinity=0, density=0, rgba=[0.1, 0.1, 0.1, 1])
    if element == "sphere":
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[r, 0, 0], pos=[x, 0, r], **common)
    elif element == "capsule":  # axis along y; a rotation about x keeps the geom's x forward
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_CAPSULE, size=[r, width / 2, 0], pos=[x, 0, r],
                      quat=[math.sqrt(0.5), math.sqrt(0.5), 0, 0], **common)
    else:
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[cell / 2, width / 2, r], pos=[x, 0, r], **common)


def build_surfacevel_model(robot: Robot, config: SimConfig | None = None, terrain: Terrain | None = None,
                           **options) -> mujoco.MjModel:
    """Compiled model with the tracks at rest; drive it with :func:`set_track_speeds`.

    ``config`` defaults to :func:`surfacevel_config`; a SimConfig with the roller chain's
    friction settings is used as given but logged as a warning (module docstring, item 4).
    """
    config = config or surfacevel_config()
    for problem in setting_problems(config):
        log.warning("surfacevel: %s (the surfacevel study); see surfacevel_config()", problem)
    return build_robot_model(robot, config, SurfacevelTracks(**options), terrain)


def track_geom_ids(model: mujoco.MjModel) -> dict[str, np.ndarray]:
    """Geom ids of each track's contact elements: {"left": (N,), "right": (N,)}."""
    names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, i) or "" for i in range(model.ngeom)]
    return {s: np.array([i for i, nm in enumerate(names) if nm.startswith(f"track_{s}_")]) for s in SIDES}


def set_track_speeds(model: mujoco.MjModel, v_left: float, v_right: float, *, ids=None) -> None:
    """Set the track surface speeds V_L, V_R [m/s] for the following steps (surfacevel -V along x)."""
    ids = ids if ids is not None else track_geom_ids(model)
    model.geom_surfacevel[ids["left"], 0] = -float(v_left)
    model.geom_surfacevel[ids["right"], 0] = -float(v_right)
    model.flg_surfacevel = 1


# -- driving and measuring ----------------------------------------------------------------
def body_twist(data: mujoco.MjData) -> np.ndarray:
    """(vx, vy, wz) of site ``centre`` in the chassis frame [m/s, m/s, rad/s], shape (3,)."""
    lin, ang = data.sensor("body_linvel").data, data.sensor("body_angvel").data
    return np.array([lin[0], lin[1], ang[2]])


def ground_contact(data: mujoco.MjData, ids: dict[str, np.ndarray] | np.ndarray) -> np.ndarray:
    """Whether each track (left, right) has an active ground contact now, bool (2,).

    Active: a contact of the last collision pass with dist < margin (it enters the solver).
    ``ids``: :func:`track_geom_ids`, or its :func:`side_lookup` (faster, for step loops).
    """
    side_of = ids if isinstance(ids, np.ndarray) else side_lookup(ids, data.model.ngeom)
    n = data.ncon
    if n == 0:
        return np.zeros(2, dtype=bool)
    con = data.contact
    sides = side_of[con.geom[:n][con.dist[:n] < con.includemargin[:n]]]
    return np.array([(sides == 0).any(), (sides == 1).any()])


def side_lookup(ids: dict[str, np.ndarray], ngeom: int) -> np.ndarray:
    """Track of every geom id: 0 left, 1 right, -1 none, int (ngeom,) (from :func:`track_geom_ids`)."""
    out = np.full(ngeom, -1, dtype=int)
    for k, s in enumerate(SIDES):
        out[ids[s]] = k
    return out


def track_traction(model: mujoco.MjModel, data: mujoco.MjData, ids: dict[str, np.ndarray]) -> np.ndarray:
    """Ground force on each track along the chassis x axis [N], (2,) (left, right).

    Positive when the ground pushes the robot forward (a forward-driving track's reaction).
    """
    out = np.zeros(2)
    f6 = np.zeros(6)
    R = data.site("centre").xmat.reshape(3, 3)
    for i in range(data.ncon):
        con = data.contact[i]
        for k, s in enumerate(SIDES):
            if con.geom[1] in ids[s]:  # pairs are (floor, element): force on geom[1]
                mujoco.mj_contactForce(model, data, i, f6)
                world = con.frame.reshape(3, 3).T @ f6[:3]
                out[k] += (R.T @ world)[0]
    return out


def element_loads(model: mujoco.MjModel, data: mujoco.MjData, ids: dict[str, np.ndarray]) -> np.ndarray:
    """Normal force on each contact element [N], shape (2, N) (rows left, right; 0 if not touching)."""
    out = np.zeros((2, len(ids["left"])))
    f6 = np.zeros(6)
    for i in range(data.ncon):
        g = data.contact[i].geom[1]
        for k, s in enumerate(SIDES):
            hit = np.flatnonzero(ids[s] == g)
            if hit.size:
                mujoco.mj_contactForce(model, data, i, f6)
                out[k, hit[0]] += f6[0]
    return out


class TrackDrive:
    """Track speeds as a state, applied through surfacevel at every step.

    Per step of length dt with held commands c (left, right) [m/s]:
      set-point  u <- c + (u - c) exp(-dt/lag)        (exact first-order lag, each side its own; u = c if lag = 0)
      kinematic  V <- V + clip(u - V, +-a_max dt)      (``torque_limited=False``)
      servo      m_t dV/dt = F - F_g,  F = clip(kv (u - V), +-F_max)
    with m_t, kv, F_max and the lag of :func:`mjtrack.sim.drivetrain.drive_of` (the roller chain's
    drive: robot keys, mass-scaled defaults), a_max = F_max / (m_t + m/2) and
    F_g the ground's traction on the track (:func:`track_traction`). surfacevel has no degree of
    freedom for the contact force to act on, so F_g is fed back explicitly from the previous
    step; fed back raw it makes a period-2 oscillation (measured: F_g alternating +-78 N in
    straight driving), so it is low-passed with time constant ``traction_filter`` [s]. The
    unsaturated servo is integrated implicitly, V' = (V + dt (kv u - F_g)/m_t) / (1 + dt kv/m_t)
    (m_t/kv < dt). In steady state V = u - F_g/kv (servo droop) or |F_g| = F_max (stall).
    """

    def __init__(self, model: mujoco.MjModel, robot: Robot, config: SimConfig | None = None,
                 *, torque_limited: bool = False, traction_filter: float = 0.01, ground=None) -> None:
        config = config or surfacevel_config()
        if not traction_filter > 0:
            raise InputError(f"surfacevel: 'traction_filter' must be positive, got {traction_filter!r}")
        self.model, self.ids = model, track_geom_ids(model)
        drive = drive_of(robot, config)  # the robot's drivetrain keys, scaled defaults
        self.lags, self.kv, self.track_mass = np.array(drive.lags), drive.kv, drive.track_mass
        self.force_limit = drive.force_limit  # [N]
        # kinematic mode: the track speed changes at most as fast as the force limit can
        # accelerate the drivetrain and the half robot it pushes (m_t + m/2)
        self.max_accel = drive.force_limit / (drive.track_mass + robot.mass / 2)  # [m/s^2]
        self.torque_limited = torque_limited
        self.traction_filter = traction_filter
        self.setpoint = np.zeros(2)  # u [m/s]
        self.speeds = np.zeros(2)  # V [m/s], (left, right)
        self.force = np.zeros(2)  # servo force F [N]
        self.traction = np.zeros(2)  # filtered F_g [N]
        self.ground = ground  # the ground's per-step update (mjtrack.sim.ground.ground_stepper), or None

    def step(self, data: mujoco.MjData, v_left: float, v_right: float) -> None:
        """Advance the drive and the simulation by one timestep under commands V_L, V_R [m/s]."""
        dt = self.model.opt.timestep
        cmd = np.array([v_left, v_right], dtype=float)
        a = np.array([math.exp(-dt / lag) if lag > 0 else 0.0 for lag in self.lags])
        self.setpoint = cmd + (self.setpoint - cmd) * a
        if self.torque_limited:
            fg = track_traction(self.model, data, self.ids)
            self.traction += (fg - self.traction) * (1.0 - math.exp(-dt / self.traction_filter))
            m, kv, fg = self.track_mass, self.kv, self.traction
            v_new = (self.speeds + dt * (kv * self.setpoint - fg) / m) / (1 + dt * kv / m)
            force = kv * (self.setpoint - v_new)
            sat = np.abs(force) > self.force_limit
            force = np.clip(force, -self.force_limit, self.force_limit)
            self.speeds = np.where(sat, self.speeds + dt * (force - fg) / m, v_new)
            self.force = force
        else:
            dv = np.clip(self.setpoint - self.speeds, -self.max_accel * dt, self.max_accel * dt)
            self.speeds = self.speeds + dv
        set_track_speeds(self.model, *self.speeds, ids=self.ids)
        if self.ground is not None:
            self.ground.update(data, *self.speeds)
        mujoco.mj_step(self.model, data)


@dataclass(frozen=True)
class SteadyRun:
    """Mean twist and contact statistics of a constant-command run (:func:`run_steady`).

    vx, vy, wz: mean body twist over the averaging window [m/s, m/s, rad/s]; v_left, v_right:
    track speeds [m/s]; contact_left/right: fraction of all steps with a ground contact [-];
    drift: |lateral displacement| / distance travelled over the window [-] (straight runs);
    loads: mean normal force of each element over the window [N], (2, N) (left, right);
    steps_per_s: wall-clock simulation speed; warnings: MuJoCo warnings raised.
    """

    vx: float
    vy: float
    wz: float
    v_left: float
    v_right: float
    contact_left: float
    contact_right: float
    drift: float
    loads: np.ndarray
    steps_per_s: float
    warnings: int

    def icr(self) -> tuple[float, float, float]:
        """(y_l, y_r, x_c) [m] by (2.13); raises InputError for wz == 0."""
        if self.wz == 0.0:
            raise InputError("surfacevel: ICRs undefined for wz = 0")
        return ((self.vx - self.v_left) / self.wz, (self.vx - self.v_right) / self.wz, -self.vy / self.wz)


def run_steady(model: mujoco.MjModel, v_left: float, v_right: float, *,
               duration: float = 4.0, average: float = 1.5, ground=None) -> SteadyRun:
    """Drive from rest at constant V_L, V_R [m/s] for ``duration`` [s]; average the last ``average`` s.
    ``ground``: the ground's per-step update (:func:`mjtrack.sim.ground.ground_stepper`), or None."""
    if not 0 < average <= duration:
        raise InputError(f"surfacevel: need 0 < average <= duration, got {average!r}, {duration!r}")
    data = mujoco.MjData(model)
    ids = track_geom_ids(model)
    set_track_speeds(model, v_left, v_right, ids=ids)
    side_of = side_lookup(ids, model.ngeom)
    mujoco.mj_forward(model, data)
    n, n_avg = int(round(duration / model.opt.timestep)), int(round(average / model.opt.timestep))
    twist = np.zeros((n_avg, 3))
    contact = np.zeros((n, 2), dtype=bool)
    loads, n_loads = np.zeros((2, len(ids["left"]))), 0
    t0 = time.perf_counter()
    for k in range(n):
        if k == n - n_avg:
            p0, yaw0 = data.qpos[:2].copy(), _yaw(data)
        if ground is not None:
            ground.update(data, v_left, v_right)
        mujoco.mj_step(model, data)
        contact[k] = ground_contact(data, side_of)
        if k >= n - n_avg:
            twist[k - n + n_avg] = body_twist(data)
            if k % 10 == 0:
                loads += element_loads(model, data, ids)
                n_loads += 1
    wall = time.perf_counter() - t0
    d = data.qpos[:2] - p0
    along = np.array([math.cos(yaw0), math.sin(yaw0)])
    dist = abs(d @ along)
    drift = abs(along[0] * d[1] - along[1] * d[0]) / dist if dist > 0 else float("nan")
    vx, vy, wz = twist.mean(axis=0)
    return SteadyRun(vx=float(vx), vy=float(vy), wz=float(wz), v_left=float(v_left), v_right=float(v_right),
                     contact_left=float(contact[:, 0].mean()), contact_right=float(contact[:, 1].mean()),
                     drift=float(drift), loads=loads / max(n_loads, 1), steps_per_s=n / wall,
                     warnings=int(sum(w.number for w in data.warning)))


def _yaw(data: mujoco.MjData) -> float:
    w, x, y, z = data.qpos[3:7]
    return math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
