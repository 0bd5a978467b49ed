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

from importlib import import_module

# The package's names are loaded on first use (PEP 562), so that its module without MuJoCo
# (``config``, the simulator settings) can be imported by the layers that must not load it.
_WHERE = {
    "build_model": "builder", "build_spec": "builder", "control_matrix": "builder", "SimConfig": "config",
    "drive_log": "rollout", "log_icrs": "rollout", "run_batch": "rollout", "simulate": "rollout",
    "SCENARIOS": "scenarios", "read_commands": "scenarios", "scenario_commands": "scenarios",
    "SteadyResult": "steady", "steady_batch": "steady", "steady_state": "steady",
}


def __getattr__(name: str):
    if name in _WHERE:
        value = getattr(import_module(f"mjtrack.sim.{_WHERE[name]}"), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'mjtrack.sim' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_WHERE))


__all__ = [
    "SCENARIOS", "SimConfig", "SteadyResult", "build_model", "build_spec", "control_matrix", "drive_log", "log_icrs",
    "read_commands", "run_batch", "scenario_commands", "simulate", "steady_batch", "steady_state",
]
