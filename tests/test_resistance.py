"""Motion resistance (robot key ``rolling_resistance``): each side held back by f_r times its weight.

The checks come from Newton's law, not from the builder: driving straight at constant speed, the
drives must push with the total resistance f_r m g (the contact transmits it; nothing else acts
along x on level ground); in a turn, both sides slide and the resistance has to be balanced by the
sliding friction, so the body falls behind its tracks (forward speed below the mean track speed)
by more the sharper the turn -- what real wheeled robots show and Coulomb contact alone does not.
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from mjtrack.errors import InputError
from mjtrack.io.robot import G, Robot
from mjtrack.sim import drive_log
from mjtrack.sim.builder import build_model, control_matrix
from mjtrack.sim.steady import steady_state
from mjtrack.sim.windows import WindowSim, simulate_windows
from mjtrack.windows import make_windows

WHEELED = Robot(traction="wheels", track_gauge=0.55, wheelbase=0.5, sprocket_radius=0.165, mass=50.0, mu=0.6,
                cg_z=0.2, track_width=0.1)


def _drive_push(robot: Robot, v: float, seconds: float = 3.0) -> float:
    """Mean total drive force [N] over the last second of straight driving at ``v`` m/s."""
    m = build_model(robot)
    d = mujoco.MjData(m)
    B = control_matrix(m)
    d.ctrl[:] = B @ np.array([v, v])
    drives = np.flatnonzero(B.any(axis=1))
    n = int(seconds / m.opt.timestep)
    out = []
    for k in range(n):
        mujoco.mj_step(m, d)
        if k >= n - int(1.0 / m.opt.timestep):
            out.append(d.actuator_force[drives].sum())
    return float(np.mean(out))


@pytest.mark.parametrize("robot", [Robot(mass=20.0), WHEELED], ids=["tracks", "wheels"])
def test_straight_drive_pushes_with_the_resistance(robot):
    for c in (0.0, 0.1):
        push = _drive_push(robot.replace(rolling_resistance=c), 0.5)
        # measured: within 1 % of f_r m g (tracks and wheels); 0.5 N absolute for the servo
        # ripple at f_r = 0
        assert push == pytest.approx(c * robot.mass * G, rel=0.03, abs=0.5), (c, push)


def test_a_turn_loses_forward_speed_the_sharper_the_more():
    ratios = {}
    for c in (0.0, 0.1):
        r = WHEELED.replace(rolling_resistance=c)
        ratios[c] = [steady_state(r, vm - dv / 2, vm + dv / 2).vx / vm for vm, dv in ((0.5, 0.3), (0.4, 0.8))]
    assert ratios[0.0] == pytest.approx([1.0, 1.0], abs=0.05)  # Coulomb contact alone: no loss
    gentle, sharp = ratios[0.1]
    # measured (Husky-sized, mu 0.6): 0.9 and 0.7
    assert sharp < gentle < 0.97 and sharp < 0.85, ratios


def test_window_variant_equals_a_robot_built_with_it():
    robot = Robot()
    table = (np.array([0.0, 1.0, 2.5]), np.array([0.2, 0.6, -0.3]), np.array([0.6, 0.1, 0.5]))
    lg = drive_log(robot.replace(rolling_resistance=0.08), table, duration=4.0, log_rate=20.0)
    ws = make_windows(lg, 2.0)
    resisted = WindowSim(robot, resisted=True)
    a = simulate_windows(resisted, lg, ws, [{"rolling_resistance": 0.08}, {}])
    b = simulate_windows(WindowSim(robot.replace(rolling_resistance=0.08)), lg, ws)
    np.testing.assert_allclose(a.poses[0], b.poses[0], atol=1e-6)
    # the actuators at zero force change nothing: the robot without them, to rounding (seen: 4e-16 m;
    # two more actuators change the order of MuJoCo's sums)
    c = simulate_windows(WindowSim(robot), lg, ws)
    np.testing.assert_allclose(a.poses[1], c.poses[0], rtol=0, atol=1e-12)
    assert a.pos_err()[0].max() < 1e-3 < a.pos_err()[1].max()
    with pytest.raises(InputError, match="resisted"):
        simulate_windows(WindowSim(robot), lg, ws, [{"rolling_resistance": 0.1}])


@pytest.mark.parametrize("bad", [-0.1, 1.5, float("nan"), "0.1"])
def test_robot_key_is_checked(bad):
    with pytest.raises(InputError, match="rolling_resistance"):
        Robot(rolling_resistance=bad)


def test_robot_key_round_trips():
    r = Robot(rolling_resistance=0.12)
    assert Robot.from_dict(r.to_dict()).rolling_resistance == 0.12
