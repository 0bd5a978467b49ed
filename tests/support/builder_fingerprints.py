"""Fingerprints of the compiled MuJoCo robot models: a detector of unintended model changes.

Every case builds one robot + track model + terrain (+ ground model), compiles it and records
a hash of every array and scalar of the ``MjModel`` (sizes, masses, inertias, positions, geom
and actuator parameters, contact pairs, options...), a hash of the spec's XML and a hash of a
short open-loop rollout's (qpos, qvel) bytes (plain ``mj_step``, constant track commands).
Three robots (the default one, a heavy asymmetric one, a light one with a ground model), both
track models, flat / incline / step / height-field terrain, both roller couplings and the
surfacevel element variants. Every setting is pinned in the stored file (the SimConfig fields
are stored, not taken from the current defaults), so a change of a default elsewhere does not
show up here; a change of what the builders make from the same inputs does.

    python tests/support/builder_fingerprints.py --write  # store tests/data/builder_fingerprints.json
    python tests/support/builder_fingerprints.py          # compare with the stored file, list differences

``tests/test_builder_fingerprints.py`` runs the comparison by default. The hashes are bit-exact
(same MuJoCo build and CPU family); regenerate the file only for an intended model change, and
say which in the commit.
"""

from __future__ import annotations

import argparse
import dataclasses
import hashlib
import json
import sys
from pathlib import Path

import mujoco
import numpy as np

from mjtrack.io.robot import Ground, Robot
from mjtrack.sim.builder import build_model, build_spec, control_matrix
from mjtrack.sim.config import SimConfig, surfacevel_config
from mjtrack.sim.surfacevel import build_surfacevel_model, robot_spec, set_track_speeds
from mjtrack.sim.terrain import HField, Step, Terrain

STORE = Path(__file__).resolve().parents[1] / "data" / "builder_fingerprints.json"  # tests/data
STEPS = 150  # rollout length [steps]
COMMAND = (0.3, 0.5)  # (V_L, V_R) [m/s]: a gentle left turn

ROBOTS = {
    "default": dict(),
    "heavy": dict(track_gauge=0.6, track_length=0.9, track_width=0.12, sprocket_radius=0.08, mass=60.0, cg_x=0.05,
                  cg_y=-0.02, cg_z=0.2, mu=0.7, mu_left=0.7, mu_right=0.5, drive_lag=0.02, drive_force_limit=400.0),
    "light": dict(track_gauge=0.3, track_length=0.35, track_width=0.05, sprocket_radius=0.04, mass=8.0, cg_x=-0.02,
                  cg_z=0.08, mu=0.6),
}
GROUNDS = {"road_wheels": {"model": "road_wheels", "wheels": 4, "concentration": 0.6, "span": 0.8},
           "anisotropic": {"model": "anisotropic", "lateral_ratio": 0.6}}


def _hfield() -> HField:
    y, x = np.mgrid[0:21, 0:31]
    heights = 0.5 + 0.5 * np.sin(x / 3.0) * np.cos(y / 4.0)  # closed form, no randomness
    return HField(file="synthetic", size_x=6.0, size_y=4.0, height=0.03, heights=heights)


TERRAINS = {"flat": lambda: None, "incline": lambda: Terrain(angle=0.17, direction=0.5, spec="incline:0.17:0.5"),
            "step": lambda: Terrain(steps=(Step(height=0.05, x=0.9),), spec="step:0.05:0.9"),
            "hfield": lambda: Terrain(hfield=_hfield(), spec="hfield:synthetic")}

# (name, robot, ground, track model, config changes ("base": whose defaults), terrain, surfacevel options)
CASES = [
    ("default-rollers-flat", "default", None, "rollers", {}, "flat", {}),
    ("default-rollers-step", "default", None, "rollers", {}, "step", {}),
    ("default-rollers-equality", "default", None, "rollers", {"coupling": "equality", "lag": 0.05}, "flat", {}),
    ("heavy-rollers-incline", "heavy", None, "rollers", {}, "incline", {}),
    ("light-rollers-roadwheels", "light", "road_wheels", "rollers", {}, "flat", {}),
    ("light-rollers-anisotropic-hfield", "light", "anisotropic", "rollers", {}, "hfield", {}),
    ("default-surfacevel-flat", "default", None, "surfacevel", {}, "flat", {}),
    ("default-surfacevel-step", "default", None, "surfacevel", {}, "step", {}),
    ("heavy-surfacevel-incline", "heavy", None, "surfacevel", {}, "incline", {}),
    ("light-surfacevel-hfield", "light", None, "surfacevel", {}, "hfield", {}),
    ("default-surfacevel-capsules", "default", None, "surfacevel", {}, "flat", {"element": "capsule"}),
    ("default-surfacevel-rigid-box", "default", None, "surfacevel", {}, "flat",
     {"element": "box", "n_elements": 1, "sprung": False}),
    # the roller chain's settings (Euler, PGS, impratio 1e-4...) given to the surfacevel builder as they are
    ("default-surfacevel-rollerconfig", "default", None, "surfacevel", {"base": "rollers"}, "flat", {}),
]


def _digest(b: bytes) -> str:
    return hashlib.sha256(b).hexdigest()[:20]


def model_fields(model: mujoco.MjModel) -> dict[str, str]:
    """{field group: hash} of every array and number of the compiled model and of its options;
    a group is the fields named alike up to the first ``_`` (``body_mass``, ``body_pos``... ->
    ``body``), or the scalar sizes (``n``)."""
    fields = {}
    for obj, prefix in ((model, ""), (model.opt, "opt."), (model.stat, "stat."), (model.vis.global_, "vis.global.")):
        for name in dir(obj):
            if name.startswith("_"):
                continue
            try:
                value = getattr(obj, name)
            except Exception:  # noqa: BLE001 (properties that cannot be read here)
                continue
            if isinstance(value, np.ndarray):
                fields[prefix + name] = np.ascontiguousarray(value).tobytes() + str(value.shape).encode()
            elif isinstance(value, (int, float, bytes, str)) and not callable(value):
                fields[prefix + name] = repr(value).encode()
    groups: dict[str, hashlib._Hash] = {}
    for name in sorted(fields):
        group = name.partition("_")[0] if "_" in name else "n"
        groups.setdefault(group, hashlib.sha256()).update(name.encode() + b"=" + fields[name])
    return {g: h.hexdigest()[:16] for g, h in groups.items()}


def _robot(name: str, ground: str | None) -> Robot:
    robot = Robot(**ROBOTS[name])
    return dataclasses.replace(robot, ground=Ground.from_value(GROUNDS[ground])) if ground else robot


def _config(track_model: str, changes: dict) -> SimConfig:
    base = SimConfig() if changes.get("base", track_model) == "rollers" else surfacevel_config()
    return base.replace(**{k: v for k, v in changes.items() if k != "base"})


def build_case(case, config: SimConfig) -> tuple[mujoco.MjModel, str]:
    """(compiled model, hash of the robot spec's XML) of one case."""
    name, robot_name, ground, track_model, _, terrain_name, options = case
    robot = _robot(robot_name, ground)
    terrain = TERRAINS[terrain_name]()
    if track_model == "rollers":
        model = build_model(robot, config, terrain)
        xml = build_spec(robot, config).to_xml()
    else:
        model = build_surfacevel_model(robot, config, terrain, **options)
        xml = robot_spec(robot, config, **options).to_xml()
    return model, _digest(xml.encode())


def rollout(model: mujoco.MjModel, track_model: str) -> tuple[str, list[float]]:
    """(hash of every step's qpos and qvel, final qpos) of STEPS steps at COMMAND from rest."""
    data = mujoco.MjData(model)
    if track_model == "rollers":
        data.ctrl[:] = control_matrix(model) @ np.array(COMMAND)
    else:
        set_track_speeds(model, *COMMAND)
    h = hashlib.sha256()
    for _ in range(STEPS):
        mujoco.mj_step(model, data)
        h.update(data.qpos.tobytes())
        h.update(data.qvel.tobytes())
    return h.hexdigest()[:20], [float(x) for x in data.qpos]


def fingerprint(case, config: SimConfig) -> dict:
    model, xml = build_case(case, config)
    traj, qpos = rollout(model, case[3])
    return {"config": config.to_dict(), "fields": model_fields(model), "spec_xml": xml, "rollout": traj,
            "final_qpos": qpos}


def current(stored: dict | None = None) -> dict:
    """Fingerprints of every case; with ``stored``, each case built with its stored SimConfig."""
    out = {}
    for case in CASES:
        if stored is not None and case[0] in stored:
            cfg = dict(stored[case[0]]["config"])
            cfg["solimp"] = tuple(cfg["solimp"])
            names = {f.name for f in dataclasses.fields(SimConfig)}
            config = SimConfig(**{k: v for k, v in cfg.items() if k in names})
        else:
            config = _config(case[3], case[4])
        out[case[0]] = {**fingerprint(case, config), "mujoco": mujoco.__version__}
    return out


def differences(stored: dict, now: dict) -> list[str]:
    """One line per case and item that differs (fields listed by name)."""
    out = []
    for name, old in stored.items():
        new = now.get(name)
        if new is None:
            out.append(f"{name}: case missing")
            continue
        changed = sorted(k for k in set(old["fields"]) | set(new["fields"])
                         if old["fields"].get(k) != new["fields"].get(k))
        if changed:
            out.append(f"{name}: model fields differ (groups): {', '.join(changed)}")
        if old["spec_xml"] != new["spec_xml"]:
            out.append(f"{name}: robot spec XML differs")
        if old["rollout"] != new["rollout"]:
            dq = np.max(np.abs(np.array(old["final_qpos"]) - np.array(new["final_qpos"]))) \
                if len(old["final_qpos"]) == len(new["final_qpos"]) else float("nan")
            out.append(f"{name}: rollout differs (final qpos max |diff| {dq:.3g})")
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--write", action="store_true", help=f"store the fingerprints in {STORE}")
    args = parser.parse_args(argv)
    if args.write:
        STORE.parent.mkdir(parents=True, exist_ok=True)
        STORE.write_text(json.dumps(current(), indent=0, sort_keys=True) + "\n")
        print(f"wrote {len(CASES)} cases to {STORE}")
        return 0
    stored = json.loads(STORE.read_text())
    diff = differences(stored, current(stored))
    print("\n".join(diff) if diff else f"all {len(stored)} cases bit-identical")
    return 1 if diff else 0


if __name__ == "__main__":
    sys.exit(main())
