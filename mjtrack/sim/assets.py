"""The default robot as MJCF files: ``assets/robot.xml`` (robot) + ``assets/scene.xml`` (scene).

Both are generated from the builder (:func:`asset_texts`), never edited by hand; a test
checks that the committed files equal what the builder produces. ``robot.xml`` is the robot
alone (bodies, joints, actuators, sensors, solver options); ``scene.xml`` includes it and
adds the floor, the roller-floor contact pairs (which carry the friction settings) and a
light. MuJoCo's XML writer rounds numbers to 6 significant digits, so the files are for
viewing and for other tools; rollouts build the model from :mod:`mjtrack.sim.builder`.
Regenerate with ``python -c "from mjtrack.sim.assets import write_assets; write_assets()"``.
"""

from __future__ import annotations

from pathlib import Path

from mjtrack.io.atomic import atomic_write_text
from mjtrack.io.robot import Robot
from mjtrack.sim.builder import ROLLER_CHAIN, build_model, build_spec
from mjtrack.sim.chassis import add_scene
from mjtrack.sim.config import SimConfig
from mjtrack.sim.terrain import FLOOR_FRICTION

ASSETS_DIR = Path(__file__).resolve().parents[2] / "assets"


def asset_texts(robot: Robot | None = None, config: SimConfig | None = None) -> dict[str, str]:
    """{'robot.xml': ..., 'scene.xml': ...} for a robot (default: the default robot)."""
    robot = robot or Robot()
    config = config or SimConfig()
    robot_xml = build_spec(robot, config).to_xml()
    scene = add_scene(build_spec(robot, config), robot, config, tracks=ROLLER_CHAIN)
    # the compiled model's margins: the builder adds the rollers' rest penetrations after compiling
    # (mjtrack.sim.builder.apply_rest_margins)
    model = build_model(robot, config)
    margin = {model.pair(i).name: float(model.pair_margin[i]) for i in range(model.npair)}
    lines = ['<mujoco model="tracked_robot_scene">', '  <include file="robot.xml"/>', "",
             '  <visual>', '    <headlight diffuse="0.6 0.6 0.6" ambient="0.3 0.3 0.3"/>', '  </visual>', "",
             "  <worldbody>",
             f'    <geom name="floor" type="plane" size="50 50 0.1" friction="{_fmt(_floor_friction())} 0 0" '
             'rgba="0.8 0.8 0.75 1"/>',
             '    <light name="sun" pos="0 0 5" dir="0 0 -1" directional="true"/>',
             "  </worldbody>", "", "  <contact>"]
    for p in scene.pairs:
        lines.append(
            f'    <pair name="{p.name}" geom1="{p.geomname1}" geom2="{p.geomname2}" condim="{p.condim}" '
            f'friction="{_vec(p.friction)}" solref="{_vec(p.solref)}" solreffriction="{_vec(p.solreffriction)}" '
            f'solimp="{_vec(p.solimp)}" margin="{_fmt(margin.get(p.name, p.margin))}"/>'
        )
    lines += ["  </contact>", "</mujoco>", ""]
    return {"robot.xml": robot_xml, "scene.xml": "\n".join(lines)}


def _floor_friction() -> float:
    return FLOOR_FRICTION


def _fmt(x: float) -> str:
    return f"{float(x):.6g}"


def _vec(v) -> str:
    return " ".join(_fmt(x) for x in v)


def write_assets(directory: str | Path = ASSETS_DIR) -> list[Path]:
    """Write robot.xml and scene.xml of the default robot into ``directory``."""
    directory = Path(directory)
    paths = []
    for name, text in asset_texts().items():
        atomic_write_text(directory / name, text)
        paths.append(directory / name)
    return paths
