"""The surfacevel track model (mjtrack.sim.surfacevel): structure, straight driving, pivot symmetry,
agreement with the Coulomb reference, contact persistence, warnings, track drive."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from mjtrack.errors import InputError
from mjtrack.io.robot import Robot
from mjtrack.models.coulomb import steady_state
from mjtrack.sim.surfacevel import (
    TrackDrive,
    body_twist,
    build_surfacevel_model,
    ground_contact,
    run_steady,
    set_track_speeds,
    side_lookup,
    surfacevel_config,
    track_geom_ids,
)

CONFIG = surfacevel_config()


@pytest.fixture(scope="module")
def model() -> mujoco.MjModel:
    return build_surfacevel_model(Robot(), CONFIG)


def _fresh() -> mujoco.MjModel:  # run_steady writes the track speeds into the model
    return build_surfacevel_model(Robot(), CONFIG)


def test_named_elements(model):
    n = CONFIG.n_rollers
    for obj, names in (
        (mujoco.mjtObj.mjOBJ_BODY, ["chassis", "left_track", "right_track"]
         + [f"wheel_{s}_{i}" for s in ("left", "right") for i in range(n)]),
        (mujoco.mjtObj.mjOBJ_JOINT, ["root"] + [f"susp_{s}_{i}" for s in ("left", "right") for i in range(n)]),
        (mujoco.mjtObj.mjOBJ_GEOM, ["floor", "hull"] + [f"track_{s}_{i}" for s in ("left", "right") for i in range(n)]),
        (mujoco.mjtObj.mjOBJ_SITE, ["centre", "cg", "left_track", "right_track"]),
        (mujoco.mjtObj.mjOBJ_SENSOR, ["body_linvel", "body_angvel", "body_pos", "body_quat"]
         + [f"ground_{s}" for s in ("left", "right")]),
        (mujoco.mjtObj.mjOBJ_PAIR, [f"contact_{s}_{i}" for s in ("left", "right") for i in range(n)]),
    ):
        for name in names:
            assert mujoco.mj_name2id(model, obj, name) >= 0, name
    ids = track_geom_ids(model)
    assert len(ids["left"]) == len(ids["right"]) == n
    # every body, joint, geom and sensor has a name
    for obj, count in ((mujoco.mjtObj.mjOBJ_BODY, model.nbody), (mujoco.mjtObj.mjOBJ_JOINT, model.njnt),
                       (mujoco.mjtObj.mjOBJ_GEOM, model.ngeom), (mujoco.mjtObj.mjOBJ_SENSOR, model.nsensor)):
        assert all(mujoco.mj_id2name(model, obj, i) for i in range(1 if obj == mujoco.mjtObj.mjOBJ_BODY else 0, count))


def test_mass_and_centre_of_mass():
    robot = Robot(cg_x=0.05, cg_y=-0.03, cg_z=0.1, mass=25.0)
    m = build_surfacevel_model(robot, CONFIG)
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    chassis = m.body("chassis").id
    assert m.body_subtreemass[chassis] == pytest.approx(robot.mass, rel=1e-12)
    np.testing.assert_allclose(d.subtree_com[chassis], [0.05, -0.03, 0.1], atol=1e-12)


def test_track_speed_sign_and_frame(model):
    set_track_speeds(model, 0.3, -0.7)
    ids = track_geom_ids(model)
    np.testing.assert_array_equal(model.geom_surfacevel[ids["left"]], [[-0.3, 0, 0, 0, 0, 0]] * len(ids["left"]))
    np.testing.assert_array_equal(model.geom_surfacevel[ids["right"], 0], 0.7)
    assert model.flg_surfacevel == 1
    # the element geoms' frames are aligned with the chassis, so surfacevel x is the robot's x
    d = mujoco.MjData(model)
    mujoco.mj_forward(model, d)
    R = d.xmat[model.body("chassis").id].reshape(3, 3)
    for g in np.concatenate([ids["left"], ids["right"]]):
        np.testing.assert_allclose(d.geom_xmat[g].reshape(3, 3)[:, 0], R[:, 0], atol=1e-12)


@pytest.mark.parametrize("v", [0.3, -0.5])
def test_straight_driving_speed(v):
    run = run_steady(_fresh(), v, v, duration=1.5, average=0.5)
    assert abs(run.vx - v) < 0.01 * abs(v)  # fidelity target: 1 % of V
    assert abs(run.wz) < 1e-6 and abs(run.vy) < 1e-6
    assert run.drift < 1e-3  # lateral drift < 1 mm per metre
    assert run.warnings == 0


def test_pivot_turn_symmetry_and_coulomb():
    v = 0.3
    ccw = run_steady(_fresh(), -v, v, duration=2.0, average=0.5)
    cw = run_steady(_fresh(), v, -v, duration=2.0, average=0.5)
    assert ccw.wz > 0 and cw.wz == pytest.approx(-ccw.wz, rel=1e-3)
    for run in (ccw, cw):
        assert abs(run.vx) < 1e-3 and abs(run.vy) < 1e-3
        y_l, y_r, _ = run.icr()
        assert y_l == pytest.approx(-y_r, rel=1e-3)
    ref = steady_state(Robot(), -v, v)
    # Coulomb yaw ratio 0.743 (not the 0.41 of a rigid row); 2 % leaves room for 12 vs 200 points
    assert ccw.wz == pytest.approx(ref.wz, rel=0.02)
    assert ccw.warnings == 0 and cw.warnings == 0


def test_contact_persists_in_a_steady_turn():
    robot = Robot(cg_x=0.05)
    T, v, radius = robot.track_gauge, 0.8, 0.5
    vl, vr = v * (1 - T / (2 * radius)), v * (1 + T / (2 * radius))
    run = run_steady(build_surfacevel_model(robot, CONFIG), vl, vr, duration=1.5, average=0.5)
    assert run.contact_left >= 0.99 and run.contact_right >= 0.99
    d = mujoco.MjData(m := build_surfacevel_model(robot, CONFIG))
    set_track_speeds(m, vl, vr)
    for _ in range(500):
        mujoco.mj_step(m, d)
    ground = [d.sensor(f"ground_{s}").data[0] for s in ("left", "right")]
    # one contact pair per element on flat ground: N contacts = every element touches (sensor view)
    assert ground == [CONFIG.n_rollers] * 2
    assert np.all(run.loads > 0)  # every element carries load (no element hop)
    ref = steady_state(robot, vl, vr)
    y_l, y_r, x_c = run.icr()
    assert abs(y_l - ref.y_l) < 0.1 * T / 2 and abs(y_r - ref.y_r) < 0.1 * T / 2
    assert abs(x_c - ref.x_c) < 0.02 * robot.track_length
    assert run.warnings == 0


def test_ground_contact_lookup_matches_ids_and_sensors():
    """The per-step fast path (side lookup) gives what the id dict and the contact sensors give."""
    m = build_surfacevel_model(Robot(cg_x=0.05), CONFIG)
    ids = track_geom_ids(m)
    side_of = side_lookup(ids, m.ngeom)
    assert sorted(np.flatnonzero(side_of == 0)) == sorted(ids["left"])
    assert sorted(np.flatnonzero(side_of == 1)) == sorted(ids["right"])
    assert np.count_nonzero(side_of >= 0) == 2 * CONFIG.n_rollers
    d = mujoco.MjData(m)
    set_track_speeds(m, 0.2, 0.6)
    for _ in range(50):
        mujoco.mj_step(m, d)
    sensor = [d.sensor(f"ground_{s}").data[0] > 0 for s in ("left", "right")]
    np.testing.assert_array_equal(ground_contact(d, side_of), ground_contact(d, ids))
    np.testing.assert_array_equal(ground_contact(d, side_of), sensor)
    assert ground_contact(d, side_of).all()
    d.qpos[2] += 0.1  # lift the robot 10 cm: no contact on either track
    mujoco.mj_forward(m, d)
    np.testing.assert_array_equal(ground_contact(d, side_of), [False, False])
    np.testing.assert_array_equal(ground_contact(d, ids), [False, False])


# The worst cases of the fidelity grid for this model (python benchmarks/fidelity.py
# --track-model surfacevel: largest err_x on the default robot 0.0106 L, largest err_y on the long
# robot 0.031 T/2) and low-friction cases of the long robot with the cg at -0.1 L. Commands: v 0.8 m/s.
LONG = Robot(track_gauge=0.6, track_length=0.9, mass=60.0, cg_z=0.2)


@pytest.mark.parametrize("robot, v_left, v_right", [
    (Robot(cg_x=0.05, mu=0.8), 0.8 * (1 - 0.2 / 2.0), 0.8 * (1 + 0.2 / 2.0)),  # default, R 2 m
    (LONG.replace(cg_x=0.09, mu=0.8), 0.8 * (1 - 0.3 / 0.25), 0.8 * (1 + 0.3 / 0.25)),  # long, R 0.25 m
    (LONG.replace(cg_x=-0.09, mu=0.4), -0.8 * (1 + 0.3 / 0.25), -0.8 * (1 - 0.3 / 0.25)),  # long, R 0.25 m, reverse
    (LONG.replace(cg_x=-0.09, mu=0.4), -0.8, 0.8),  # long, pivot
])
def test_issue3_corner_cases_match_coulomb(robot, v_left, v_right):
    from mjtrack.sim.steady import steady_state as sim_steady

    res = sim_steady(robot, v_left, v_right, config=CONFIG)
    ref = steady_state(robot, v_left, v_right)
    half, L = robot.track_gauge / 2, robot.track_length
    assert abs(res.y_l - ref.y_l) < 0.1 * half and abs(res.y_r - ref.y_r) < 0.1 * half
    assert abs(res.x_c - ref.x_c) < 0.02 * L
    assert min(res.contact_left, res.contact_right) >= 0.99


def test_loads_follow_the_centre_of_mass():
    """Sprung elements make the loads determinate: front-heavy robot, front elements carry more."""
    run = run_steady(build_surfacevel_model(Robot(cg_x=0.05), CONFIG), 0.3, 0.3, duration=1.0, average=0.3)
    x = -0.25 + (np.arange(CONFIG.n_rollers) + 0.5) * 0.5 / CONFIG.n_rollers
    for row in run.loads:
        assert row.sum() == pytest.approx(Robot().weight / 2, rel=0.02)
        assert row @ x / row.sum() == pytest.approx(0.05, abs=0.005)


def test_track_drive_lag_is_exact_first_order():
    # force limit far above what the lag asks for (0.8 m/s / 0.1 s): the rate limit stays idle
    robot, lag = Robot(drive_lag=0.1, drive_force_limit=1e6), 0.1
    cfg = surfacevel_config()
    m = build_surfacevel_model(robot, cfg)
    d = mujoco.MjData(m)
    drive = TrackDrive(m, robot, cfg)
    for _ in range(50):
        drive.step(d, 0.8, -0.4)
    t = 50 * m.opt.timestep
    np.testing.assert_allclose(drive.speeds, np.array([0.8, -0.4]) * (1 - math.exp(-t / lag)), rtol=1e-12)
    ids = track_geom_ids(m)
    assert m.geom_surfacevel[ids["left"][0], 0] == -drive.speeds[0]


def _drive(robot, cfg, commands, n):
    m = build_surfacevel_model(robot, cfg)
    d = mujoco.MjData(m)
    drive = TrackDrive(m, robot, cfg, torque_limited=True)
    peak = 0.0
    for _ in range(n):
        drive.step(d, *commands)
        peak = max(peak, np.abs(drive.force).max())
    return drive, d, peak


def test_torque_limited_drive_servo_droop():
    """Straight: reaches the command (no load); pivot: steady V = u - F_g/kv exactly."""
    robot, cfg = Robot(), surfacevel_config()
    drive, d, _ = _drive(robot, cfg, (0.8, 0.8), 750)
    np.testing.assert_allclose(drive.speeds, 0.8, atol=1e-6)
    assert body_twist(d)[0] == pytest.approx(0.8, rel=0.01)
    drive, d, _ = _drive(robot, cfg, (-0.3, 0.3), 750)
    np.testing.assert_allclose(drive.speeds, np.array([-0.3, 0.3]) - drive.traction / cfg.kv, atol=1e-9)
    assert drive.traction[0] < 0 < drive.traction[1]  # the ground resists each track
    assert np.all(np.abs(drive.speeds) < 0.3)


def test_torque_limited_drive_stalls_at_the_force_limit():
    """F_max = 20 N is below a pivot turn's Coulomb turning resistance (~44 N a track): the drive
    stalls, the servo stays saturated and the mean ground traction equals F_max."""
    robot = Robot()
    cfg = surfacevel_config(torque_limit=1.2)  # F_max = 1.2 N m / 0.06 m = 20 N
    m = build_surfacevel_model(robot, cfg)
    d = mujoco.MjData(m)
    drive = TrackDrive(m, robot, cfg, torque_limited=True)
    traction, speeds = [], []
    for k in range(1500):
        drive.step(d, -0.3, 0.3)
        assert np.all(np.abs(drive.force) <= drive.force_limit + 1e-9)
        if k >= 500:
            traction.append(drive.traction.copy())
            speeds.append(drive.speeds.copy())
    assert drive.force_limit == pytest.approx(20.0)
    np.testing.assert_allclose(drive.force, [-20.0, 20.0])
    # stick-slip at stall: the filtered traction fluctuates by ~+-5 N about F_max, hence 5 % on the mean
    np.testing.assert_allclose(np.mean(traction, axis=0), [-20.0, 20.0], rtol=0.05)
    assert np.abs(speeds).max() < 0.05  # stalled (commanded 0.3 m/s)


def test_bad_options_are_refused():
    with pytest.raises(InputError, match="element"):
        build_surfacevel_model(Robot(), CONFIG, element="wheel")
    with pytest.raises(InputError, match="n_elements"):
        build_surfacevel_model(Robot(), CONFIG, n_elements=0)
    with pytest.raises(InputError, match="traction_filter"):
        TrackDrive(build_surfacevel_model(Robot(), CONFIG), Robot(), CONFIG, traction_filter=0.0)


def test_robot_alone_compiles_without_floor():
    from mjtrack.sim.surfacevel import robot_spec

    m = robot_spec(Robot(), CONFIG).compile()
    assert mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "floor") == -1
    assert m.body("chassis").id == 1


@pytest.mark.parametrize("changes, words", [
    (dict(friction_timeconst=1.0), "creep"),
    (dict(impratio=1e-4), "almost no friction"),
    (dict(solimp=(0.95, 0.99, 0.001, 0.5, 2.0)), "hop"),
])
def test_distorting_settings_are_flagged(caplog, changes, words):
    with caplog.at_level("WARNING", logger="mjtrack.sim.surfacevel"):
        build_surfacevel_model(Robot(), surfacevel_config(**changes))
    assert words in caplog.text



def test_recommended_settings_are_not_flagged(caplog):
    with caplog.at_level("WARNING", logger="mjtrack.sim.surfacevel"):
        build_surfacevel_model(Robot(), CONFIG)
    assert caplog.text == ""


def test_builder_switch_builds_this_model():
    from mjtrack.sim.builder import build_model

    m = build_model(Robot(), CONFIG)
    assert len(track_geom_ids(m)["left"]) == CONFIG.n_rollers and m.flg_surfacevel == 1


def test_wide_tracks_build_with_the_shared_hull():
    # tracks wider than half the gauge: the surfacevel model used to give its visual hull a
    # width T/2 - w <= 0 ("size 1 must be positive in geom"); the shared chassis keeps 0.1 T
    m = build_surfacevel_model(Robot(track_gauge=0.3, track_width=0.15), CONFIG)
    assert m.geom("hull").size[1] == pytest.approx(0.03)


def test_divergence_ends_in_nan_not_in_a_silent_reset():
    # the shared chassis options disable MuJoCo's auto-reset (the roller chain's setting): before,
    # this unstable surfacevel model (dt 0.05 s, stiff springs) jumped back to rest unnoticed
    m = build_surfacevel_model(Robot(), surfacevel_config(timestep=0.05, suspension_deflection=0.0005))
    d = mujoco.MjData(m)
    set_track_speeds(m, -1.0, 1.0)
    for _ in range(100):
        mujoco.mj_step(m, d)
    assert d.time == pytest.approx(100 * 0.05)
    assert not np.isfinite(d.qpos).all()
