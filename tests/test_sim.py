"""MuJoCo roller-chain robot: builder, physics properties, determinism, robustness, assets."""

from __future__ import annotations

import itertools
import json
import math

import mujoco
import numpy as np
import pytest

from mjtrack.errors import InputError
from mjtrack.io.logs import log_to_csv_text
from mjtrack.io.robot import Robot
from mjtrack.sim.assets import ASSETS_DIR, asset_texts
from mjtrack.sim.builder import build_model, control_matrix
from mjtrack.sim.config import SimConfig
from mjtrack.sim.rollout import drive_log, hold_commands, steps_per_sample
from mjtrack.sim.scenarios import SCENARIOS, read_commands, scenario_commands
from mjtrack.sim.steady import steady_state


def test_builder_names_every_element():
    cfg = SimConfig()
    m = build_model(Robot(), cfg)
    n = cfg.n_rollers
    assert m.nu == 2 * n and m.nv == 6 + 4 * n + 2  # + the two belt joints
    for kind, names in (
        (mujoco.mjtObj.mjOBJ_BODY, ["chassis", "left_track", "right_track", "belt_left", "belt_right"]
         + [f"roller_{s}_{i}" for s in ("left", "right") for i in range(n)]),
        (mujoco.mjtObj.mjOBJ_JOINT, ["root", "belt_left", "belt_right"] + [f"{j}_{s}_{i}" for j in ("susp", "roll")
                                                                           for s in ("left", "right") for i in range(n)]),
        (mujoco.mjtObj.mjOBJ_ACTUATOR, [f"drive_{s}_{i}" for s in ("left", "right") for i in range(n)]),
        (mujoco.mjtObj.mjOBJ_SENSOR, ["body_linvel", "body_angvel", "body_pos", "body_quat",
                                      "track_speed_left", "track_speed_right", "ground_left", "ground_right"]),
        (mujoco.mjtObj.mjOBJ_SITE, ["centre", "cg"]),
        (mujoco.mjtObj.mjOBJ_TENDON, ["track_left", "track_right"] + [f"belt_{s}_{i}" for s in ("left", "right")
                                                                      for i in range(n)]),
    ):
        for name in names:
            assert mujoco.mj_name2id(m, kind, name) >= 0, name
    for kind, count in ((mujoco.mjtObj.mjOBJ_BODY, m.nbody), (mujoco.mjtObj.mjOBJ_JOINT, m.njnt),
                        (mujoco.mjtObj.mjOBJ_ACTUATOR, m.nu), (mujoco.mjtObj.mjOBJ_SENSOR, m.nsensor)):
        unnamed = [i for i in range(1 if kind == mujoco.mjtObj.mjOBJ_BODY else 0, count)
                   if not mujoco.mj_id2name(m, kind, i)]
        assert not unnamed
    B = control_matrix(m)
    assert B.shape == (2 * n, 2) and np.all(B.sum(axis=1) == 1) and B[:, 0].sum() == n


def test_mass_and_centre_of_mass_match_the_robot():
    robot = Robot(cg_x=0.04, cg_y=-0.03, cg_z=0.1, mass=25.0)
    m = build_model(robot)
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    chassis = m.body("chassis").id
    assert m.body_subtreemass[chassis] == pytest.approx(25.0)
    np.testing.assert_allclose(d.subtree_com[chassis], [0.04, -0.03, 0.1], atol=1e-12)


def test_equality_coupling_variant_builds_and_drives():
    cfg = SimConfig(coupling="equality", timestep=0.002, kv=3000.0, track_mass=10.0, integrator="implicitfast")
    m = build_model(Robot(), cfg)
    assert m.neq == 2 * cfg.n_rollers and m.nu == 2
    res = steady_state(Robot(), 0.5, 0.5, config=cfg, settle_s=1.0, window_s=0.5)
    assert res.vx == pytest.approx(res.v_left, rel=0.01)


def test_straight_driving_speed_and_drift():
    res = steady_state(Robot(), 0.8, 0.8, settle_s=1.5, window_s=1.0)
    V = (res.v_left + res.v_right) / 2
    assert abs(res.vx - V) < 0.01 * V  # fidelity target: |v_x - V| < 1 % of V
    assert abs(res.vy) < 1e-4 and abs(res.wz) < 1e-4
    assert math.isnan(res.y_l)  # straight: ICRs undefined, reported as NaN
    assert res.contact_left == res.contact_right == 1.0


def test_pivot_is_symmetric_and_close_to_coulomb():
    from mjtrack.models.coulomb import steady_state as coulomb

    ccw = steady_state(Robot(), -0.5, 0.5, settle_s=1.5, window_s=1.0)
    cw = steady_state(Robot(), 0.5, -0.5, settle_s=1.5, window_s=1.0)
    assert ccw.wz > 0 and cw.wz == pytest.approx(-ccw.wz, rel=1e-3)
    assert ccw.y_l == pytest.approx(-ccw.y_r, abs=1e-3)
    assert abs(ccw.x_c) < 1e-3 and abs(ccw.vx) < 1e-3
    ref = coulomb(Robot(), ccw.v_left, ccw.v_right)
    assert abs(ccw.y_l - ref.y_l) < 0.1 * Robot().track_gauge / 2
    assert min(ccw.contact_left, ccw.contact_right, ccw.roller_contact) == 1.0


def test_cg_forward_moves_icr_forward():
    from mjtrack.models.coulomb import steady_state as coulomb

    robot = Robot(cg_x=0.05)
    res = steady_state(robot, 0.3, 0.8, settle_s=2.0, window_s=1.0)
    ref = coulomb(robot, res.v_left, res.v_right)
    assert res.x_c > 0.03
    assert abs(res.x_c - ref.x_c) < 0.02 * robot.track_length


def test_same_seed_same_log_bytes():
    robot = Robot()
    table, _ = scenario_commands("random_steps", robot, seed=7)
    a = log_to_csv_text(drive_log(robot, table, duration=4.0))
    b = log_to_csv_text(drive_log(robot, table, duration=4.0))
    assert a == b
    other, _ = scenario_commands("random_steps", robot, seed=8)
    assert log_to_csv_text(drive_log(robot, other, duration=4.0)) != a


def test_log_columns_and_rate():
    log = drive_log(Robot(), scenario_commands("circle", Robot())[0], duration=1.0, log_rate=50.0)
    assert len(log.t) == 51 and log.t[0] == 0.0 and log.t[-1] == pytest.approx(1.0)
    assert log.v_left_cmd[-1] < log.v_right_cmd[-1] and log.wz[-1] > 0
    with pytest.raises(InputError, match="multiple of the time step"):
        steps_per_sample(0.004, 30.0)


def test_logged_command_is_the_one_in_force_from_the_row_time():
    # A step in the command at t = 0.5 s: the row at 0.5 s already carries the new command (it
    # is held over [t_j, t_j+1), as models.integrate and the filters assume), while the robot
    # at 0.5 s has not yet responded to it.
    table = (np.array([0.0, 0.5]), np.array([0.0, 0.4]), np.array([0.0, 0.4]))
    log = drive_log(Robot(), table, duration=1.0, log_rate=50.0)
    j = int(np.flatnonzero(np.isclose(log.t, 0.5))[0])
    assert log.v_left_cmd[j - 1] == 0.0 and log.v_left_cmd[j] == 0.4 and log.v_right_cmd[j] == 0.4
    assert abs(log.vx[j]) < 1e-3 and log.vx[j + 5] > 0.05
    assert log.v_left_cmd[-1] == 0.4


def test_zero_order_hold():
    c = hold_commands(np.array([0.0, 0.01]), np.array([1.0, 2.0]), np.array([3.0, 4.0]), timestep=0.004,
                      duration=0.02)
    np.testing.assert_array_equal(c[:, 0], [1, 1, 1, 2, 2])
    with pytest.raises(InputError, match="strictly increasing"):
        hold_commands(np.array([0.0, 0.0]), np.ones(2), np.ones(2), timestep=0.004, duration=1.0)


def test_scenarios_registry():
    robot = Robot()
    for name, sc in SCENARIOS.items():
        (t, vl, vr), duration = scenario_commands(name, robot)
        assert duration == sc.duration and len(t) == len(vl) == len(vr) and t[0] == 0.0
    (t, vl, vr), duration = scenario_commands("u_path", robot)
    assert duration == 27.0 and (vr[1] - vl[1]) / robot.track_gauge == pytest.approx(math.pi / 6)
    with pytest.raises(InputError, match="unknown scenario"):
        scenario_commands("nope", robot)


def test_read_commands(tmp_path):
    p = tmp_path / "c.csv"
    p.write_text("t,v_left_cmd,v_right_cmd\n0,0.1,0.2\n1,0.3,0.4\n")
    t, vl, vr = read_commands(p)
    np.testing.assert_array_equal(vr, [0.2, 0.4])
    p.write_text("t,v_left_cmd,v_right_cmd\n0,0.1,0.2\n0,0.3,x\n")
    with pytest.raises(InputError, match="line 3, column 'v_right_cmd'"):
        read_commands(p)
    p.write_text("t,v_left_cmd\n0,0.1\n")
    with pytest.raises(InputError, match="missing column 'v_right_cmd'"):
        read_commands(p)


def test_config_validation():
    with pytest.raises(InputError, match="n_rollers"):
        SimConfig(n_rollers=1)
    with pytest.raises(InputError, match="track_model"):
        SimConfig(track_model="belt")
    with pytest.raises(InputError, match="unstable"):
        build_model(Robot(), SimConfig(kv=1e6))


def _run_checked(robot: Robot, config: SimConfig, v_left: float, v_right: float, seconds: float) -> None:
    """Step with mj_step and fail on any MuJoCo warning or non-finite state."""
    m = build_model(robot, config)
    d = mujoco.MjData(m)
    d.ctrl[:] = control_matrix(m) @ [v_left, v_right]
    for _ in range(int(round(seconds / config.timestep))):
        mujoco.mj_step(m, d)
    warnings = {mujoco.mjtWarning(i).name: d.warning[i].number for i in range(len(d.warning)) if d.warning[i].number}
    assert not warnings, (robot, config.timestep, v_left, v_right, warnings)
    assert np.all(np.isfinite(d.qpos)) and np.all(np.isfinite(d.qvel))


def robustness_grid(seed: int, n: int):
    """Seeded grid: mu 0.1-1.5, cg up to +-40 % of L/2 and T/2, speeds up to 2 m/s, dt 0.5-4 ms."""
    rng = np.random.default_rng(seed)
    base = Robot()
    for _ in range(n):
        robot = base.replace(
            mu=float(rng.uniform(0.1, 1.5)),
            cg_x=float(rng.uniform(-0.4, 0.4) * base.track_length / 2),
            cg_y=float(rng.uniform(-0.4, 0.4) * base.track_gauge / 2),
        )
        dt = float(rng.choice([0.0005, 0.001, 0.002, 0.004]))
        yield robot, SimConfig(timestep=dt), *rng.uniform(-2.0, 2.0, 2)


def test_no_warnings_small_grid():
    extremes = [(Robot(mu=mu, cg_x=cx, cg_y=cy), SimConfig(timestep=dt), vl, vr)
                for mu, cx, cy, dt, (vl, vr) in [
                    (0.1, 0.1, 0.08, 0.004, (2.0, -2.0)), (1.5, -0.1, -0.08, 0.004, (-2.0, 2.0)),
                    (1.5, 0.1, -0.08, 0.0005, (2.0, 0.5)), (0.1, -0.1, 0.08, 0.004, (2.0, 2.0))]]
    for robot, cfg, vl, vr in itertools.chain(extremes, robustness_grid(0, 2)):
        _run_checked(robot, cfg, vl, vr, 0.5)


@pytest.mark.slow
def test_no_warnings_seeded_grid():
    for robot, cfg, vl, vr in robustness_grid(1, 40):
        _run_checked(robot, cfg, vl, vr, 3.0)


def test_committed_assets_equal_builder_output():
    for name, text in asset_texts().items():
        assert (ASSETS_DIR / name).read_text() == text, f"assets/{name} is stale: run write_assets()"
    m = mujoco.MjModel.from_xml_path(str(ASSETS_DIR / "scene.xml"))
    ref = build_model(Robot())
    assert (m.nq, m.nv, m.nu, m.npair, m.nsensor) == (ref.nq, ref.nv, ref.nu, ref.npair, ref.nsensor)


def test_steady_command_prints_json(capsys):
    import argparse

    from mjtrack.commands import steady

    p = argparse.ArgumentParser()
    steady.add_arguments(p)
    assert steady.run(p.parse_args(["--v-left", "-0.4", "--v-right", "0.4", "--settle", "1", "--window", "0.5",
                                    "--json"])) == 0
    doc = json.loads(capsys.readouterr().out)
    assert {"vx", "vy", "wz", "y_l", "y_r", "x_c"} <= set(doc) and doc["wz"] > 0


def test_simulate_command_writes_log_and_robot(tmp_path):
    import argparse

    from mjtrack.commands import simulate
    from mjtrack.io.logs import read_log
    from mjtrack.io.robot import read_robot

    p = argparse.ArgumentParser()
    simulate.add_arguments(p)
    out = tmp_path / "run.csv"
    args = p.parse_args(["--scenario", "pivot", "--duration", "1", "--cg-x", "0.02", "--out", str(out), "--quiet"])
    assert simulate.run(args) == 0
    log = read_log(out)
    assert len(log.t) == 51 and log.wz[-1] > 0
    assert read_robot(tmp_path / "run.json").cg_x == 0.02


def test_surfacevel_track_model_through_the_switch():
    pytest.importorskip("mjtrack.sim.surfacevel")
    from mjtrack.sim.config import sim_config

    cfg = sim_config("surfacevel")
    res = steady_state(Robot(), -0.5, 0.5, config=cfg, settle_s=1.5, window_s=0.5)
    assert res.y_l == pytest.approx(-res.y_r, abs=1e-3) and res.wz > 0
    log = drive_log(Robot(), scenario_commands("pivot", Robot())[0], duration=0.5, config=cfg)
    assert len(log.t) == int(round(0.5 * 50)) + 1 and log.wz[-1] > 0


def test_lag_slows_the_track_response():
    cmd = (np.array([0.0]), np.array([0.5]), np.array([0.5]))
    fast = drive_log(Robot(), cmd, duration=0.4)
    slow = drive_log(Robot(), cmd, duration=0.4, config=SimConfig(lag=0.1))
    k = np.searchsorted(fast.t, 0.3)
    assert fast.v_left[k] == pytest.approx(0.5, abs=1e-3)
    # first-order lag tau = 0.1 s: set-point 0.5 (1 - exp(-3)) at t = 0.3 s; the servo follows it
    # within its droop (about 1 mm/s here)
    assert slow.v_left[k] == pytest.approx(0.5 * (1 - math.exp(-3.0)), abs=0.005)


def test_batch_results_do_not_depend_on_threads():
    from mjtrack.sim.steady import steady_batch

    robots = [Robot(), Robot(cg_x=0.05, mu=0.4), Robot(mu=1.2), Robot(cg_y=-0.05)]
    cmds = np.array([[-0.5, 0.5], [0.3, 0.8], [1.0, 0.2], [0.6, 0.6]])
    one = steady_batch(robots, cmds, settle_s=0.5, window_s=0.25, nthread=1)
    two = steady_batch(robots, cmds, settle_s=0.5, window_s=0.25, nthread=2)
    assert [r.to_dict() for r in one] == [r.to_dict() for r in two]


def test_log_icrs_of_a_pivot():
    from mjtrack.sim.rollout import log_icrs

    log = drive_log(Robot(), scenario_commands("pivot", Robot())[0], duration=2.0)
    icr = log_icrs(log)
    assert not icr.valid[0]  # at rest
    assert icr.y_l[-1] == pytest.approx(-icr.y_r[-1], abs=1e-3) and 0.2 < icr.y_l[-1] < 0.35
