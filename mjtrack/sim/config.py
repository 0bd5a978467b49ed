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
    """How the robot is simulated (SI units; the measurements behind each default: docs/theory/simulator.md).

    Attributes:
        timestep: integration step [s] (steady states may take a shorter one: ``lag_budget``).
        n_rollers, roller_radius: contact rollers per track (>= 2) [-] and their radius [m].
        unsprung_fraction: share of ``robot.mass`` in the 2N rollers [-].
        suspension_deflection, suspension_damping_ratio: static deflection of a roller spring under
            its share of the weight [m]; its damping relative to critical [-].
        track_mass, kv, torque_limit: drivetrain inertia of one track at its surface [kg], track
            servo gain [N/(m/s)], sprocket torque limit [N m].
        drive_reference_mass: robot mass [kg] those three are given for; heavier robots get them
            scaled up (:meth:`for_robot_mass`); ``None``: absolute values.
        lag: first-order time constant from command to servo set-point [s] (0 = none).
        contact_timeconst, contact_dampratio, solimp: contact solref time constant [s] (0 = two
            steps), damping ratio [-] and impedance (dmin, dmax, width, midpoint, power).
        friction_timeconst: solref time constant of the friction rows only [s] (0 = two steps).
        contact_margin: distance at which a roller-ground contact becomes active [m].
        coupling, coupling_timeconst: ``"servo"`` (a servo per roller) or ``"equality"`` (rollers
            tied to one sprocket); the time constant of those ties [s] (0 = two steps).
        belt_timeconst: time constant of the springs that tie each roller to its track's belt [s];
            ``None``: no belt.
        slip_budget: largest mu g dt / (|w| L/2) a steady case runs at (:meth:`step_for`) [-].
        principal_axes: the chassis keeps the robot's principal axes on the body axes.
        cone, impratio: ``"elliptic"`` or ``"pyramidal"`` friction cone; friction-to-normal impratio.
        noslip_iterations, noslip_tolerance: limits of MuJoCo's noslip friction pass.
        solver, iterations, tolerance, jacobian, integrator, implicit_damping: MuJoCo's settings.
        track_model: ``"rollers"`` (the roller chain) or ``"surfacevel"``.
        rest_margin, level_chassis: contact point at the roller radius; chassis resting level.
        lag_budget: steady states of the roller chain: largest v dt [fraction of L] per step.
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


# Settings measured for the surfacevel track model (the surfacevel study; why each
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
#: ``drive_input``: what the drives followed when the robot was calibrated on a log ("commanded", the
#: default, or "measured": the logged track speeds), which the MuJoCo diagnosis of a log then follows too
ROBOT_SIM_KEYS = ("track_model", "n_rollers", "timestep", "drive_input")


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
    if out.get("drive_input", "commanded") not in ("commanded", "measured"):
        raise InputError(f"robot: simulator 'drive_input' must be commanded or measured, got {out['drive_input']!r}")
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
