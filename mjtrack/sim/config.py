"""Simulation settings of the MuJoCo tracked robot: :class:`SimConfig`.

Everything that is not a property of the robot itself (those live in
:class:`mjtrack.io.robot.Robot`) but decides how it is simulated: time step, roller
discretisation of the tracks, suspension, contact model and solver, the drive servo.
The defaults are the settings that ``benchmarks/fidelity.py`` measured against the
rigid-track Coulomb reference; ``assets/README.md`` says why each one is what it is.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

from mjtrack.errors import InputError
from mjtrack.io.robot import G

TRACK_MODELS = ("rollers", "surfacevel")
SOLVERS = ("Newton", "PGS", "CG")
# most divisions of the step the slip budget asks for (5 ms / 8 = 0.625 ms): gentler turns of
# light robots than a 5 kg robot at R 10 m, 0.2 m/s (k = 5) run at 0.625 ms, unconverged in dt
MAX_STEP_DIVISIONS = 8


@dataclass(frozen=True)
class SimConfig:
    """How the robot is simulated (SI units).

    Attributes:
        timestep: integration step [s].
        n_rollers: contact rollers per track (>= 2); placed at the midpoints of N equal
            cells of the contact length, so that they integrate a uniform load exactly [-].
        roller_radius: radius of the spherical contact rollers [m].
        unsprung_fraction: share of ``robot.mass`` in the 2N rollers (unsprung mass) [-];
            a fraction, so that the explicit damper's stability margin c dt / m_roller does
            not depend on the robot's mass.
        suspension_deflection: static spring deflection of a roller under its share of the
            weight [m]; sets the road-wheel spring stiffness k = m g / (2 N d).
        suspension_damping_ratio: damping of the roller spring relative to critical for
            the roller's share of the sprung mass [-].
        track_mass: drivetrain inertia of one track (chain, sprocket, gearbox and rotor)
            reflected to the track surface [kg]; armature track_mass r^2 / N on each roller
            hinge (track_mass R_s^2 on the sprocket with the equality coupling). Heavy by
            default (a geared motor: rotor 5e-5 kg m^2 x 100^2 / R_s^2 = 139 kg), so that the
            rollers of a track move together (assets/README.md, item 5).
        kv: velocity-servo gain of a track drive [N/(m/s)] (kv / N per roller servo).
        torque_limit: sprocket torque limit [N m] (track force limit torque/R_s).
        drive_reference_mass: robot mass [kg] for which ``track_mass``, ``kv`` and
            ``torque_limit`` are given; the roller chain scales all three up by
            max(1, robot.mass / drive_reference_mass) (:meth:`for_robot_mass`), so that no
            robot has a softer drive per unit of traction than the default one (track speeds
            within F/kv = 2.6 mm/s of the command at full traction, same spin-up acceleration
            and explicit-damper margin kv dt / track_mass). Not scaled down: a 5 kg robot with
            a quarter of the drive missed Coulomb by up to 3.9 T/2 in 10 m turns at 0.2 m/s
            against 0.42 with the full one. ``None``: absolute values (before: a 150 kg robot
            had the 20 kg robot's drive, benchmarks/fidelity.py --wide --previous-defaults).
        lag: first-order time constant from command to servo set-point [s] (0 = none).
        contact_timeconst: contact solref time constant [s] (0 = 2 timesteps).
        contact_dampratio: contact solref damping ratio [-].
        solimp: contact impedance (dmin, dmax, width, midpoint, power).
        friction_timeconst: solref time constant of the friction rows only [s] (explicit
            contact pairs' ``solreffriction``; 0 = 2 timesteps). Keep it short: the noslip
            pass then opposes the slip *velocity*; a long one (1 s) makes friction follow
            accelerations (measured err_x 0.45 L, benchmarks/sim_ablation.py).
        contact_margin: distance at which a roller-ground contact becomes active [m]; room
            for the separating acceleration that sliding produces in MuJoCo's convex contact
            model, so that a sliding roller floats up a little instead of losing contact.
        coupling_timeconst: solref time constant of the roller-sprocket couplings [s]
            (0 = 2 timesteps).
        coupling: how a track's rollers share its speed: ``"servo"`` (each roller hinge has
            its own velocity servo on the track command, gain kv, force limit
            torque_limit / (R_s N), armature track_mass r^2 / N: no constraint rows) or
            ``"equality"`` (roller hinges tied to one sprocket by joint equalities, one
            servo on the sprocket: an exact chain, but N more constraint rows).
        belt_timeconst: the track belt (``coupling="servo"``): each track has a belt joint
            ``belt_<side>`` carrying a quarter of its reflected inertia (``track_mass``; the rollers
            keep the rest) and every roller's surface is tied to it by a spring of stiffness
            k = (track_mass / N) / belt_timeconst^2 (fixed tendons ``belt_<side>_<i>`` =
            r (q_i - q_belt)), so that in a steady state every roller of a track runs at the belt's
            speed, as the contact points of a belt do, whatever its load [s]. Without it (``None``,
            before session 6) only the servos tie the rollers together and their surface speeds
            spread by F_i / (kv/N): mm/s, the size of the slips of a gentle turn, which moved x_c
            by up to 0.03 L at R 10 m, 0.2 m/s (benchmarks/gentle_turns.py, sections 5, 7, 8).
            Internal forces: the drive's common mode is untouched. Cost 2 % of a step at N = 10
            and 40. Two forms were measured (development probes) and not kept: every roller tied to its track's mean
            position (same steady states, but N^2 tendon entries: 4.6 % at N = 10, 20 % at 40)
            and a chain of springs between neighbours (its end-to-end mode relaxes in 0.15 s at
            N = 10, 2.4 s at 40, and made straight driving creep 3.5e-4 of the speed).
            Explicit Euler: the belt joint's mode against its rollers, w = 2.31 / belt_timeconst,
            needs w dt < 1.5 (checked).
        slip_budget: largest ratio mu g dt / (|w| L/2) of the friction's velocity change per step
            to the lateral slip at the track ends that a steady case may run at
            (:meth:`step_for`) [-]: the noslip friction opposes the slip expected one step
            ahead, and where one step of friction moves a contact by many times its slip the
            friction direction is off (errors follow the friction time constant 2 dt, not the
            contact's: gentle_turns.py section 8; with the belt the dt-halving change of gentle
            turns stays <= 0.0033 T/2 up to r = 12 and reaches 0.022 at r = 21.8). ``None``: no
            such rule.
        principal_axes: the chassis takes the products of inertia that keep the whole robot's
            principal axes on the body axes (:func:`mjtrack.sim.chassis.chassis_mass_properties`);
            False: a plain box (before session 6: the elements then tilt the principal axes and
            a spinning robot with its cg off-centre feels a pitch moment no description of it has).
        cone: ``"elliptic"`` (isotropic Coulomb cone) or ``"pyramidal"``.
        impratio: friction-to-normal impedance ratio (elliptic cones) [-]; 1e-4 keeps the
            friction rows of the main solve far inside the cone (no sliding lift-off); the
            noslip pass then supplies hard Coulomb friction.
        noslip_iterations: most post-solve iterations of the un-regularised friction solver
            (it stops at its tolerance: 5 iterations in turns). Fewer cost accuracy where it
            needs more: 4 moves turn ICRs by <= 0.004 T/2 but straight driving drifts 2 mm/m
            at 2 m/s (20: 0.09 mm/m); assets/README.md "Speed". 40 since session 6: with the
            belt, straight driving keeps tangential preloads from the start and 20 iterations
            left 0.49 mm/m at 0.8 m/s (30: 0.035, 40: 0.008), at no measurable cost on random
            steps (88x real time either way: the tolerance stops it first elsewhere; development
            probes, with the mean-coupled belt of the time).
        solver: main constraint solver, ``"Newton"``, ``"PGS"`` or ``"CG"``. PGS: with
            impratio 1e-4 the main solve carries only the normal rows and PGS reaches
            Newton's forces (ICRs equal to 1e-7) without Newton's nv x nv factorisation, on the
            matrix that noslip needs anyway.
        iterations, tolerance: main solver settings.
        jacobian: ``"dense"`` or ``"sparse"``. With friction in the noslip pass (which
            works on the dense constraint matrix) dense measured ~15 % faster at 10 rollers;
            sparse was 2-6x faster when the main Newton solve carried the friction.
        integrator: ``"implicitfast"``, ``"Euler"``, ``"implicit"`` or ``"RK4"``.
        implicit_damping: keep MuJoCo's implicit joint damping under Euler (default off:
            the constraint solver cannot see it, see assets/README.md).
        track_model: ``"rollers"`` (this module's roller chain) or ``"surfacevel"``.
        noslip_tolerance: early-termination tolerance of the noslip pass (MuJoCo's default
            1e-6). 1e-4 is 7 % faster at 10 rollers and moves issue-3 grid ICRs by <= 0.0012 T/2,
            but the most ill-conditioned gentle turns (5 kg, R 10 m) by 0.07 T/2: kept at 1e-6.
        rest_margin: roller chain only: make each roller's rest penetration its contact margin
            (:func:`mjtrack.sim.builder.apply_rest_margins`), so that the contact point lies at the
            roller radius and the ground sees the measured track speed (MuJoCo puts a
            sphere-plane contact half-way into the penetration).
        level_chassis: preload each element's spring with its share of Wong's linear load
            distribution (:func:`mjtrack.sim.chassis.rest_loads`), so that a chassis whose
            centre of mass is off-centre rests level instead of pitching on its springs. On a
            pitched chassis the slides lean, and the noslip pass's longitudinal friction pushed
            the rollers along them (an acceleration the main solve never saw): inner rollers sank
            and outer ones rose by up to 48 um in a turn, moving the contact points
            (benchmarks/gentle_turns.py). Off (or |c_x| beyond ~L/6): equal preloads.
        lag_budget: roller chain: largest x_c offset v dt allowed, as a fraction of the track
            length [-]. The noslip friction opposes the slip predicted one step ahead, which the
            turn has rotated by w dt, so a steady turn's x_c sits v dt off Coulomb
            (benchmarks/gentle_turns.py, section 5): 1 cm = 0.056 L for a 0.18 m track at 2 m/s
            and 5 ms. In steady states (``steady_batch``, so ``steady`` and ``sweep``) each case
            runs at ``timestep / k``, k the smallest integer with v_max dt <= lag_budget L (v_max:
            the larger |track speed| commanded; :meth:`step_for`). 0.01 keeps the default
            robot at 5 ms up to 1 m/s. None: ``timestep`` always. Logs (``drive_log``, so
            ``simulate``), calibration and diagnosis windows and the closed-loop plant run at
            ``timestep``: a log is then simulated at the step its windows are, and a window step
            that followed the fitted track length would make the objective discontinuous.
    """

    timestep: float = 0.005
    n_rollers: int = 10
    roller_radius: float = 0.03
    unsprung_fraction: float = 0.3
    suspension_deflection: float = 0.005
    suspension_damping_ratio: float = 1.0
    track_mass: float = 200.0
    kv: float = 30000.0
    torque_limit: float = 60.0
    lag: float = 0.0
    drive_reference_mass: float | None = 20.0
    contact_timeconst: float = 0.0
    contact_dampratio: float = 1.0
    solimp: tuple[float, float, float, float, float] = (0.95, 0.99, 0.001, 0.5, 2.0)
    friction_timeconst: float = 0.0
    contact_margin: float = 0.0
    coupling_timeconst: float = 0.0
    coupling: str = "servo"
    belt_timeconst: float | None = 0.01
    slip_budget: float | None = 5.0
    principal_axes: bool = True
    cone: str = "elliptic"
    impratio: float = 1e-4
    noslip_iterations: int = 40
    noslip_tolerance: float = 1e-6
    rest_margin: bool = True
    level_chassis: bool = True
    lag_budget: float | None = 0.01
    solver: str = "PGS"
    iterations: int = 50
    tolerance: float = 1e-6
    jacobian: str = "dense"
    integrator: str = "Euler"
    implicit_damping: bool = False
    track_model: str = "rollers"

    def __post_init__(self) -> None:
        if not (isinstance(self.unsprung_fraction, (int, float)) and 0 < self.unsprung_fraction <= 0.5):
            raise InputError(f"sim config: 'unsprung_fraction' must be in (0, 0.5], got {self.unsprung_fraction!r}")
        for name in ("timestep", "roller_radius", "suspension_deflection",
                     "track_mass", "kv", "torque_limit", "impratio", "tolerance", "noslip_tolerance"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise InputError(f"sim config: '{name}' must be a positive number, got {value!r}")
        for name in ("lag", "contact_timeconst", "coupling_timeconst", "friction_timeconst", "contact_margin", "suspension_damping_ratio",
                     "contact_dampratio"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
                raise InputError(f"sim config: '{name}' must be a number >= 0, got {value!r}")
        for name in ("rest_margin", "level_chassis", "principal_axes"):
            if not isinstance(getattr(self, name), bool):
                raise InputError(f"sim config: '{name}' must be true or false, got {getattr(self, name)!r}")
        for name in ("lag_budget", "belt_timeconst", "slip_budget"):
            value = getattr(self, name)
            if value is not None and not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise InputError(f"sim config: '{name}' must be a positive number or None, got {value!r}")
        if self.drive_reference_mass is not None and not (
                isinstance(self.drive_reference_mass, (int, float)) and math.isfinite(self.drive_reference_mass)
                and self.drive_reference_mass > 0):
            raise InputError(f"sim config: 'drive_reference_mass' must be a positive number or None, "
                             f"got {self.drive_reference_mass!r}")
        if not isinstance(self.n_rollers, int) or self.n_rollers < 2:
            raise InputError(f"sim config: 'n_rollers' must be an integer >= 2, got {self.n_rollers!r}")
        for name in ("noslip_iterations", "iterations"):
            value = getattr(self, name)
            if not isinstance(value, int) or value < 0:
                raise InputError(f"sim config: '{name}' must be an integer >= 0, got {value!r}")
        if len(self.solimp) != 5:
            raise InputError(f"sim config: 'solimp' needs 5 numbers, got {self.solimp!r}")
        if self.cone not in ("elliptic", "pyramidal"):
            raise InputError(f"sim config: 'cone' must be elliptic or pyramidal, got {self.cone!r}")
        if self.coupling not in ("servo", "equality"):
            raise InputError(f"sim config: 'coupling' must be servo or equality, got {self.coupling!r}")
        if self.solver not in SOLVERS:
            raise InputError(f"sim config: 'solver' must be one of {SOLVERS}, got {self.solver!r}")
        if self.jacobian not in ("sparse", "dense"):
            raise InputError(f"sim config: 'jacobian' must be sparse or dense, got {self.jacobian!r}")
        if self.integrator not in ("implicitfast", "Euler", "implicit", "RK4"):
            raise InputError(f"sim config: unknown integrator {self.integrator!r}")
        if self.track_model not in TRACK_MODELS:
            raise InputError(
                f"sim config: 'track_model' must be one of {TRACK_MODELS}, got {self.track_model!r}"
            )

    @property
    def contact_solref(self) -> tuple[float, float]:
        """(timeconst, dampratio) of the ground contacts; 0 means two timesteps."""
        tc = self.contact_timeconst or 2.0 * self.timestep
        return (tc, self.contact_dampratio)

    @property
    def coupling_solref(self) -> tuple[float, float]:
        tc = self.coupling_timeconst or 2.0 * self.timestep
        return (tc, 1.0)

    def roller_mass(self, robot_mass: float) -> float:
        """Mass of one roller [kg] for a robot of ``robot_mass`` [kg]."""
        return self.unsprung_fraction * robot_mass / (2 * self.n_rollers)

    def for_robot_mass(self, robot_mass: float) -> "SimConfig":
        """The drive settings (track_mass, kv, torque_limit) scaled up to a robot of ``robot_mass``
        [kg] (see ``drive_reference_mass``); unchanged when it is None or the robot is lighter."""
        if self.drive_reference_mass is None:
            return self
        s = max(1.0, robot_mass / self.drive_reference_mass)
        return self.replace(track_mass=self.track_mass * s, kv=self.kv * s, torque_limit=self.torque_limit * s,
                            drive_reference_mass=None)

    def step_for(self, track_length: float, v_max: float, turn_rate: float = 0.0, mu: float = 0.0) -> "SimConfig":
        """This config with the roller chain's time step for a steady case: ``timestep / k``, k the
        smallest integer with

        * v_max dt <= lag_budget L (track speeds up to ``v_max`` [m/s], ``lag_budget``) and
        * mu g dt <= slip_budget |w| L / 2 (turn rate ``turn_rate`` [rad/s], friction ``mu``,
          ``slip_budget``; no rule when the robot does not turn), k at most
          :data:`MAX_STEP_DIVISIONS` for this rule,

        L = ``track_length`` [m]. Unchanged for the surfacevel model, without budgets, or when k
        is 1; so applying it twice changes nothing, and halving ``timestep``, ``lag_budget`` and
        ``slip_budget`` together halves the step it gives."""
        if self.track_model != "rollers":
            return self
        k = 1
        if self.lag_budget is not None and v_max > 0:
            k = max(k, math.ceil(v_max * self.timestep / (self.lag_budget * track_length) * (1 - 1e-12)))
        k = max(k, min(self.slip_divisions(track_length, turn_rate, mu), MAX_STEP_DIVISIONS))
        return self if k == 1 else self.replace(timestep=self.timestep / k)

    def slip_divisions(self, track_length: float, turn_rate: float, mu: float) -> int:
        """The divisions of ``timestep`` the slip budget asks for (uncapped; 1 without a budget,
        a turn or friction): the smallest k with mu g timestep / k <= slip_budget |w| L / 2."""
        end_slip = abs(turn_rate) * track_length / 2
        if self.slip_budget is None or not end_slip > 0 or not mu > 0:
            return 1
        return max(1, math.ceil(mu * G * self.timestep / (self.slip_budget * end_slip) * (1 - 1e-12)))

    def halved(self) -> "SimConfig":
        """The config whose step is half the one this config runs each case at (a convergence
        check): halving the time step, the lag budget and the slip budget together halves the step
        :meth:`step_for` picks."""
        return self.replace(timestep=self.timestep / 2,
                            lag_budget=None if self.lag_budget is None else self.lag_budget / 2,
                            slip_budget=None if self.slip_budget is None else self.slip_budget / 2)

    def replace(self, **changes: Any) -> "SimConfig":
        """A copy with some fields changed (validated again)."""
        return dataclasses.replace(self, **changes)

    def to_dict(self) -> dict[str, Any]:
        d = dataclasses.asdict(self)
        d["solimp"] = list(self.solimp)
        return d


# The roller chain's defaults before the speed study (benchmarks/bench_sim.py --compare,
# benchmarks/fidelity.py --wide --previous-defaults): Newton main solver, one drive for every
# robot mass. Kept so that old and new settings are timed and checked in the same run (ratios
# survive a loaded machine better than absolute numbers).
PREVIOUS_ROLLER_DEFAULTS = dict(solver="Newton", noslip_iterations=20, drive_reference_mass=None, rest_margin=False,
                                level_chassis=False, lag_budget=None, belt_timeconst=None, slip_budget=None,
                                principal_axes=False)


def previous_defaults() -> SimConfig:
    """The roller chain's settings before the speed study (:data:`PREVIOUS_ROLLER_DEFAULTS`)."""
    return SimConfig(**PREVIOUS_ROLLER_DEFAULTS)


# Settings measured for the surfacevel track model (benchmarks/surfacevel_study.py; why each
# one: mjtrack/sim/surfacevel.py's docstring), pinned here: the SimConfig
# defaults are tuned for the roller chain and change with it. Why each one: module docstring.
SURFACEVEL_SETTINGS = dict(
    track_model="surfacevel",
    timestep=0.002,  # [s] halving it moves the ICRs by < 0.2 % of T/2
    n_rollers=12,  # elements per track at cell midpoints
    roller_radius=0.03,  # [m] sphere radius
    roller_mass=0.15,  # [kg] unsprung mass of one element (older SimConfig) ...
    unsprung_fraction=0.18,  # ... or the same 24 x 0.15 kg as a share of the 20 kg robot
    suspension_deflection=0.01,  # [m] static spring deflection: loads determinate
    suspension_damping_ratio=1.0,
    contact_timeconst=0.0,  # 2 timesteps
    contact_dampratio=1.0,
    solimp=(0.0, 0.99, 0.001, 0.5, 2.0),  # dmin = 0: no push at zero penetration, no element hop
    friction_timeconst=0.0,  # friction rows as hard as the normal row: weak ones creep
    cone="elliptic",
    impratio=10.0,
    noslip_iterations=0,  # no effect through surfacevel (measured), costs time
    solver="Newton",  # pinned: the roller chain default (PGS) was not measured here
    iterations=50,
    tolerance=1e-8,
    integrator="implicitfast",
    lag_budget=None,  # a roller-chain rule (its noslip friction lag); not measured here
    slip_budget=None,  # likewise
    belt_timeconst=None,  # the roller chain's belt tendons
)


def surfacevel_config(**changes) -> SimConfig:
    """The SimConfig this model was measured with: :data:`SURFACEVEL_SETTINGS` plus ``changes``.

    Settings that this version of SimConfig does not have are left out.
    """
    names = {f.name for f in dataclasses.fields(SimConfig)}
    return SimConfig(**{k: v for k, v in {**SURFACEVEL_SETTINGS, **changes}.items() if k in names or k in changes})


#: settings a robot description may carry under its key ``simulator`` (a calibrated robot records
#: the simulator its parameters were fitted with, so that every command rebuilds that one)
ROBOT_SIM_KEYS = ("track_model", "n_rollers", "timestep")


def robot_sim_settings(robot) -> dict:
    """The ``simulator`` settings of a robot description ({} when it has none); InputError on a bad one."""
    given = robot.extra.get("simulator") if robot is not None else None
    if given is None:
        return {}
    if not isinstance(given, dict) or set(given) - set(ROBOT_SIM_KEYS):
        raise InputError(f"robot: 'simulator' must be an object with keys among {', '.join(ROBOT_SIM_KEYS)}, "
                         f"got {given!r}")
    out = dict(given)
    if "n_rollers" in out and (not isinstance(out["n_rollers"], int) or isinstance(out["n_rollers"], bool)
                               or not 2 <= out["n_rollers"] <= 200):
        raise InputError(f"robot: simulator 'n_rollers' must be a whole number in [2, 200], got {out['n_rollers']!r}")
    if "timestep" in out and (isinstance(out["timestep"], bool) or not isinstance(out["timestep"], (int, float))
                              or not 1e-5 <= out["timestep"] <= 0.05):
        raise InputError(f"robot: simulator 'timestep' must be a number in [1e-05, 0.05] s, got {out['timestep']!r}")
    if out.get("track_model", "rollers") not in ("rollers", "surfacevel"):
        raise InputError(f"robot: simulator 'track_model' must be rollers or surfacevel, got {out['track_model']!r}")
    return out


def sim_config(track_model: str | None = "rollers", *, timestep: float | None = None, robot=None) -> SimConfig:
    """The measured default settings of a track model (the surfacevel model has its own); with
    ``timestep``, that fixed step (no ``lag_budget`` nor ``slip_budget``: an explicit step is
    used as given).

    With ``robot``, the settings its description records under ``simulator``
    (:func:`robot_sim_settings`) apply where the arguments do not say otherwise: ``track_model``
    None takes the robot's (else rollers), ``timestep`` None the robot's."""
    settings = robot_sim_settings(robot)
    if track_model is None:
        track_model = settings.get("track_model", "rollers")
    if timestep is None and "timestep" in settings and settings.get("track_model", "rollers") == track_model:
        timestep = float(settings["timestep"])
    if track_model == "surfacevel":
        config = surfacevel_config(track_model="surfacevel")
    elif track_model == "rollers":
        config = SimConfig()
        if "n_rollers" in settings:
            config = config.replace(n_rollers=int(settings["n_rollers"]))
    else:
        raise InputError(f"unknown track model {track_model!r}; choose rollers or surfacevel")
    return config if timestep is None else config.replace(timestep=timestep, lag_budget=None, slip_budget=None)
