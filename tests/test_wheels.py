"""The wheeled skid-steer robot: its description keys, the point-contact Coulomb reference against
hand-derived closed forms, the MuJoCo model (names, mass, loads, straight driving), windows and
the video's wheels. (Fidelity against the reference: tests/test_wheeled_fidelity.py; commands:
tests/test_wheels_cli.py.)"""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest
from scipy import optimize

from mjtrack.errors import InputError
from mjtrack.io.robot import G, Robot
from mjtrack.models.coulomb import normal_loads, steady_state
from mjtrack.sim import SimConfig, drive_log
from mjtrack.sim.builder import build_model, control_matrix
from mjtrack.sim.rollout import STATE_SPEC, settled_state
from mjtrack.sim.terrain import parse_terrain

HUSKY = dict(traction="wheels", track_gauge=0.555, wheel_radius=0.165, wheelbase=0.512, mass=50.0, cg_z=0.2,
             track_width=0.11)


def husky(**changes) -> Robot:
    return Robot.from_dict(HUSKY).replace(**changes) if changes else Robot.from_dict(HUSKY)


# -- description --------------------------------------------------------------------------------
def test_wheeled_keys_and_the_wheel_radius_alias_round_trip():
    r = husky()
    assert (r.traction, r.wheels_per_side, r.contact_length) == ("wheels", 2, 0.512)
    assert r.wheel_radius == r.sprocket_radius == 0.165
    assert Robot.from_dict(r.to_dict()) == r
    d = r.to_dict()
    assert d["wheel_radius"] == d["sprocket_radius"] == 0.165 and d["traction"] == "wheels"
    alias = {k: v for k, v in HUSKY.items() if k != "wheel_radius"} | {"sprocket_radius": 0.165}
    assert Robot.from_dict(alias) == r  # the DRIVE logs' key
    assert "sprocket_radius" in r.provided


def test_a_tracked_description_keeps_its_keys_and_a_wheeled_one_defaults_to_a_square_footprint():
    assert not {"traction", "wheelbase", "wheels_per_side", "wheel_radius"} & set(Robot().to_dict())
    r = Robot.from_dict({"track_gauge": 0.6, "traction": "wheels"})
    assert r.wheelbase == r.contact_length == 0.6 and "wheelbase" not in r.provided


def test_axles_are_evenly_spaced_over_the_wheelbase():
    assert husky().axle_positions() == pytest.approx([-0.256, 0.256])
    assert husky(wheels_per_side=3).axle_positions() == pytest.approx([-0.256, 0.0, 0.256])
    with pytest.raises(InputError, match="no axles"):
        Robot().axle_positions()


@pytest.mark.parametrize("change, match", [
    ({"traction": "legs"}, "'traction' must be one of"),
    ({"wheels_per_side": 2.5}, "whole number from 2 to 10"),
    ({"wheels_per_side": 1}, "whole number from 2 to 10"),
    ({"wheelbase": -0.3}, "'wheelbase' must be a positive number"),
    ({"wheelbase": 500.0}, "beyond physical plausibility"),
    ({"cg_x": 0.26}, r"outside the wheels \(\|cg_x\| must be < wheelbase/2"),
    ({"sprocket_radius": 0.2}, "alias 'sprocket_radius' = 0.2 differ"),
    ({"ground": {"model": "road_wheels"}}, "carries its load at its axles"),
    ({"traction": "tracks"}, "describe a wheeled robot"),
])
def test_bad_wheeled_descriptions_are_refused_in_one_line(change, match):
    with pytest.raises(InputError, match=match) as err:
        Robot.from_dict({**HUSKY, **change}, source="husky.json")
    assert "\n" not in str(err.value) and str(err.value).startswith("husky.json: ")


# -- the point-contact Coulomb reference (hand-derived closed forms) -------------------------------
@pytest.mark.parametrize("T, B", [(0.555, 0.512), (1.08, 1.1), (0.9, 0.45)])
def test_pivot_of_a_four_wheel_robot_has_the_closed_form_yaw_ratio(T, B):
    # Equal loads, V_L = -V, V_R = V, no inertia: by symmetry vx = vy = 0, and the four slips
    # (V - wz T/2, +-wz B/2) have the same moment arm: Mz = 0 <=> wz (T^2 + B^2)/4 = V T/2.
    r = Robot(traction="wheels", track_gauge=T, wheelbase=B)
    s = steady_state(r, -0.7, 0.7, inertial=False)
    wz = 2 * 0.7 * T / (T * T + B * B)
    assert s.wz == pytest.approx(wz, rel=1e-9)
    assert (s.y_l, s.y_r, s.x_c) == pytest.approx((0.7 / wz, -0.7 / wz, 0.0), abs=1e-9)


def test_pivot_of_a_six_wheel_robot_solves_the_hand_derived_moment_balance():
    # Equal loads; front and rear wheels slip (V - wz T/2, +-wz B/2), the middle ones (V - wz T/2, 0):
    # Mz = 0 <=> 2 (wz (B^2 + T^2)/4 - V T/2) / |u_front| = T/2 (the middle wheels' moment).
    T, B, V = 0.8, 1.0, 0.5
    r = Robot(traction="wheels", track_gauge=T, wheelbase=B, wheels_per_side=3)

    def g(wz):
        return 2 * (wz * (B * B + T * T) / 4 - V * T / 2) / math.hypot(V - wz * T / 2, wz * B / 2) - T / 2

    wz = optimize.brentq(g, 1e-9, 2 * V / T - 1e-9, xtol=1e-15)
    assert steady_state(r, -V, V, inertial=False).wz == pytest.approx(wz, rel=1e-9)


def test_wheel_loads_follow_the_lever_rule():
    # Rigid chassis on equal springs, four wheels at (+-B/2, +-T/2): N = W/4 (1 +- 2 cx/B +- 2 cy/T).
    r = husky(cg_x=0.04, cg_y=-0.03)
    x, y, N = normal_loads(r)
    expected = r.weight / 4 * (1 + 2 * 0.04 * np.sign(x) / 0.512 - 2 * 0.03 * np.sign(y) / 0.555)
    assert N == pytest.approx(expected, rel=1e-12)
    assert len(N) == 4 and set(np.round(x, 6)) == {-0.256, 0.256}


@pytest.mark.parametrize("cg_frac, rolls", [(0.15, True), (0.1, False)])
def test_a_robot_with_its_load_on_the_front_axle_turns_about_it(cg_frac, rolls):
    # Quasi-static, front wheels rolling: the twist turns about the front axle at the ideal rate,
    # the rear wheels slide sideways (u = (0, -wz B)) and push mu N_r each; the front wheels must take
    # -2 mu N_r sideways and the couple: f_x = -+2 B mu N_r / T. They can (each lateral share mu N_r)
    # when N_r^2 (1 + 4 B^2/T^2) <= N_f^2, N_f,r = W/4 (1 +- 2 cx/B) (lever rule).
    T, B = 0.37, 0.262
    r = Robot(traction="wheels", track_gauge=T, wheelbase=B, mass=17.0, cg_x=cg_frac * B)
    nf, nr = 1 + 2 * cg_frac, 1 - 2 * cg_frac
    assert (nr * nr * (1 + 4 * B * B / (T * T)) <= nf * nf) == rolls  # the hand condition
    s = steady_state(r, 0.4, 1.0, inertial=False)
    if rolls:
        assert (s.y_l, s.y_r, s.x_c) == pytest.approx((T / 2, -T / 2, B / 2), abs=1e-12)
        assert s.wz == pytest.approx(0.6 / T, rel=1e-12)
    else:
        assert s.x_c < B / 2 - 0.01 and abs(s.y_l - T / 2) > 0.01  # no wheel rolls


# -- the MuJoCo model -------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def model():
    return build_model(husky(cg_x=0.03, cg_y=0.01))


def test_model_names_mass_and_centre_of_mass(model):
    names = {model.sensor(i).name for i in range(model.nsensor)}
    assert {"track_speed_left", "track_speed_right", "ground_left", "ground_right", "body_linvel", "body_angvel",
            "body_pos", "body_quat"} <= names
    joints = {model.joint(j).name for j in range(model.njnt)}
    assert {f"{k}_{s}_{i}" for k in ("roll", "susp") for s in ("left", "right") for i in range(2)} <= joints
    assert {model.actuator(a).name for a in range(model.nu)} == {f"drive_{s}_{i}" for s in ("left", "right")
                                                                 for i in range(2)}
    assert model.npair == 4 and {model.pair(p).name for p in range(model.npair)} == {
        f"contact_{s}_{i}" for s in ("left", "right") for i in range(2)}
    assert control_matrix(model).sum(axis=0) == pytest.approx([2, 2])
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    assert model.body_subtreemass[0] == pytest.approx(50.0, rel=1e-9)
    assert data.subtree_com[0] == pytest.approx([0.03, 0.01, 0.2], abs=1e-9)


def test_wheels_rest_on_their_lever_rule_loads_without_warnings(model):
    data = mujoco.MjData(model)
    mujoco.mj_setState(model, data, settled_state(model), STATE_SPEC)
    mujoco.mj_forward(model, data)
    f6, loads = np.zeros(6), {}
    for i in range(data.ncon):
        mujoco.mj_contactForce(model, data, i, f6)
        c = data.contact[i]
        loads[model.geom(c.geom2 if model.geom(c.geom2).name.startswith("wheel") else c.geom1).name] = f6[0]
    W = 50.0 * G
    for name, n in loads.items():
        side, i = name.split("_")[1], int(name.split("_")[2])
        sx, sy = (-1, 1)[i], 1 if side == "left" else -1
        assert n == pytest.approx(W / 4 * (1 + 2 * 0.03 * sx / 0.512 + 2 * 0.01 * sy / 0.555), rel=2e-3), name
    assert len(loads) == 4 and not any(w.number for w in data.warning)


def test_straight_driving_runs_at_the_wheel_speed():
    log = drive_log(husky(), (np.array([0.0]), np.array([1.0]), np.array([1.0])), duration=6.0)
    k = log.t >= 4.0
    speed = (log.v_left[k] + log.v_right[k]) / 2
    assert np.mean(log.vx[k]) == pytest.approx(np.mean(speed), rel=1e-4)
    assert abs(log.y[-1] - log.y[0]) < 1e-4 * abs(log.x[-1] - log.x[0])


def test_wheels_climb_a_step_without_idlers():
    m = build_model(husky(), terrain=parse_terrain("step:0.04:1.0"))
    assert not any(m.body(b).name.startswith("idler_") for b in range(m.nbody))


def test_the_surfacevel_track_model_is_refused_for_wheels():
    with pytest.raises(InputError, match="has wheels, not the 'surfacevel' track model"):
        build_model(husky(), SimConfig(track_model="surfacevel"))


def test_the_wheel_spin_inertia_has_no_gyroscopic_moment(model):
    # the spin inertia is the hinge's armature; the body's own inertia about its axle is 1 % of a
    # solid sphere's (assets/README.md, "Wheels": a full one gave 9.5 % more lateral load transfer)
    b = model.body("wheel_left_0").id
    assert model.body_inertia[b][1] < 0.02 * model.body_inertia[b][0]
    assert model.dof_armature[model.joint("roll_left_0").dofadr[0]] > 100 * model.body_inertia[b][1]


# -- windows and the video ------------------------------------------------------------------------
def test_windows_replay_a_wheeled_log_and_move_with_its_wheelbase():
    from mjtrack.sim.windows import WindowSim, simulate_windows
    from mjtrack.windows import make_windows

    robot = husky(cg_x=0.03, drive_lag=0.05)
    table = (np.array([0.0, 1.3, 3.0, 4.65]), np.array([0.0, 0.5, -0.4, 0.6]), np.array([0.0, 0.7, 0.4, -0.2]))
    log = drive_log(robot, table, duration=6.0, log_rate=20.0)
    ws = make_windows(log, 2.0)
    sim = WindowSim(robot)
    res = simulate_windows(sim, log, ws, [{}, {"wheelbase": 0.4}, {"mu": 0.5}])
    rms = res.rms()
    assert rms[0] < 1e-3 and rms[1] > 10 * rms[0] and rms[2] > 10 * rms[0] and not res.any_diverged
    with pytest.raises(InputError, match="no track length"):
        simulate_windows(sim, log, ws, [{"track_length": 0.6}])
    with pytest.raises(InputError, match="'wheelbase' needs a wheeled robot"):
        simulate_windows(WindowSim(Robot()), log, ws, [{"wheelbase": 0.4}])


def test_the_video_turns_each_side_s_wheels_by_its_travel_over_the_radius(model):
    from mjtrack.render import turn_wheels

    travel = np.array([[0.0, 0.0], [0.33, -0.165]])
    q = turn_wheels(model, np.tile(model.qpos0, (2, 1)), travel, 0.165)
    for side, angle in (("left", 2.0), ("right", -1.0)):
        for i in range(2):
            assert q[1, model.joint(f"roll_{side}_{i}").qposadr[0]] == pytest.approx(angle)
    assert q[1, :7] == pytest.approx(model.qpos0[:7])


def test_wheels_on_the_anisotropic_ground_match_the_reference():
    # lateral tyre friction half the longitudinal (capsule contacts across each wheel); the first
    # command turns about the front axle (the reference's rolling state), the second is a pivot
    from mjtrack.sim.steady import steady_batch

    r = husky(cg_x=0.03, ground={"model": "anisotropic", "lateral_ratio": 0.5})
    for s in steady_batch([r, r], np.array([[0.2, 0.8], [-0.5, 0.5]])):
        ref = steady_state(r, s.v_left, s.v_right)
        assert max(abs(a - b) for a, b in zip((s.y_l, s.y_r, s.x_c), ref.icr)) < 0.05 * r.track_gauge / 2
