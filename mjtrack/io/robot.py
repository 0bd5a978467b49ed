"""Robot description: the geometry, mass and friction of a skid-steer robot,
on two tracks or on wheels (``traction``).

A :class:`Robot` is what every simulating command takes, what ``simulate`` writes beside
its log (``LOG.json``) and what ``diagnose`` reads. SI units; angles in radians.

Keys beyond the fields: a key close to a known one (``drive_lags``) is refused as a typo, with
the known key it resembles; a key that names a known quantity otherwise (``weight``, ``length``,
``mass_kg``: :data:`QUANTITY_KEYS`, :data:`UNIT_SUFFIXES`) is refused with the key it means; the fields, ``wheel_radius`` (the alias of ``sprocket_radius``) and the keys mjtrack writes
itself (:data:`RECORD_KEYS`: ``terrain``, ``noise``, ``simulator``) are known; any other key (a data set's metadata such as ``robot``, ``note``,
``sample_rate_hz``) is kept in ``extra``, so that a description round-trips, and listed once in a
warning. A description file is at most :data:`MAX_FILE_BYTES` and nested at most
:data:`MAX_DEPTH` deep (:func:`mjtrack.io.jsonfile.read_json`).
"""

from __future__ import annotations

import dataclasses
import difflib
import json
import logging
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mjtrack.errors import InputError
from mjtrack.io.jsonfile import read_json

logger = logging.getLogger(__name__)

MAX_FILE_BYTES = 1 << 20  # [bytes] a description is a few hundred bytes; a megabyte is not a robot
MAX_DEPTH = 6  # nesting: description > terrain > patches > patch (LOG.json of a run on terrain) is 4
# fields of wheeled robots only (traction "tracks" | "wheels", wheelbase, wheels_per_side): a tracked
# robot's description does not write them
WHEEL_KEYS = ("traction", "wheelbase", "wheels_per_side")
WHEEL_RADIUS = "wheel_radius"  # a wheeled robot's sprocket_radius, read and written under this name too
# written by mjtrack itself: "terrain" beside a simulated log (the terrain it ran on; text in some
# data sets), "noise" beside a simulated log (the measurement noise added to it: mjtrack.sim.noise),
# "simulator" by calibrate (the simulator settings the parameters were fitted with)
RECORD_KEYS = ("terrain", "noise", "simulator")
# "source_<key>": where a value of the description comes from (calibrate lists it under "assumed")
SOURCE_PREFIX = "source_"
TYPO_CUTOFF = 0.8  # difflib similarity at which an unknown key is taken for a misspelt known key
# unknown keys that name a quantity the description holds under another key: refused with that key
# (kept, they would be ignored and the robot would run at the key's default, e.g. 20 kg for "weight")
QUANTITY_KEYS: dict[str, str] = {
    **dict.fromkeys(("weight", "total_mass", "robot_mass", "mass_total"), "mass"),
    **dict.fromkeys(("length", "contact_length", "track_contact_length"), "track_length"),
    **dict.fromkeys(("gauge", "track_separation", "wheel_separation", "track_distance", "tread"), "track_gauge"),
    **dict.fromkeys(("width", "belt_width", "tyre_width", "tire_width"), "track_width"),
    **dict.fromkeys(("radius", "sprocket_radius_m", "drive_radius"), "sprocket_radius"),
    **dict.fromkeys(("friction", "friction_coefficient", "ground_friction"), "mu"),
    **dict.fromkeys(("mu_l", "friction_left"), "mu_left"),
    **dict.fromkeys(("mu_r", "friction_right"), "mu_right"),
    **dict.fromkeys(("com_x", "cog_x", "cm_x", "cg_offset_x"), "cg_x"),
    **dict.fromkeys(("com_y", "cog_y", "cm_y", "cg_offset_y"), "cg_y"),
    **dict.fromkeys(("com_z", "cog_z", "cm_z", "height", "cg_height", "com_height"), "cg_z"),
    **dict.fromkeys(("lag", "time_constant", "actuator_lag"), "drive_lag"),
    **dict.fromkeys(("delay", "dead_time", "command_delay"), "drive_delay"),
    **dict.fromkeys(("speed_scale", "track_scale"), "track_speed_scale"),
    **dict.fromkeys(("wheel_base", "axle_distance"), "wheelbase"),
}
# unit suffixes a key may carry (``mass_kg``): the description is in SI units, under the plain key
UNIT_SUFFIXES = ("_m", "_mm", "_cm", "_kg", "_g", "_s", "_ms", "_n", "_deg", "_rad")
_warned: set[tuple[str, tuple[str, ...]]] = set()  # (source, keys) already listed in a warning

G = 9.81  # [m/s^2] gravity used throughout the package
MAX_DRIVE_TIME = 10.0  # [s] largest accepted drive_lag / drive_delay (beyond: a unit error)
MAX_SPEED_SCALE = 10.0  # [-] largest accepted track_speed_scale
MAX_RESISTANCE = 1.0  # [-] largest accepted rolling_resistance (beyond: the robot could not move on any ground)
NULLABLE = ("mu_left", "mu_right", "drive_force_limit", "wheelbase")  # keys that may be JSON null
# drivetrain keys that may be JSON null (none / the both-sides key) and are written only when set
DRIVE_SIDE_KEYS = ("drive_speed_limit", "drive_speed_limit_left", "drive_speed_limit_right", "drive_lag_left",
                   "drive_lag_right", "drive_delay_left", "drive_delay_right", "drive_accel_limit",
                   "drive_mean_speed_limit", "drive_turn_limit", "drive_mean_accel_limit", "drive_turn_accel_limit")
MAX_DRIVE_SPEED = 100.0  # [m/s] largest accepted drive_speed_limit (beyond: a unit error)
MAX_DRIVE_ACCEL = 1000.0  # [m/s^2] largest accepted drive_accel_limit (100 g: a unit error)
TRACTIONS = ("tracks", "wheels")
MAX_WHEELS_PER_SIDE = 10
# cg_z (the height of the centre of mass above the ground) is at most this multiple of the
# footprint's larger side, max(track_gauge, contact length). At that height a robot tips over
# under a lateral acceleration of g T / (2 cg_z) <= g / 4 (a gentle turn, or a 14 degree side
# slope, already tips it), which no skid-steer robot is built for; a higher value is a unit or
# sign error, and the MuJoCo robot does not settle to a steady state with it.
MAX_CG_HEIGHT_RATIO = 2.0

# Physical plausibility of a description: (low, high) inclusive. Beyond these a value is a unit
# mix-up or a corrupt file (a 1 mm to 100 m track, a 1 g to 10 000 t robot, friction up to 10),
# and the simulator would fail on it with a cryptic message, so it is refused up front.
PLAUSIBLE_ROBOT: dict[str, tuple[float, float, str]] = {
    "track_gauge": (1e-3, 100.0, "m"), "track_length": (1e-3, 100.0, "m"), "track_width": (1e-3, 100.0, "m"),
    "sprocket_radius": (1e-3, 100.0, "m"), "wheelbase": (1e-3, 100.0, "m"), "mass": (1e-3, 1e7, "kg"),
    "mu": (0.0, 10.0, "-"), "mu_left": (0.0, 10.0, "-"), "mu_right": (0.0, 10.0, "-"),  # > 0 checked above;
    # a track with friction 1e-12 is how the diagnosis isolates the other track's effect
}

# Ground models (key ``ground`` of a description): name -> {parameter: (default, low, high)}.
# What each one is and how the MuJoCo robot realises it: mjtrack/sim/ground.py, assets/README.md.
GROUND_MODELS: dict[str, dict[str, tuple[float, float, float]]] = {
    # rigid track, isotropic Coulomb friction, load spread along the track (Wong's linear law)
    "coulomb": {},
    # the load concentrated under `wheels` road wheels spread over `span` of the contact length;
    # `concentration` is the share of the weight they carry (the rest stays spread along the track)
    "road_wheels": {"wheels": (4.0, 1.0, 20.0), "concentration": (0.8, 0.0, 0.95), "span": (1.0, 0.05, 1.0)},
    # friction anisotropic in the track's frame: lateral / longitudinal coefficient (mu is longitudinal)
    "anisotropic": {"lateral_ratio": (0.5, 0.05, 1.0)},
    # Janosi-Hanamoto shear: friction builds up as mu (1 - exp(-j/K)) with the shear displacement j
    # [m]; shear_modulus K [m], 0 = coulomb; lateral_shear_ratio: the modulus across the track or
    # tyre over the one along it (1: isotropic; docs/theory/shear.md, "Different moduli along and across")
    "shear": {"shear_modulus": (0.01, 0.0, 0.5), "lateral_shear_ratio": (1.0, 0.1, 10.0)},
}



def side_word(traction: str) -> str:
    """What carries each side of a robot on ``traction`` ("tracks" or "wheels"), in words: "track" or
    "wheels" (a wheeled robot's side ICR is that of its left or right wheels)."""
    return "wheels" if traction == "wheels" else "track"

@dataclass(frozen=True)
class Ground:
    """The ground model and its parameters (robot key ``ground``, e.g.
    ``{"model": "anisotropic", "lateral_ratio": 0.6}``); unset parameters take their defaults.

    Attributes:
        model: one of :data:`GROUND_MODELS`.
        params: (name, value) pairs, sorted, every parameter of the model (hashable).
    """

    model: str = "coulomb"
    params: tuple[tuple[str, float], ...] = ()

    def __post_init__(self) -> None:
        if self.model not in GROUND_MODELS:
            raise InputError(f"robot: 'ground' model must be one of {sorted(GROUND_MODELS)}, got {self.model!r}")
        spec = GROUND_MODELS[self.model]
        given = dict(self.params)
        for name in given:
            if name not in spec:
                raise InputError(f"robot: ground model {self.model!r} has no parameter {name!r} "
                                 f"(parameters: {sorted(spec) or 'none'})")
        full = []
        for name, (default, lo, hi) in sorted(spec.items()):
            value = given.get(name, default)
            if not _is_finite_number(value) or not lo <= value <= hi:
                raise InputError(f"robot: ground parameter {name!r} must be a number in [{lo}, {hi}], got {value!r}")
            if name == "wheels" and value != int(value):
                raise InputError(f"robot: ground parameter 'wheels' must be a whole number, got {value!r}")
            full.append((name, float(value)))
        object.__setattr__(self, "params", tuple(full))

    def __getitem__(self, name: str) -> float:
        return dict(self.params)[name]

    @property
    def is_default(self) -> bool:
        """True for the rigid-track isotropic Coulomb ground."""
        return self.model == "coulomb"

    def to_dict(self) -> dict[str, Any]:
        return {"model": self.model, **dict(self.params)}

    def load_shares(self, x, track_length: float):
        """w (n,): the point at ``x[i]`` (evenly spaced along a track, ascending) carries w_i / n of
        the track's static load (sum w = n); all ones unless the model is ``road_wheels``: then
        w_i = (1 - c) + c n a_i, a_i the part of the ``wheels`` equal wheel loads at
        X_j = span (-L/2 + (j + 1/2) L / wheels) that falls on point i by linear interpolation
        (a hat function on the grid: each wheel's load and moment are kept). The MuJoCo robot's
        roller springs (:func:`mjtrack.sim.ground.load_shares`) and the Coulomb reference's
        contact loads (:mod:`mjtrack.models.coulomb`) both use it."""
        import numpy as np

        xr = np.asarray(x, dtype=float)
        n = xr.size
        if self.model != "road_wheels":
            return np.ones(n)
        nw, c, span = int(self["wheels"]), self["concentration"], self["span"]
        L = float(track_length)
        a = np.zeros(n)
        for X in span * (-L / 2 + (np.arange(nw) + 0.5) * L / nw):
            f = np.clip((X - xr[0]) / (xr[1] - xr[0]), 0.0, n - 1.0)
            i = min(int(math.floor(f)), n - 2)
            a[i] += (i + 1 - f) / nw
            a[i + 1] += (f - i) / nw
        return (1.0 - c) + c * n * a

    @classmethod
    def from_value(cls, value: Any, *, source: str = "robot description") -> "Ground":
        """From a description's ``ground`` value: a model name or ``{"model": NAME, PARAM: value}``."""
        if isinstance(value, Ground):
            return value
        if isinstance(value, str):
            value = {"model": value}
        if not isinstance(value, dict):
            raise InputError(f"{source}: key 'ground' must be an object like {{\"model\": \"coulomb\"}}, got {value!r}")
        params = {k: v for k, v in value.items() if k != "model"}
        try:
            return cls(model=value.get("model", "coulomb"), params=tuple(params.items()))
        except InputError as exc:
            raise InputError(f"{source}: {str(exc).removeprefix('robot: ')}") from None


@dataclass(frozen=True)
class Robot:
    """Geometry, mass and friction of a skid-steer robot on two tracks or on wheels.

    Frame: x forward, y left, z up, origin at the geometric centre of the two track
    contact patches (or of the wheels' contact points) on the ground plane.

    A wheeled robot (``traction="wheels"``) reads the track fields as its wheels' (gauge, wheel
    radius, tyre width): docs/guide/wheeled.md; every key: docs/reference/formats/robot-file.md.

    Attributes:
        track_gauge: T, distance between the track (wheel) centre lines [m].
        track_length: L, length of each track's ground contact [m] (tracks only).
        track_width: width of each track's ground contact (of each tyre) [m].
        sprocket_radius: radius from sprocket (wheel) speed to track (wheel surface) speed [m].
        mass: total mass [kg].
        cg_x: centre of mass ahead (+) of the geometric centre [m]; abs(cg_x) < contact length / 2.
        cg_y: centre of mass left (+) of the geometric centre [m]; abs(cg_y) < track_gauge / 2.
        cg_z: height of the centre of mass above the ground (the plane the tracks or wheels rest on,
            which holds the frame's origin) [m]; 0 < cg_z <= :attr:`max_cg_z`.
        mu, mu_left, mu_right: ground friction coefficient; per track, ``None`` meaning ``mu`` [-].
        drive_lag: first-order time constant from track command to track speed [s] (0: none).
        drive_delay: dead time from track command to track speed [s].
        drive_force_limit: traction force limit of one track drive [N]; ``None``: the simulator's
            default, which scales with the mass (:meth:`mjtrack.sim.config.SimConfig.for_robot_mass`).
        drive_speed_limit: track speed [m/s] at which the robot's own speed controller saturates a
            side's set-point (the command after scale and dead time); ``None``: no limit.
        drive_speed_limit_left, drive_speed_limit_right: per side; ``None``: ``drive_speed_limit``.
        drive_lag_left, drive_lag_right, drive_delay_left, drive_delay_right: per side [s];
            ``None``: ``drive_lag`` / ``drive_delay``.
        drive_accel_limit: largest rate of change of a side's set-point [m/s^2] (the controller's
            ramp); ``None``: no limit. The chain: :mod:`mjtrack.models.drivetrain`.
        drive_turn_scale: a twist controller's half difference of the two sides' set-points over
            the (scaled) commanded one [-] (1: none; an effective track separation other than the gauge).
        drive_mean_speed_limit, drive_turn_limit: a twist controller's limits on the mean and the
            half difference of the two sides' set-points [m/s] (its linear speed limit, its angular
            speed limit times half the gauge); ``None``: none.
        drive_mean_accel_limit, drive_turn_accel_limit: a twist controller's ramps: the largest
            rate of change of the mean and of the half difference of the two sides' set-points
            [m/s^2] (its linear acceleration limit, its angular one times half the gauge), applied
            before the split into sides; ``None``: none.
        track_speed_scale: actual / commanded track speed, both tracks [-].
        rolling_resistance: motion resistance coefficient f_r [-]: each side is held back by a
            force f_r times the weight it carries, opposing its motion over the ground (rolling,
            bulldozing and tread losses); 0: none (docs/theory/simulator.md).
        ground: the ground model and its parameters (:class:`Ground`, a dict or a model name;
            default isotropic Coulomb).
        traction: ``"tracks"`` (default) or ``"wheels"``.
        wheelbase: B, front to rear axle [m] (wheels only; default the track gauge).
        wheels_per_side: wheels on each side, axles evenly spaced over the wheelbase [-].
        extra: project-specific keys read from a description file, kept for round trips.
        provided: the keys a description file gave (the others took their defaults), or None
            for a robot built in code; diagnosis tells known from assumed geometry by it.
    """

    track_gauge: float = 0.4
    track_length: float = 0.5
    track_width: float = 0.08
    sprocket_radius: float = 0.06
    mass: float = 20.0
    cg_x: float = 0.0
    cg_y: float = 0.0
    cg_z: float = 0.12
    mu: float = 0.8
    mu_left: float | None = None
    mu_right: float | None = None
    drive_lag: float = 0.0
    drive_delay: float = 0.0
    drive_force_limit: float | None = None
    track_speed_scale: float = 1.0
    rolling_resistance: float = 0.0
    drive_speed_limit: float | None = None
    drive_speed_limit_left: float | None = None
    drive_speed_limit_right: float | None = None
    drive_lag_left: float | None = None
    drive_lag_right: float | None = None
    drive_delay_left: float | None = None
    drive_delay_right: float | None = None
    drive_accel_limit: float | None = None
    drive_turn_scale: float = 1.0
    drive_mean_speed_limit: float | None = None
    drive_turn_limit: float | None = None
    drive_mean_accel_limit: float | None = None
    drive_turn_accel_limit: float | None = None
    ground: Ground = field(default_factory=Ground)
    traction: str = "tracks"
    wheelbase: float | None = None
    wheels_per_side: int = 2
    extra: dict[str, Any] = field(default_factory=dict, compare=False)
    provided: frozenset[str] | None = field(default=None, compare=False, repr=False)

    def __post_init__(self) -> None:
        if not isinstance(self.ground, Ground):
            object.__setattr__(self, "ground", Ground.from_value(self.ground, source="robot"))
        for name in ("track_gauge", "track_length", "track_width", "sprocket_radius", "mass", "mu"):
            value = getattr(self, name)
            if not _is_finite_number(value) or value <= 0:
                raise InputError(f"robot: '{name}' must be a positive number, got {value!r}")
        self._check_traction()
        for name in ("cg_x", "cg_y", "cg_z"):
            value = getattr(self, name)
            if not _is_finite_number(value):
                raise InputError(f"robot: '{name}' must be a finite number, got {value!r}")
        if self.cg_z <= 0:
            raise InputError(f"robot: 'cg_z' = {self.cg_z:g} m puts the centre of mass at or below the ground "
                             "('cg_z' is its height above the ground, > 0)")
        for name in ("mu_left", "mu_right"):
            value = getattr(self, name)
            if value is not None and (not _is_finite_number(value) or value <= 0):
                raise InputError(f"robot: '{name}' must be a positive number or null, got {value!r}")
        for name, upper in (("drive_lag", MAX_DRIVE_TIME), ("drive_delay", MAX_DRIVE_TIME)):
            value = getattr(self, name)
            if not _is_finite_number(value) or not 0 <= value <= upper:
                raise InputError(f"robot: '{name}' must be a number in [0, {upper:g}] s, got {value!r}")
        if self.drive_force_limit is not None and (
                not _is_finite_number(self.drive_force_limit) or self.drive_force_limit <= 0):
            raise InputError(f"robot: 'drive_force_limit' must be a positive number (N per track) or null, "
                             f"got {self.drive_force_limit!r}")
        if not _is_finite_number(self.track_speed_scale) or not 0 < self.track_speed_scale <= MAX_SPEED_SCALE:
            raise InputError(f"robot: 'track_speed_scale' must be a number in (0, {MAX_SPEED_SCALE:g}], "
                             f"got {self.track_speed_scale!r}")
        if not _is_finite_number(self.rolling_resistance) or not 0 <= self.rolling_resistance <= MAX_RESISTANCE:
            raise InputError(f"robot: 'rolling_resistance' must be a number in [0, {MAX_RESISTANCE:g}] (a share of "
                             f"the weight), got {self.rolling_resistance!r}")
        self._check_drive_sides()
        for name, (low, high, unit) in PLAUSIBLE_ROBOT.items():
            value = getattr(self, name)
            if value is not None and not low <= value <= high:
                raise InputError(f"robot: '{name}' = {value:g} {unit} is beyond physical plausibility "
                                 f"(between {low:g} and {high:g} {unit})")
        if self.track_width >= self.track_gauge:
            raise InputError(f"robot: 'track_width' = {self.track_width} is not less than 'track_gauge' = "
                             f"{self.track_gauge}: the two tracks would overlap")
        if abs(self.cg_x) >= self.contact_length / 2:
            length = "track_length" if self.traction == "tracks" else "wheelbase"
            raise InputError(
                f"robot: 'cg_x' = {self.cg_x} puts the centre of mass outside the {self.traction} "
                f"(|cg_x| must be < {length}/2 = {self.contact_length / 2})"
            )
        if abs(self.cg_y) >= self.track_gauge / 2:
            raise InputError(
                f"robot: 'cg_y' = {self.cg_y} puts the centre of mass outside the tracks "
                f"(|cg_y| must be < track_gauge/2 = {self.track_gauge / 2})"
            )
        if self.cg_z > self.max_cg_z:
            length = "track_length" if self.traction == "tracks" else "wheelbase"
            raise InputError(
                f"robot: 'cg_z' = {self.cg_z:g} m is beyond physical plausibility: the centre of mass at most "
                f"{MAX_CG_HEIGHT_RATIO:g} x max(track_gauge, {length}) = {self.max_cg_z:g} m above the ground "
                "(higher, the robot would tip over in a gentle turn)"
            )

    def _check_drive_sides(self) -> None:
        """The per-side and limit drivetrain keys: null, or a number in their range."""
        checks = [(n, 0.0, MAX_DRIVE_TIME, "s", True) for n in DRIVE_SIDE_KEYS if n.startswith(("drive_lag", "drive_delay"))]
        checks += [(n, 0.0, MAX_DRIVE_SPEED, "m/s", False) for n in DRIVE_SIDE_KEYS
                   if n.startswith("drive_speed_limit") or n in ("drive_mean_speed_limit", "drive_turn_limit")]
        checks += [(n, 0.0, MAX_DRIVE_ACCEL, "m/s^2", False)
                   for n in ("drive_accel_limit", "drive_mean_accel_limit", "drive_turn_accel_limit")]
        if not _is_finite_number(self.drive_turn_scale) or not 0 < self.drive_turn_scale <= MAX_SPEED_SCALE:
            raise InputError(f"robot: 'drive_turn_scale' must be a number in (0, {MAX_SPEED_SCALE:g}], "
                             f"got {self.drive_turn_scale!r}")
        for name, low, high, unit, closed in checks:
            value = getattr(self, name)
            if value is None:
                continue
            if not _is_finite_number(value) or not (low <= value if closed else low < value) or value > high:
                bracket = "[" if closed else "("
                raise InputError(f"robot: '{name}' must be a number in {bracket}{low:g}, {high:g}] {unit} or null, "
                                 f"got {value!r}")

    @property
    def lag_per_side(self) -> tuple[float, float]:
        """First-order time constant of the (left, right) drive [s]."""
        return tuple(self.drive_lag if v is None else v for v in (self.drive_lag_left, self.drive_lag_right))

    @property
    def delay_per_side(self) -> tuple[float, float]:
        """Dead time of the (left, right) drive [s]."""
        return tuple(self.drive_delay if v is None else v for v in (self.drive_delay_left, self.drive_delay_right))

    @property
    def speed_limit_per_side(self) -> tuple[float | None, float | None]:
        """Speed-controller saturation of the (left, right) set-point [m/s]; None: none."""
        return tuple(self.drive_speed_limit if v is None else v
                     for v in (self.drive_speed_limit_left, self.drive_speed_limit_right))

    def _check_traction(self) -> None:
        """The wheeled keys: a known traction, an integer wheel count, a plausible wheelbase."""
        if self.traction not in TRACTIONS:
            raise InputError(f"robot: 'traction' must be one of {list(TRACTIONS)}, got {self.traction!r}")
        n = self.wheels_per_side
        if not _is_finite_number(n) or n != int(n) or not 2 <= n <= MAX_WHEELS_PER_SIDE:
            raise InputError(f"robot: 'wheels_per_side' must be a whole number from 2 to {MAX_WHEELS_PER_SIDE}, "
                             f"got {n!r}")
        object.__setattr__(self, "wheels_per_side", int(n))
        if self.wheelbase is not None and (not _is_finite_number(self.wheelbase) or self.wheelbase <= 0):
            raise InputError(f"robot: 'wheelbase' must be a positive number or null, got {self.wheelbase!r}")
        if self.traction == "tracks":
            if self.wheelbase is not None or self.wheels_per_side != 2:
                raise InputError("robot: 'wheelbase' and 'wheels_per_side' describe a wheeled robot; "
                                 "set 'traction' to \"wheels\"")
        elif self.wheelbase is None:  # a square footprint: B = T
            object.__setattr__(self, "wheelbase", float(self.track_gauge))
        if self.traction == "wheels" and self.ground.model == "road_wheels":
            raise InputError("robot: ground model 'road_wheels' spreads a track's load over its road wheels; "
                             "a wheeled robot carries its load at its axles (use 'coulomb' or 'anisotropic')")

    # -- derived quantities -------------------------------------------------------------
    @property
    def wheel_radius(self) -> float:
        """Wheel radius [m] of a wheeled robot: :attr:`sprocket_radius` (the same conversion from
        wheel speed to surface speed)."""
        return self.sprocket_radius

    @property
    def max_cg_z(self) -> float:
        """Largest accepted ``cg_z`` [m]: :data:`MAX_CG_HEIGHT_RATIO` times the footprint's larger
        side, max(track_gauge, :attr:`contact_length`)."""
        return MAX_CG_HEIGHT_RATIO * max(self.track_gauge, self.contact_length)

    @property
    def contact_length(self) -> float:
        """Length of a side's ground contact along x [m]: ``track_length`` on tracks; on wheels
        the distance from the front to the rear contact point, ``wheelbase``."""
        return self.track_length if self.traction == "tracks" else float(self.wheelbase)

    def axle_positions(self):
        """x of the wheel axles of a wheeled robot, front last, (wheels_per_side,) [m]: evenly
        spaced from -B/2 to B/2 (B = :attr:`contact_length`). InputError on tracks."""
        import numpy as np

        if self.traction != "wheels":
            raise InputError("robot: a tracked robot has no axles (traction is 'tracks')")
        return np.linspace(-self.contact_length / 2, self.contact_length / 2, self.wheels_per_side)

    @property
    def friction_left(self) -> float:
        """Friction coefficient of the left track [-]."""
        return self.mu if self.mu_left is None else self.mu_left

    @property
    def friction_right(self) -> float:
        """Friction coefficient of the right track [-]."""
        return self.mu if self.mu_right is None else self.mu_right

    @property
    def weight(self) -> float:
        """m g [N]."""
        return self.mass * G

    def replace(self, **changes: Any) -> "Robot":
        """A copy with some fields changed (validated again); changed fields count as provided."""
        provided = None if self.provided is None else self.provided | frozenset(changes)
        return dataclasses.replace(self, **changes, provided=provided)

    # -- serialisation --------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """The full description: every field; the wheeled keys (and ``wheel_radius``, the alias
        of ``sprocket_radius``) only for a wheeled robot, so that tracked descriptions keep their keys."""
        skip = ("extra", "provided") + (WHEEL_KEYS if self.traction == "tracks" else ())
        skip += tuple(k for k in DRIVE_SIDE_KEYS if getattr(self, k) is None)  # unset: descriptions keep their keys
        skip += ("drive_turn_scale",) if self.drive_turn_scale == 1.0 else ()
        d = {f.name: getattr(self, f.name) for f in dataclasses.fields(self) if f.name not in skip}
        d["ground"] = self.ground.to_dict()
        if self.traction == "wheels":
            d["wheel_radius"] = self.wheel_radius
        return {**self.extra, **d}

    @classmethod
    def from_dict(cls, data: dict[str, Any], *, source: str = "robot description") -> "Robot":
        if not isinstance(data, dict):
            raise InputError(f"{source}: expected a JSON object, got {type(data).__name__}")
        data = _wheel_radius_alias(data, source)
        names = {f.name for f in dataclasses.fields(cls)} - {"extra", "provided"}
        known = {k: v for k, v in data.items() if k in names}
        extra = {k: v for k, v in data.items() if k not in names}
        _check_extra_keys(extra, names, source)
        if "track_gauge" not in data:
            raise InputError(f"{source}: missing required key 'track_gauge'")
        for k, v in known.items():
            if k == "ground":
                known[k] = Ground.from_value(v, source=source)
                continue
            if k == "traction":
                if v not in TRACTIONS:
                    raise InputError(f"{source}: key 'traction' must be one of {list(TRACTIONS)}, got {v!r}")
                continue
            if v is None and (k in NULLABLE or k in DRIVE_SIDE_KEYS):
                continue
            if not _is_finite_number(v):
                raise InputError(f"{source}: key '{k}' must be a number, got {v!r}")
            known[k] = float(v)
        try:
            return cls(**known, extra=extra, provided=frozenset(known))
        except InputError as exc:
            raise InputError(f"{source}: {str(exc).removeprefix('robot: ')}") from None


def _check_extra_keys(extra: dict[str, Any], names: set[str], source: str) -> None:
    """Refuse a key that looks like a misspelt known key; warn once about the other unknown keys."""
    targets = sorted(names | {WHEEL_RADIUS} | set(RECORD_KEYS))
    lowered = {t.lower(): t for t in targets}
    unknown = []
    for key in extra:
        if key in targets or str(key).startswith(SOURCE_PREFIX):
            continue
        close = difflib.get_close_matches(str(key).lower(), list(lowered), n=1, cutoff=TYPO_CUTOFF)
        if close:
            raise InputError(f"{source}: key {key!r}: did you mean {lowered[close[0]]!r}? (a misspelt key would "
                             "be ignored)")
        meant = _quantity_key(str(key), names)
        if meant is not None:
            default = next((f.default for f in dataclasses.fields(Robot) if f.name == meant), None)
            unused = f"; unknown keys are not used, so the robot would keep the default {meant} = {default}" \
                if isinstance(default, (int, float)) else ""
            raise InputError(f"{source}: key {key!r} looks like the robot's {meant}: did you mean {meant!r} "
                             f"(in SI units{unused})?")
        unknown.append(str(key))
    if unknown and (source, tuple(unknown)) not in _warned:
        _warned.add((source, tuple(unknown)))
        logger.warning("%s: key(s) %s not used by mjtrack; kept in the description", source, ", ".join(unknown))


def _quantity_key(key: str, names: set[str]) -> str | None:
    """The known key an unknown ``key`` names under another name (:data:`QUANTITY_KEYS`), or with a
    unit suffix (``mass_kg``, ``track_gauge_mm``); None when it names none."""
    lowered = key.lower().replace("-", "_").replace(" ", "_")
    if lowered in QUANTITY_KEYS:
        return QUANTITY_KEYS[lowered]
    for suffix in UNIT_SUFFIXES:
        stem = lowered.removesuffix(suffix)
        if stem != lowered and (stem in names or stem == WHEEL_RADIUS):
            return stem
        if stem != lowered and stem in QUANTITY_KEYS:
            return QUANTITY_KEYS[stem]
    return None


def _wheel_radius_alias(data: dict[str, Any], source: str) -> dict[str, Any]:
    """``wheel_radius`` read as ``sprocket_radius`` (its alias); both given must agree."""
    if "wheel_radius" not in data:
        return data
    out = {k: v for k, v in data.items() if k != "wheel_radius"}
    radius = data["wheel_radius"]
    if "sprocket_radius" in data and data["sprocket_radius"] != radius:
        raise InputError(f"{source}: 'wheel_radius' = {radius!r} and its alias 'sprocket_radius' = "
                         f"{data['sprocket_radius']!r} differ; give one of them")
    out["sprocket_radius"] = radius
    return out


def _is_finite_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def read_robot(path: str | os.PathLike) -> Robot:
    """Read a robot description JSON file; bad input raises :class:`InputError`."""
    path = Path(path)
    data = read_json(path, what="robot description", max_bytes=MAX_FILE_BYTES, max_depth=MAX_DEPTH)
    return Robot.from_dict(data, source=str(path))


def write_robot(robot: Robot, path: str | os.PathLike) -> None:
    """Write the full description atomically (temp file renamed at the end)."""
    from mjtrack.io.atomic import atomic_write_text

    atomic_write_text(path, json.dumps(robot.to_dict(), indent=2, sort_keys=True) + "\n")


#: keys on which the description of a test log must agree with the robot of the training log, which
#: calibration and diagnosis use for both logs: the running gear, the mass and its centre, and the
#: friction (neither can give the test log's robot its own). A key the test log's description does
#: not give is not compared (it relies on the default: it says nothing).
SAME_ROBOT_KEYS = ("traction", "track_gauge", "track_length", "track_width", "sprocket_radius", "wheelbase",
                   "wheels_per_side", "mass", "cg_x", "cg_y", "cg_z", "mu", "mu_left", "mu_right")
#: relative tolerance of that agreement: far above the round-off of a unit conversion or of a
#: value printed with 7 digits, far below any difference between two robots (a millimetre on a metre)
SAME_ROBOT_REL = 1e-6


def check_same_robot(robot: Robot, other: Robot, where: str) -> None:
    """Refuse ``other`` (the description given with a test log, ``where`` its file) when it
    states, on a key of :data:`SAME_ROBOT_KEYS`, another value than ``robot`` (the training log's
    robot as it is used, defaults included): InputError naming each key and both values."""
    differ = []
    for k in SAME_ROBOT_KEYS:
        if other.provided is not None and k not in other.provided:
            continue
        if k in ("mu_left", "mu_right"):  # null: the same as mu
            a, b = (r.friction_left if k == "mu_left" else r.friction_right for r in (robot, other))
        else:
            a, b = getattr(robot, k), getattr(other, k)
        numbers = _is_finite_number(a) and _is_finite_number(b)
        if not (a == b or numbers and math.isclose(a, b, rel_tol=SAME_ROBOT_REL, abs_tol=1e-12)):
            differ.append(f"{k} {_shown(b)} in its description, {_shown(a)} for the training log")
    if differ:
        raise InputError(f"{where}: recorded with another robot ({'; '.join(differ)}): a test log must come "
                         "from the robot of the training log")


def _shown(value: Any) -> str:
    return "null" if value is None else f"{value:g}" if _is_finite_number(value) else str(value)

