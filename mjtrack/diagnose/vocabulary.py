"""Names of the effect vocabulary and the names they replaced.

One name per physical quantity across the robot file, calibration.json, diagnosis.json and the
API: an effect whose quantity has a robot-file key or a calibration parameter takes that name,
for the effect and its parameter alike. The names below were diagnose's own until 0.3; they are
still read (effects to test, older diagnosis.json) with a :class:`DeprecationWarning`, for one
release.

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

from mjtrack.errors import InputError

#: old effect / parameter name -> the name it has now
RENAMED: dict[str, str] = {
    "cg_offset_x": "cg_x",
    "cg_offset_y": "cg_y",
    "friction_asymmetry": "mu_ratio",
    "actuator_lag": "drive_lag",
    "command_delay": "drive_delay",
    "speed_limit": "drive_speed_limit",
}
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


def _upgrade_params(effect: str, values: dict) -> dict:
    if effect == "slope" and "slope_direction" in values and "slope_x" not in values:
        s, d = values["slope"], values["slope_direction"]
        if isinstance(s, (list, tuple)):  # an interval: its components are not known, only the estimate's
            return {}
        return {"slope_x": math.sin(s) * math.cos(d), "slope_y": math.sin(s) * math.sin(d)}
    return {RENAMED.get(k, RENAMED_PARAMS.get(k, k)): v for k, v in values.items()}


def upgrade_diagnosis(data: dict) -> dict:
    """A diagnosis.json written before the renames, in today's names (a new copy; a current one is
    returned unchanged). Warns (:class:`DeprecationWarning`) when it renamed anything."""
    old = sorted({n for n in _names_in(data) if n in RENAMED or n in RENAMED_PARAMS or n == "slope_direction"})
    if not old:
        return data
    warnings.warn(f"diagnosis.json written with older effect names ({', '.join(old)}): read in today's names",
                  DeprecationWarning, stacklevel=2)
    out = dict(data)
    if "cause" in out:
        out["cause"] = RENAMED.get(out["cause"], out["cause"])
    for key in ("findings", "candidates"):
        if key in out:
            out[key] = [_upgrade_entry(f) for f in out[key]]
    if "steps" in out:
        out["steps"] = [{**s, "added": RENAMED.get(s.get("added"), s.get("added")),
                         "on_top_of": [RENAMED.get(n, n) for n in s.get("on_top_of", [])],
                         "candidates": [_upgrade_entry(c) for c in s.get("candidates", [])]} for s in out["steps"]]
    if "not_tested" in out:
        out["not_tested"] = {RENAMED.get(k, k): v for k, v in out["not_tested"].items()}
    return out


def _upgrade_entry(f: dict) -> dict:
    f = dict(f)
    name = f.get("effect")
    f["effect"] = RENAMED.get(name, name)
    if name == "slope" and "slope_direction" in f.get("estimate", {}):
        f["derived"] = dict(f["estimate"])
    for key in ("estimate", "interval"):
        if key in f:
            f[key] = _upgrade_params(name, f[key])
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


__all__ = ["RENAMED", "RENAMED_PARAMS", "canonical_effects", "slope_angle", "upgrade_diagnosis"]
