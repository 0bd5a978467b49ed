"""Simulation settings of the roller chain: the faster defaults keep the old answers, the drive
scales with the robot, the step rules, the belt and the principal axes, and the wider fidelity
grid."""

from __future__ import annotations

import functools
import math
import time

import numpy as np
import pytest

from mjtrack.errors import InputError
from mjtrack.io.robot import Robot
from mjtrack.models.coulomb import steady_state as coulomb
from mjtrack.sim.config import MAX_STEP_DIVISIONS, SimConfig, previous_defaults
from mjtrack.sim.steady import case_timestep, steady_batch
from support.repo import load_benchmark


def test_solver_and_drive_settings_are_validated():
    with pytest.raises(InputError, match="solver"):
        SimConfig(solver="Jacobi")
    with pytest.raises(InputError, match="drive_reference_mass"):
        SimConfig(drive_reference_mass=0.0)
    with pytest.raises(InputError, match="rest_margin"):
        SimConfig(rest_margin="yes")
    with pytest.raises(InputError, match="level_chassis"):
        SimConfig(level_chassis=1)
    cfg = SimConfig().for_robot_mass(80.0)
    base = SimConfig()
    assert (cfg.kv, cfg.track_mass, cfg.torque_limit) == (4 * base.kv, 4 * base.track_mass, 4 * base.torque_limit)
    assert cfg.drive_reference_mass is None and cfg.for_robot_mass(5.0) == cfg  # scaled once only
    light = base.for_robot_mass(5.0)  # never softer than the default robot's drive
    assert (light.kv, light.track_mass, light.torque_limit) == (base.kv, base.track_mass, base.torque_limit)
    assert SimConfig(drive_reference_mass=None).for_robot_mass(80.0).kv == base.kv


def test_faster_defaults_give_the_previous_icrs():
    """PGS main solver against Newton (drive unscaled in both: default robot of 20 kg)."""
    robots = [Robot(cg_x=0.05), Robot(cg_x=-0.05, mu=0.4), Robot()]
    cmds = np.array([[0.6, 1.0], [-0.8, -0.5], [-0.5, 0.5]])  # R ~ 1 m, reverse R ~ 0.9 m, pivot
    new = steady_batch(robots, cmds, config=SimConfig(), settle_s=2.0, window_s=1.0)
    # the later and separate changes (rest margins, level chassis, belt, principal axes) on in both
    old = steady_batch(robots, cmds, config=previous_defaults().replace(
        rest_margin=True, level_chassis=True, belt_timeconst=SimConfig().belt_timeconst, principal_axes=True),
        settle_s=2.0, window_s=1.0)
    for a, b, r in zip(new, old, robots):
        # the main solve carries only the normal rows: PGS and Newton agree to 1e-7 T/2 on the
        # fidelity quick grid (assets/README.md "Speed"); 1e-4 leaves room for summation order
        assert max(abs(a.y_l - b.y_l), abs(a.y_r - b.y_r)) < 1e-4 * r.track_gauge / 2
        assert abs(a.x_c - b.x_c) < 1e-4 * r.track_length


def test_straight_driving_does_not_drift_with_the_defaults():
    """Too few noslip iterations break the left/right symmetry: 4 drifted 2 mm/m at 2 m/s."""
    from mjtrack.sim.rollout import drive_log

    log = drive_log(Robot(), (np.array([0.0]), np.array([2.0]), np.array([2.0])), duration=4.0, config=SimConfig())
    dist = float(np.hypot(log.x[-1] - log.x[0], log.y[-1] - log.y[0]))
    assert abs(log.y[-1] - log.y[0]) / dist < 1e-3  # measured 0.09 mm/m over 10 s (fidelity.py)


def test_straight_driving_speed_equals_the_track_speed():
    """No slip in straight driving, so the body moves at the belt speed. Without the rest margins
    it fell 0.10 % short at every speed (MuJoCo puts the contact point half-way into the rest
    penetration, at r - d/2); with them it matches to 5e-8, and with the belt to
    about 1e-5 at 0.3 m/s and 2e-6 at 2 m/s (benchmarks/fidelity.py: the strain the belt keeps
    from the start holds tangential forces at the sticking contacts, which creep by that much). The margin-less check runs
    at the fixed 5 ms step: at 2 m/s the lag budget halves the step, and d (~ tc^2) with it falls 4x."""
    from mjtrack.sim.rollout import drive_log

    for config, bound in ((SimConfig(), 1e-4), (SimConfig(rest_margin=False, lag_budget=None), None)):
        for v in (0.3, 2.0):
            log = drive_log(Robot(), (np.array([0.0]), np.array([v]), np.array([v])), duration=4.0, config=config)
            k = log.t >= 2.0
            V = np.mean(log.v_left[k] + log.v_right[k]) / 2
            err = abs(np.mean(log.vx[k]) - V) / V
            if bound is None:
                assert err > 5e-4  # the artefact the margins remove is there without them
            else:
                assert err < bound


def test_rest_margins_put_the_rollers_on_the_ground_and_are_idempotent():
    import mujoco

    from mjtrack.sim.builder import apply_rest_margins, build_model
    from mjtrack.sim.rollout import STATE_SPEC, settled_state

    for robot in (Robot(), Robot(mass=150.0, track_gauge=0.8, track_length=0.6, cg_x=0.05, cg_y=0.04)):
        model = build_model(robot)
        margins = model.pair_margin.copy()
        assert np.all(margins > 1e-5) and np.all(margins < 1e-3)  # tens of micrometres
        data = mujoco.MjData(model)
        mujoco.mj_setState(model, data, settled_state(model), STATE_SPEC)
        mujoco.mj_forward(model, data)
        dist = np.array([data.contact[i].dist for i in range(data.ncon)])
        assert data.ncon == 2 * SimConfig().n_rollers
        assert np.abs(dist).max() < 0.02 * margins.min()  # contact point at the roller radius
        apply_rest_margins(model)
        # The rest depth keeps a trace of how the robot landed (static friction holds the
        # tangential state of the landing), so reapplying is a contraction, not a no-op: for the
        # 150 kg robot the margins move by 4.8e-4, then 4.6e-6, then 5.7e-8 (2.2e-4 without the
        # belt, which couples the rollers' tangential states).
        np.testing.assert_allclose(model.pair_margin, margins, rtol=1e-3)


def test_heavy_robot_keeps_the_commanded_speed_difference():
    """80 kg, R = 5 m at 1.5 m/s: with the 20 kg robot's drive the servo error F/kv (~1 cm/s)
    ate most of the 0.15 m/s difference; the scaled drive keeps >= 90 % and the ICRs follow Coulomb."""
    robot = Robot(track_gauge=0.5, track_length=1.0, mass=80.0, cg_z=0.15)
    v, R = 1.5, 5.0
    cmd = np.array([[v * (1 - robot.track_gauge / (2 * R)), v * (1 + robot.track_gauge / (2 * R))]])
    res = steady_batch([robot], cmd, config=SimConfig(), settle_s=2.0, window_s=1.0)[0]
    assert (res.v_right - res.v_left) > 0.9 * (cmd[0, 1] - cmd[0, 0])
    ref = coulomb(robot, res.v_left, res.v_right)
    # measured 0.05 T/2 here without the belt and principal axes (0.0081 with the belt and principal axes; the unscaled
    # drive gave 0.05-0.13); the wide grid's 0.05 T/2 is the bound
    assert max(abs(res.y_l - ref.y_l), abs(res.y_r - ref.y_r)) < 0.05 * robot.track_gauge / 2


@functools.lru_cache(maxsize=1)
def _wide_rows():
    fidelity = load_benchmark("fidelity")
    return fidelity, fidelity.run_wide(True, SimConfig(), half_dt=True)


@pytest.mark.slow
def test_wide_quick_grid_passes_everywhere():
    """The wide quick grid (112 turns: 4 robots of 5-150 kg, L/T 0.6-2, pivot and R 1-10 m at
    0.2 and 2 m/s, both directions, cg +-0.1 L) with the default settings: every turn within
    0.05 T/2 and 0.02 L of the Coulomb reference with load transfer (independent code), dt
    halving < 0.02 T/2, contact >= 99 %. Without the belt, principal axes and slip budget,
    100 of 112: fast pivots of the 5 kg
    long robot (0.053 T/2, principal axes), R 10 m at 0.2 m/s (drive compliance: belt; the
    friction time constant: slip budget)."""
    fidelity, rows = _wide_rows()
    assert len(rows) == 112
    for r in rows:
        assert r["err_y"] <= fidelity.TOL_WIDE_Y and r["err_x"] <= fidelity.TOL_WIDE_X, r
        assert r["dt_dy"] < fidelity.TOL_WIDE_DT and r["contact_min"] >= 0.99, r


@pytest.mark.slow
def test_wide_grid_x_c_error_is_the_friction_horizon_offset_v_dt():
    """The friction rows' reference acceleration -v_slip/dt makes the noslip friction oppose the
    slip predicted one step ahead, which the turn has rotated by w dt, so the steady x_c lies
    v_x dt ahead of the Coulomb one (derivation and checks: assets/README.md, benchmarks/
    the gentle-turns study: RK4 gives the same offset, a longer friction time constant a longer one).
    The lag budget picks each case's step so that v dt <= 0.01 L: every turn of the quick grid
    but R = 10 m at 0.2 m/s is then within 0.02 L, and stays so less the offset v_x dt at the
    case's own step (before the budget, at 5 ms throughout: 0.056 L for the 5 kg robot with
    L = 0.18 m at 2 m/s; test_lag_budget_removes_the_friction_lag_offset_of_x_c)."""
    fidelity, rows = _wide_rows()
    turns = [r for r in rows if r["radius"] != "pivot" and not (r["radius"] == 10.0 and r["v"] == 0.2)]
    assert len(turns) == 64
    assert {r["timestep"] for r in turns if r["v"] == 2.0 and r["L"] == 0.18} == {0.005 / 6}
    raw = [abs(r["x_c"] - r["ref_x_c"]) / r["L"] for r in turns]
    corrected = [abs(r["x_c"] - r["ref_x_c"] - r["vx"] * r["timestep"]) / r["L"] for r in turns]
    assert max(raw) <= fidelity.TOL_WIDE_X and max(corrected) <= fidelity.TOL_WIDE_X


@pytest.mark.slow
def test_new_defaults_cost_less_cpu_than_the_previous():
    """CPU time (not wall: less sensitive to a shared machine), repeats interleaved."""
    from mjtrack.sim.builder import build_model
    from mjtrack.sim.rollout import run_batch, settled_state

    models = {k: build_model(Robot(), c) for k, c in (("old", previous_defaults()), ("new", SimConfig()))}
    s0 = {k: settled_state(m)[None] for k, m in models.items()}
    cmds = np.tile([0.3, 0.6], (1, 2000, 1))
    cpu = {"old": [], "new": []}
    for _ in range(5):
        for k, m in models.items():
            t0 = time.process_time()
            run_batch([m], cmds, state0=s0[k])
            cpu[k].append(time.process_time() - t0)
    # measured 1.11x in CPU time (assets/README.md "Speed"); 1.04 leaves room for timer noise
    assert np.median(cpu["old"]) > 1.04 * np.median(cpu["new"])


def test_lag_budget_step_rule():
    cfg = SimConfig()
    assert cfg.lag_budget == 0.01 and cfg.timestep == 0.005
    assert cfg.step_for(0.5, 1.0).timestep == 0.005  # default robot: 5 ms up to 1 m/s
    assert cfg.step_for(0.5, 1.01).timestep == 0.0025
    fine = cfg.step_for(0.18, 2.0)
    assert fine.timestep == pytest.approx(0.005 / 6) and fine.step_for(0.18, 2.0) == fine  # ceil(5.56); idempotent
    halved = cfg.replace(timestep=0.0025, lag_budget=0.005).step_for(0.18, 2.0)
    assert halved.timestep == pytest.approx(fine.timestep / 2)  # how the dt-halving checks halve it
    assert cfg.step_for(0.18, 0.0) == cfg
    assert SimConfig(lag_budget=None).step_for(0.18, 2.0).timestep == 0.005
    assert previous_defaults().lag_budget is None
    from mjtrack.sim.config import sim_config

    assert sim_config("rollers", timestep=0.004).step_for(0.18, 2.0).timestep == 0.004  # explicit: as given
    assert sim_config("surfacevel").step_for(0.18, 2.0).timestep == sim_config("surfacevel").timestep
    for bad in (0.0, -0.01, float("nan"), "0.01"):
        with pytest.raises(InputError, match="lag_budget"):
            SimConfig(lag_budget=bad)


def test_lag_budget_removes_the_friction_lag_offset_of_x_c():
    """A 0.18 m track at 2 m/s in a 5 m turn (the wide grid's worst x_c): the steady x_c sits v dt
    off the Coulomb reference with load transfer (independent code), the noslip friction's one-step
    lag (the gentle-turns study section 5). Measured: 10.0 mm = 0.056 L at the fixed 5 ms,
    1.78 mm = 0.0099 L at the 0.83 ms the budget picks (v dt = 1.67 mm)."""
    robot = Robot(track_gauge=0.3, track_length=0.18, track_width=0.08, mass=5.0, cg_z=0.045, cg_y=0.015)
    v, w = 2.0, 2.0 / 5.0
    cmd = [v - w * robot.track_gauge / 2, v + w * robot.track_gauge / 2]
    for config in (SimConfig(lag_budget=None), SimConfig()):
        s = steady_batch([robot], [cmd], config=config)[0]
        ref = coulomb(robot, s.v_left, s.v_right)
        dt = case_timestep(config, robot, cmd)
        assert 0.9 < (s.x_c - ref.x_c) / (v * dt) < 1.2  # the offset is v dt at either step
        assert max(abs(s.y_l - ref.y_l), abs(s.y_r - ref.y_r)) < 0.01 * robot.track_gauge / 2
    assert abs(s.x_c - ref.x_c) < 0.02 * robot.track_length  # within the wide grid's tolerance with the budget


def test_steady_batch_runs_each_case_at_its_own_step():
    """Cases at different steps in one batch give what each gives alone (bit for bit)."""
    robots = [Robot(), Robot(track_length=0.18, track_gauge=0.3, mass=5.0), Robot(cg_x=0.05)]
    cmds = np.array([[0.6, 1.0], [1.8, 2.2], [1.2, 1.6]])  # 5 ms, 0.83 ms, 2.5 ms
    batch = steady_batch(robots, cmds, settle_s=1.0, window_s=0.5)
    for robot, cmd, b in zip(robots, cmds, batch):
        alone = steady_batch([robot], [cmd], settle_s=1.0, window_s=0.5)[0]
        assert (b.y_l, b.y_r, b.x_c, b.wz) == (alone.y_l, alone.y_r, alone.x_c, alone.wz)


def test_drive_log_keeps_the_fixed_step():
    """Logs are simulated at config.timestep whatever the budget (calibration and diagnosis windows
    run there: tests/test_calibrate.py), unlike steady states at the same commands."""
    from mjtrack.sim.rollout import drive_log

    robot = Robot(track_length=0.18, track_gauge=0.3, mass=5.0)
    table = (np.array([0.0, 1.0]), np.array([0.5, 1.9]), np.array([0.5, 2.1]))
    auto = drive_log(robot, table, duration=2.0, config=SimConfig())
    fixed = drive_log(robot, table, duration=2.0, config=SimConfig(lag_budget=None))
    assert np.array_equal(auto.x, fixed.x) and np.array_equal(auto.wz, fixed.wz)
    assert SimConfig().step_for(robot.track_length, 2.1).timestep < SimConfig().timestep


def test_slip_budget_step_rule():
    """mu g dt <= slip_budget |w| L/2 (SimConfig.slip_budget): the 5 kg wide robot of the wide grid
    (L 0.18 m, mu 0.8) at R 10 m and 0.2 m/s (w 0.02 rad/s) has r = 21.8 at 5 ms: k = 5, 1 ms."""
    cfg = SimConfig()
    assert cfg.slip_budget == 5.0
    w = 0.02
    ratio = 0.8 * 9.81 * 0.005 / (w * 0.18 / 2)
    assert cfg.step_for(0.18, 0.2, w, 0.8).timestep == pytest.approx(0.005 / math.ceil(ratio / 5.0))
    assert cfg.step_for(0.18, 0.2, 0.0, 0.8) == cfg  # straight: no turn, no rule
    assert cfg.step_for(0.18, 0.2, 1e-6, 0.8).timestep == pytest.approx(0.005 / MAX_STEP_DIVISIONS)  # capped
    assert cfg.step_for(0.18, 0.2, -w, 0.8) == cfg.step_for(0.18, 0.2, w, 0.8)  # either direction
    fine = cfg.step_for(0.18, 0.2, w, 0.8)
    assert fine.step_for(0.18, 0.2, w, 0.8) == fine  # applying it twice changes nothing
    halved = cfg.replace(timestep=0.0025, lag_budget=0.005, slip_budget=2.5).step_for(0.18, 0.2, w, 0.8)
    assert halved.timestep == pytest.approx(fine.timestep / 2)  # how the dt-halving checks halve it
    assert SimConfig(slip_budget=None).step_for(0.18, 0.2, w, 0.8).timestep == 0.005
    # case_timestep: nominal turn rate from the commands and the larger track friction
    robot = Robot(track_gauge=0.3, track_length=0.18, mass=5.0, mu=0.4, mu_right=0.8)
    assert case_timestep(cfg, robot, [0.2 - w * 0.15, 0.2 + w * 0.15]) == pytest.approx(fine.timestep)
    for bad in (0.0, -1.0, float("inf"), "5"):
        with pytest.raises(InputError, match="slip_budget"):
            SimConfig(slip_budget=bad)


def _roller_surface_speeds(model, data, side: str, n: int, r: float) -> np.ndarray:
    return np.array([data.joint(f"roll_{side}_{i}").qvel[0] for i in range(n)]) * r


def test_belt_makes_the_rollers_of_a_track_run_at_one_speed():
    """SimConfig.belt_timeconst: in a gentle turn (the wide grid's 80 kg robot, cg 0.1 L ahead, R 10 m at
    0.2 m/s) the servos alone let the roller surface speeds of a track spread by F_i/(kv/N), mm/s
    like the slips, and x_c then missed Coulomb by 0.03 L (the gentle-turns study, section 5);
    with the belt every roller runs at the track speed and x_c is within 0.005 L (measured 0.0017).
    The Coulomb reference is independent code (models.coulomb)."""
    import mujoco

    from mjtrack.sim.builder import build_model, control_matrix
    from mjtrack.sim.rollout import STATE_SPEC, settled_state

    robot = Robot(mass=80.0, track_gauge=0.5, track_length=1.0, cg_z=0.125, cg_x=0.1)
    w = 0.02
    cmd = np.array([0.2 - w * 0.25, 0.2 + w * 0.25])
    spreads = {}
    for label, config in (("servos", SimConfig(belt_timeconst=None)), ("belt", SimConfig())):
        model = build_model(robot, config)
        data = mujoco.MjData(model)
        mujoco.mj_setState(model, data, settled_state(model), STATE_SPEC)
        data.ctrl[:] = control_matrix(model) @ cmd
        for _ in range(600):
            mujoco.mj_step(model, data)
        spreads[label] = max(np.ptp(_roller_surface_speeds(model, data, s, config.n_rollers, config.roller_radius))
                             for s in ("left", "right"))
        s = steady_batch([robot], [cmd], config=config)[0]
        ref = coulomb(robot, s.v_left, s.v_right)
        spreads[label + "_err_x"] = abs(s.x_c - ref.x_c) / robot.track_length
    assert spreads["servos"] > 1e-3  # mm/s: the size of the turn's slips
    assert spreads["belt"] < 0.05 * spreads["servos"]
    assert spreads["servos_err_x"] > 0.02  # the drive-compliance miss the belt removes
    assert spreads["belt_err_x"] < 0.005
    with pytest.raises(InputError, match="belt_timeconst"):
        build_model(robot, SimConfig(belt_timeconst=0.004))  # explicit Euler needs dt < belt_timeconst


def test_fast_pivot_with_the_cg_ahead_matches_coulomb():
    """5 kg long robot (T 0.2, L 0.4 m), cg 0.1 L ahead, pivot at +-2 m/s (w 10.9 rad/s): with a box
    chassis the elements tilted the robot's principal axes (I_xz = m_el cg_x (cg_z - r) M/m_chassis)
    and the centrifugal pitch moment w^2 I_xz moved the ICRs 0.053 T/2 off Coulomb; with principal
    axes (default) 0.013 T/2 (the 10-roller discretisation: 0.01)."""
    robot = Robot(mass=5.0, track_gauge=0.2, track_length=0.4, cg_z=0.05, cg_x=0.04)
    errs = {}
    for label, config in (("box", SimConfig(principal_axes=False)), ("principal", SimConfig())):
        s = steady_batch([robot], [[-2.0, 2.0]], config=config)[0]
        ref = coulomb(robot, s.v_left, s.v_right)
        errs[label] = max(abs(s.y_l - ref.y_l), abs(s.y_r - ref.y_r)) / 0.1
    assert errs["box"] > 0.04
    assert errs["principal"] < 0.02


def test_steady_warns_when_the_slip_budget_is_capped(caplog):
    """A turn so gentle that the slip budget would divide the step more than MAX_STEP_DIVISIONS
    times runs at the cap, and says so (its ICRs are not converged in dt there): 5 kg robot with a
    0.18 m track at R 40 m and 0.2 m/s asks for 18 divisions; at R 10 m (5) nothing is said."""
    import logging

    robot = Robot(track_gauge=0.3, track_length=0.18, mass=5.0, cg_z=0.045)
    gentle = [0.2 - 0.005 * 0.15, 0.2 + 0.005 * 0.15]
    assert SimConfig().slip_divisions(0.18, 0.005, 0.8) == 18
    with caplog.at_level(logging.WARNING, logger="mjtrack.sim.steady"):
        steady_batch([robot], [[0.2 - 0.02 * 0.15, 0.2 + 0.02 * 0.15]], settle_s=0.1, window_s=0.05)
        assert not caplog.records
        steady_batch([robot, robot], [gentle, gentle], settle_s=0.1, window_s=0.05)
    assert case_timestep(SimConfig(), robot, gentle) == pytest.approx(0.005 / MAX_STEP_DIVISIONS)
    assert any("2 of 2 steady case(s)" in r.getMessage() and "slip_budget" in r.getMessage() for r in caplog.records)
