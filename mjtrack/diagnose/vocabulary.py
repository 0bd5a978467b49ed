"""The effect vocabulary: names, parameters, kinds and meanings (docs/reference/formats/diagnosis-json.md).

Data only: what an effect changes in a model is each baseline's own (``Baseline.vocabulary``; the
surrogate's in :mod:`mjtrack.diagnose.surrogate`, the MuJoCo robot's in
:mod:`mjtrack.diagnose.mujoco_baseline`), and so is how it is fitted.

Two kinds: ``input`` effects act between the command and the track speed, ``ground`` effects
change the robot or its world.

One name per physical quantity across the robot file, calibration.json, diagnosis.json and the
API: an effect whose quantity has a robot-file key or a calibration parameter takes that name,
for the effect and its parameter alike. The names :data:`RENAMED` were diagnose's own until 0.3;
they are still read (effects to test, older diagnosis.json) with a :class:`DeprecationWarning`,
for one release.

The slope is one quantity with two spellings in the past: diagnose's angle and uphill direction
(``slope``, ``slope_direction``) and calibration's components ``slope_x``, ``slope_y`` (sin(angle)
x the uphill unit vector, world frame). The components are kept: they are defined at zero slope,
where a direction is not, so a fit and its interval behave there. The effect keeps its name
``slope``; diagnosis.json gives the angle and direction beside the estimate
(:func:`slope_angle`), under ``derived``, so that the contract's ``slope`` stays readable.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

from mjtrack.errors import InputError

@dataclass(frozen=True)
class Effect:
    """One effect of the vocabulary: its name, parameter names, kind ("input" or "ground"), what
    it means and the signature it leaves in prediction errors."""

    name: str
    params: tuple[str, ...]
    kind: str
    meaning: str
    signature: str


EFFECTS: dict[str, Effect] = {e.name: e for e in (
    Effect("track_speed_scale", ("track_speed_scale",), "input",
           "actual / commanded track speed, both tracks",
           "speed and yaw rate both scaled: along-track error grows with speed, turn shape unchanged"),
    Effect("drive_lag", ("drive_lag",), "input",
           "first-order time constant from command to track speed [s]",
           "errors right after command changes, the model leads the measurement"),
    Effect("drive_delay", ("drive_delay",), "input",
           "dead time from command to track speed [s]",
           "errors right after command changes, the measurement follows the model shifted in time"),
    Effect("drive_speed_limit", ("drive_speed_limit",), "input",
           "track speeds saturate at this magnitude [m/s]",
           "errors only at high commanded speeds, the model too fast"),
    Effect("drive_turn_limit", ("drive_turn_limit",), "input",
           "the half difference of the two sides' set-points (V_R - V_L)/2 saturates at this magnitude [m/s], "
           "the mean kept (a velocity controller's twist limit, common on wheeled skid-steer robots; the "
           "commanded yaw rate limited to 2 x limit / T)",
           "errors only in sharp turns and spins, the model turns too fast; straight driving exact"),
    Effect("drive_accel_limit", ("drive_accel_limit",), "input",
           "each side's set-point moves towards the command at most this fast [m/s^2] (the controller's ramp)",
           "errors after large command changes, growing with the change (a ramp takes change / limit), "
           "the model leads the measurement; steady driving exact"),
    Effect("drive_force_limit", ("drive_force_limit",), "input",
           "each side's drive delivers at most this traction force [N] (a motor's torque limit)",
           "the tracks fall behind their commands where the ground asks for more force: fast "
           "accelerations and skid turns slower than modelled, like a lower friction in turns"),
    Effect("cg_x", ("cg_x",), "ground",
           "centre of mass ahead (+) / behind (-) the geometric centre [m]",
           "the no-slip line x_c moves with the centre of mass: the robot slides to the outside (cg ahead) "
           "of its turns, the same x_c for both turn directions"),
    Effect("cg_y", ("cg_y",), "ground",
           "centre of mass left (+) / right (-) [m]",
           "the loaded track slips less: turning asymmetric (y_l, y_r shift together)"),
    Effect("friction_scale", ("friction_scale",), "ground",
           "ground friction / nominal",
           "changes the skid only through the centripetal (inertial) response: visible in fast turns only"),
    Effect("mu_ratio", ("mu_ratio",), "ground",
           "left-track friction / right-track friction, the right track keeping the nominal mu",
           "the grippier track slips less: turning asymmetric (y_l, y_r shift together)"),
    Effect("slope", ("slope_x", "slope_y"), "ground",
           "inclined ground: sin(slope angle) x the uphill unit vector, world (log) frame x and y [-]",
           "a drift whose direction in the robot frame turns with the yaw: errors depend on the heading"),
    Effect("icr_spread", ("icr_spread",), "ground",
           "track ICR spread / modelled (effective gauge factor): more (>1) or less (<1) skid in turns",
           "yaw rate off by the same factor in all turns, straight driving exact"),
    Effect("ground_anisotropy", ("lateral_ratio",), "ground",
           "anisotropic ground: lateral / longitudinal friction of the track contact",
           "turns skid less than the isotropic contact predicts (less lateral resistance), straight driving "
           "exact"),
    Effect("road_wheels", ("span",), "ground",
           "95 % of the load on 4 road wheels spread over this share of the contact length",
           "the load concentrates under the wheels: turning resistance as of a shorter contact"),
    Effect("track_length", ("track_length",), "ground",
           "length of each track's ground contact [m]",
           "turns skid more (longer contact) or less (shorter) than modelled: the yaw ratio off in every "
           "turn, straight driving exact"),
    Effect("wheelbase", ("wheelbase",), "ground",
           "front to rear axle distance of a wheeled robot [m]",
           "turns skid more (longer contact) or less (shorter) than modelled: the yaw ratio off in every "
           "turn, straight driving exact"),
    Effect("rolling_resistance", ("rolling_resistance",), "ground",
           "motion resistance: each side held back by this share of its weight [-]",
           "the body lags its tracks in every motion, more on the loaded side: speed ratio below one even "
           "straight, turns slowed"),
    Effect("shear_modulus", ("shear_modulus",), "ground",
           "shear modulus K of the ground [m]: friction builds up as mu (1 - exp(-j/K)) with the shear "
           "displacement j of each contact (Janosi-Hanamoto); 0 is Coulomb",
           "the yaw ratio depends on the turn: Coulomb's is nearly the same in every turn, the log's changes "
           "from gentle to sharp turns"),
    Effect("lateral_shear_ratio", ("lateral_shear_ratio",), "ground",
           "the shear ground's modulus across the track or tyre over the one along it [-]; 1 is isotropic",
           "on a shear ground, the robot turns more easily (ratio above 1) or less than its forward grip "
           "implies, most in gentle turns"),
)}

#: old effect / parameter name -> the name it has now
RENAMED: dict[str, str] = {
    "cg_offset_x": "cg_x",
    "cg_offset_y": "cg_y",
    "friction_asymmetry": "mu_ratio",
    "actuator_lag": "drive_lag",
    "command_delay": "drive_delay",
    "speed_limit": "drive_speed_limit",
    "yaw_rate_limit": "drive_turn_limit",  # [rad/s] -> [m/s]: times T / 2 (:data:`RESCALED`)
}
#: old names whose parameter was in other units: old name -> (new name, the robot key whose value,
#: halved, multiplies the old value): a yaw-rate limit (V_R - V_L) / T [rad/s] is the half-difference
#: limit (V_R - V_L) / 2 = yaw_rate_limit x T / 2 [m/s]
RESCALED: dict[str, tuple[str, str]] = {"yaw_rate_limit": ("drive_turn_limit", "track_gauge")}
#: old parameter names of effects that kept their name
RENAMED_PARAMS: dict[str, str] = {"road_wheel_span": "span"}


def canonical_effects(names, known, *, traction: str = "tracks") -> list[str]:
    """Effect names (e.g. what to test) in today's vocabulary: an old name is replaced, with a
    :class:`DeprecationWarning` (``contact_length`` by the robot key of the robot's ``traction``:
    ``track_length`` or ``wheelbase``); a name that is neither raises :class:`InputError`."""
    names = list(names)
    renamed = {**RENAMED, "contact_length": "wheelbase" if traction == "wheels" else "track_length"}
    old = [n for n in names if n in renamed]
    if old:
        warnings.warn(f"effect names: {', '.join(f'{o} is now {renamed[o]}' for o in old)} (the old names are "
                      "read until the next release)", DeprecationWarning, stacklevel=2)
    out = [renamed.get(n, n) for n in names]
    unknown = [n for n in out if n not in known]
    if unknown:
        raise InputError(f"diagnose: unknown effect(s) {', '.join(unknown)} (known: {', '.join(known)})")
    return out


def slope_angle(slope_x: float, slope_y: float) -> dict[str, float]:
    """The incline of slope components: ``slope`` [rad] (angle) and ``slope_direction`` [rad,
    world frame, uphill; 0 when flat]."""
    return {"slope": math.asin(min(1.0, math.hypot(slope_x, slope_y))),
            "slope_direction": math.atan2(slope_y, slope_x)}


def _upgrade_params(effect: str, values: dict, factors: dict) -> dict:
    if effect == "slope" and "slope_direction" in values and "slope_x" not in values:
        s, d = values["slope"], values["slope_direction"]
        if isinstance(s, (list, tuple)):  # an interval: its components are not known, only the estimate's
            return {}
        return {"slope_x": math.sin(s) * math.cos(d), "slope_y": math.sin(s) * math.sin(d)}
    return {RENAMED.get(k, RENAMED_PARAMS.get(k, k)): _rescaled(v, factors.get(k)) for k, v in values.items()}


def _rescaled(v, factor: float | None):
    if factor is None or v is None:
        return v
    if isinstance(v, (list, tuple)):
        return [None if x is None else x * factor for x in v]
    return v * factor


def upgrade_diagnosis(data: dict, *, robot=None) -> dict:
    """A diagnosis.json written before the renames, in today's names (a new copy; a current one is
    returned unchanged). Warns (:class:`DeprecationWarning`) when it renamed anything. A parameter
    whose units changed with its name (:data:`RESCALED`) is converted with ``robot``'s value of the
    key that relates them; without ``robot`` such a file raises :class:`InputError`."""
    old = sorted({n for n in _names_in(data) if n in RENAMED or n in RENAMED_PARAMS or n == "slope_direction"})
    if not old:
        return data
    factors = {}
    for name in (n for n in old if n in RESCALED):
        new, key = RESCALED[name]
        if robot is None:
            raise InputError(f"diagnosis.json: {name} is now {new} in other units; give the robot (its {key}) "
                             "to read it")
        factors[name] = float(getattr(robot, key)) / 2
    warnings.warn(f"diagnosis.json written with older effect names ({', '.join(old)}): read in today's names",
                  DeprecationWarning, stacklevel=2)
    out = dict(data)
    if "cause" in out:
        out["cause"] = RENAMED.get(out["cause"], out["cause"])
    for key in ("findings", "candidates"):
        if key in out:
            out[key] = [_upgrade_entry(f, factors) for f in out[key]]
    if "steps" in out:
        out["steps"] = [{**s, "added": RENAMED.get(s.get("added"), s.get("added")),
                         "on_top_of": [RENAMED.get(n, n) for n in s.get("on_top_of", [])],
                         "candidates": [_upgrade_entry(c, factors) for c in s.get("candidates", [])]} for s in out["steps"]]
    if "not_tested" in out:
        out["not_tested"] = {RENAMED.get(k, k): v for k, v in out["not_tested"].items()}
    return out


def _upgrade_entry(f: dict, factors: dict) -> dict:
    f = dict(f)
    name = f.get("effect")
    f["effect"] = RENAMED.get(name, name)
    if name == "slope" and "slope_direction" in f.get("estimate", {}):
        f["derived"] = dict(f["estimate"])
    for key in ("estimate", "interval"):
        if key in f:
            f[key] = _upgrade_params(name, f[key], factors)
    for key in ("tied_with", "on_top_of"):
        if key in f:
            f[key] = [RENAMED.get(n, n) for n in f[key]]
    return f


def _names_in(data: dict) -> set[str]:
    names = {data.get("cause")}
    for f in list(data.get("findings", [])) + list(data.get("candidates", [])):
        names.add(f.get("effect"))
        names.update(f.get("estimate", {}))
    return {n for n in names if isinstance(n, str)}


__all__ = ["EFFECTS", "Effect", "RENAMED", "RENAMED_PARAMS", "RESCALED", "canonical_effects", "slope_angle", "upgrade_diagnosis"]
