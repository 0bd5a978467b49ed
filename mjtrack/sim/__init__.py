"""MuJoCo tracked robot: model builder, rollouts, scenarios, steady states.

``chassis`` is the one robot builder (chassis, suspension, sensors, scene) into which a track
model plugs; ``builder`` makes the roller-chain robot, or the wheels of a wheeled robot
(``traction: "wheels"``), from a :class:`~mjtrack.io.robot.Robot` and a :class:`SimConfig` (and
dispatches to the other track model); ``rollout`` rolls out track-speed
commands (``mujoco.rollout``) into drive-log columns; ``scenarios`` names command tables; ``steady`` measures steady-state
twists and ICRs; ``assets`` writes ``assets/robot.xml`` and ``assets/scene.xml``. The
``surfacevel`` track model (``SimConfig(track_model="surfacevel")``) lives in
:mod:`mjtrack.sim.surfacevel`; what both track models share (terrain contacts, suspension travel,
idlers, solver options) in :mod:`mjtrack.sim.scene`; ``terrain`` parses ``--terrain`` specs and
``drivetrain`` turns the robot's drive keys into simulation terms. Import order (no circles):
config, terrain, drivetrain -> scene -> chassis -> ground, surfacevel -> builder -> rollout -> steady.
"""

from mjtrack.sim.builder import build_model as build_model
from mjtrack.sim.builder import build_spec as build_spec
from mjtrack.sim.builder import control_matrix as control_matrix
from mjtrack.sim.config import SimConfig as SimConfig
from mjtrack.sim.rollout import drive_log as drive_log
from mjtrack.sim.rollout import log_icrs as log_icrs
from mjtrack.sim.rollout import run_batch as run_batch
from mjtrack.sim.rollout import simulate as simulate
from mjtrack.sim.scenarios import SCENARIOS as SCENARIOS
from mjtrack.sim.scenarios import read_commands as read_commands
from mjtrack.sim.scenarios import scenario_commands as scenario_commands
from mjtrack.sim.steady import SteadyResult as SteadyResult
from mjtrack.sim.steady import steady_batch as steady_batch
from mjtrack.sim.steady import steady_state as steady_state

__all__ = [
    "SCENARIOS", "SimConfig", "SteadyResult", "build_model", "build_spec", "control_matrix", "drive_log", "log_icrs",
    "read_commands", "run_batch", "scenario_commands", "simulate", "steady_batch", "steady_state",
]
