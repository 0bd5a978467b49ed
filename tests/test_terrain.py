"""Terrain (--terrain): parsing, contacts with every terrain geom for both track models, step
climbing, height fields, friction patches, log columns on terrain, robustness and determinism.

Expectations come from geometry and statics (an incline's height is x tan(angle); a robot
stopped by a wall does not pass it; a patch's μ shows in the contact pairs), not from the code
under test."""

from __future__ import annotations

import json
import math
import re

import mujoco
import numpy as np
import pytest

from mjtrack.errors import InputError
from mjtrack.io.robot import Robot
from mjtrack.sim.builder import build_model, control_matrix
from mjtrack.sim.config import SimConfig, sim_config
from mjtrack.sim.rollout import simulate
from mjtrack.sim.steady import steady_state
from mjtrack.sim.surfacevel import set_track_speeds
from mjtrack.sim.terrain import parse_terrain, timestep_for
from support.cli import run_cli

MODELS = ["rollers", "surfacevel"]


@pytest.fixture
def hfield_file(tmp_path):
    rng = np.random.default_rng(3)
    path = tmp_path / "bumps.npy"
    np.save(path, rng.random((30, 30)))
    return path


@pytest.fixture
def patches_file(tmp_path):
    path = tmp_path / "ice.json"
    path.write_text(json.dumps({"patches": [{"x": 1.5, "y": 0.0, "size_x": 1.0, "size_y": 4.0, "mu": 0.1}]}))
    return path


@pytest.mark.parametrize("spec, pattern", [
    ("incline", r"expected incline:ANGLE\[:DIR\]"),
    ("incline:x", r"ANGLE must be a number, got 'x'"),
    ("incline:2", r"incline angle must be in \(-1\.2, 1\.2\) rad, got 2"),
    ("step:0.1", r"expected step:HEIGHT:X"),
    ("step:-0.1:1", r"step height must be in \(0, 5\] m"),
    ("step:nan:1", r"HEIGHT must be finite"),
    ("hfield:none.npy:1:1:0.1", r"height field file none\.npy not found"),
    ("hfield:a.txt:1:1", r"expected hfield:FILE:SIZE_X:SIZE_Y:HEIGHT"),
    ("hill", r"unknown terrain"),
])
def test_bad_specs_are_one_line_errors(spec, pattern):
    with pytest.raises(InputError, match=r"^terrain=" + re.escape(repr(spec)) + ": " + pattern) as info:
        parse_terrain(spec)
    assert "\n" not in str(info.value)


def test_bad_patch_and_json(tmp_path):
    bad = tmp_path / "p.json"
    bad.write_text(json.dumps({"patches": [{"x": 0, "y": 0, "size_x": 1, "size_y": 1, "mu": -1}]}))
    with pytest.raises(InputError, match=r"patch 0: sizes and 'mu' must be positive"):
        parse_terrain(f"patches:{bad}")
    combo = tmp_path / "t.json"
    combo.write_text(json.dumps({"incline": {"angle": 0.1}, "stairs": []}))
    with pytest.raises(InputError, match=r"unknown key\(s\) \['stairs'\]"):
        parse_terrain(str(combo))


@pytest.mark.parametrize("model", MODELS)
def test_every_track_element_meets_every_terrain_geom(model, tmp_path, hfield_file, patches_file):
    combo = tmp_path / "all.json"
    combo.write_text(json.dumps({"incline": {"angle": 0.05}, "steps": [{"height": 0.04, "x": 2.0}],
                                 "hfield": {"file": hfield_file.name, "size_x": 4, "size_y": 4, "height": 0.02},
                                 "patches": json.loads(patches_file.read_text())["patches"]}))
    robot = Robot(mu_left=0.6, mu_right=0.9)
    m = build_model(robot, sim_config(model), parse_terrain(str(combo)))
    names = lambda obj, n: [mujoco.mj_id2name(m, obj, i) for i in range(n)]  # noqa: E731
    geoms = names(mujoco.mjtObj.mjOBJ_GEOM, m.ngeom)
    terrain = ["floor", "step_0", "hfield", "patch_0"]
    elements = [g for g in geoms if g.startswith(("roller_", "track_", "idler_"))]
    assert len([g for g in elements if not g.startswith("idler_")]) == 2 * sim_config(model).n_rollers
    pairs = {}
    for p in range(m.npair):  # MuJoCo may swap a pair's geoms: key (terrain geom, element)
        a, b = geoms[m.pair_geom1[p]], geoms[m.pair_geom2[p]]
        pairs[(a, b) if a in terrain else (b, a)] = m.pair_friction[p, 0]
    for t in terrain:
        for e in elements:
            assert (t, e) in pairs, (t, e)
    side_mu = {"left": 0.6, "right": 0.9}
    for (t, e), mu in pairs.items():
        if e.startswith("idler_"):
            continue
        track_mu = side_mu[e.split("_")[1]]
        # combination rule: the ground has the track's μ; a patch μ_patch μ_track / μ
        expected = 0.1 * track_mu / robot.mu if t == "patch_0" else track_mu
        assert mu == pytest.approx(expected)


def _drive(spec, model="rollers", v=(0.5, 0.5), seconds=6.0, robot=None):
    config = sim_config(model)
    config = config.replace(timestep=timestep_for(config.timestep, parse_terrain(spec)))
    cmd = np.tile(v, (int(round(seconds / config.timestep)), 1))
    return simulate(robot or Robot(), cmd, config=config, terrain=parse_terrain(spec))


def test_incline_pose_columns():
    out = _drive("incline:0.2", seconds=3.0)
    # on the plane rising along +x: z = x tan(angle), pitch = -angle (nose up), no roll
    assert out["z"][-1] == pytest.approx(out["x"][-1] * math.tan(0.2), abs=2e-3)
    assert out["pitch"][-1] == pytest.approx(-0.2, abs=0.02)
    assert abs(out["roll"][-1]) < 0.01 and abs(out["yaw"][-1]) < 0.01
    side = _drive("incline:0.2:1.5707963", seconds=1.0)  # uphill +y: left side up
    assert side["roll"][-1] == pytest.approx(0.2, abs=0.02)
    assert "z" not in _drive("flat", seconds=0.5)  # flat logs keep their columns


@pytest.mark.parametrize("v", [0.3, 1.0])
def test_climbs_a_4cm_step_and_is_stopped_by_a_40cm_one(v):
    low = _drive("step:0.04:0.6", v=(v, v))
    assert low["x"][-1] > 1.5 and low["z"][-1] == pytest.approx(0.04, abs=0.005)
    high = _drive("step:0.4:0.6", v=(v, v))
    assert high["x"][-1] < 0.6 - 0.25 + 0.01  # the front idler (x + L/2 + R_s) stays at the wall


def test_height_field_changes_the_path(hfield_file):
    flat = _drive("flat", v=(0.5, 0.3))
    bumpy = _drive(f"hfield:{hfield_file}:4:4:0.05", v=(0.5, 0.3))
    dist = float(np.hypot(bumpy["x"][-1] - flat["x"][-1], bumpy["y"][-1] - flat["y"][-1]))
    assert dist > 0.05
    assert np.ptp(bumpy["z"]) > 0.01


def test_ice_patch_slows_the_turn(patches_file):
    """On the μ 0.1 patch the pivoting robot's yaw rate changes (Coulomb: the turning
    resistance scales with μ while the tracks' speeds are held)."""
    grip = _drive("flat", v=(-0.4, 0.4), seconds=2.0)
    # a patch under the robot at the origin
    ice = _drive(f"patches:{patches_file}", v=(-0.4, 0.4), seconds=2.0)
    assert abs(ice["yaw"][-1] - grip["yaw"][-1]) < 1e-9  # the patch is at x 1-2 m: not under it
    patches_file.write_text(json.dumps({"patches": [{"x": 0, "y": 0, "size_x": 3, "size_y": 3, "mu": 0.1}]}))
    on_ice = _drive(f"patches:{patches_file}", v=(-0.4, 0.4), seconds=2.0)
    assert abs(on_ice["yaw"][-1] - grip["yaw"][-1]) > 0.05


def test_same_seed_same_bytes(tmp_path, hfield_file):
    args = ["simulate", "--scenario", "random_steps", "--duration", "2", "--seed", "4",
            "--terrain", f"hfield:{hfield_file}:4:4:0.03", "--quiet"]
    assert run_cli([*args, "--out", tmp_path / "a.csv"]).rc == 0
    assert run_cli([*args, "--out", tmp_path / "b.csv"]).rc == 0
    assert (tmp_path / "a.csv").read_bytes() == (tmp_path / "b.csv").read_bytes()
    header = (tmp_path / "a.csv").read_text().splitlines()[0].split(",")
    assert header[-3:] == ["z", "roll", "pitch"]
    doc = json.loads((tmp_path / "a.json").read_text())
    assert doc["terrain"]["hfield"]["height"] == 0.03


def _terrain_grid(seed, n, hfield):
    rng = np.random.default_rng(seed)
    specs = ["incline:0.3", "incline:0.25:1.0", "step:0.04:0.6", "step:0.4:-0.7", f"hfield:{hfield}:4:4:0.06"]
    for _ in range(n):
        robot = Robot(mass=float(rng.choice([5.0, 20.0, 150.0])), mu=float(rng.uniform(0.3, 1.2)),
                      track_gauge=float(rng.uniform(0.3, 0.8)), track_length=float(rng.uniform(0.4, 1.0)))
        yield robot, specs[int(rng.integers(len(specs)))], rng.uniform(-2.0, 2.0, 2)


def _check_no_warning(robot, spec, v, seconds):
    terrain = parse_terrain(spec)
    m = build_model(robot, SimConfig(timestep=timestep_for(SimConfig().timestep, terrain)), terrain)
    d = mujoco.MjData(m)
    d.ctrl[:] = control_matrix(m) @ v
    for _ in range(int(round(seconds / m.opt.timestep))):
        mujoco.mj_step(m, d)
    warnings = {mujoco.mjtWarning(i).name: d.warning[i].number for i in range(len(d.warning)) if d.warning[i].number}
    assert not warnings, (robot, spec, v, warnings)
    assert np.all(np.isfinite(d.qpos)) and np.all(np.isfinite(d.qvel))


def test_no_warning_small_terrain_grid(hfield_file):
    for robot, spec, v in _terrain_grid(0, 4, hfield_file):
        _check_no_warning(robot, spec, v, 1.0)


@pytest.mark.slow
def test_no_warning_seeded_terrain_grid(hfield_file):
    for robot, spec, v in _terrain_grid(1, 40, hfield_file):
        _check_no_warning(robot, spec, v, 4.0)


def test_step_under_the_start_footprint_is_refused():
    with pytest.raises(InputError, match=r"^terrain='step:0.04:0.3': the step edge at x = 0.3 m lies under the robot's "
                                         r"start footprint"):
        build_model(Robot(), SimConfig(), parse_terrain("step:0.04:0.3"))


def test_steady_reports_undefined_icrs_where_the_robot_does_not_turn():
    """mu 0.05 against 1.0: the slippery track cannot turn the robot (before: y_l = -6268 m)."""
    r = steady_state(Robot(mu_left=0.05, mu_right=1.0), 0.3, 0.5, settle_s=1.0, window_s=0.5)
    assert math.isnan(r.y_l) and math.isnan(r.y_r) and math.isnan(r.x_c)
    assert "does not turn" in r.icr_undefined
    assert r.to_dict()["y_l"] is None
    turn = steady_state(Robot(), 0.3, 0.5, settle_s=1.0, window_s=0.5)
    assert turn.icr_undefined is None and math.isfinite(turn.y_l)


# -- Coulomb reference on slopes -----------------------------------------------------------------
def test_coulomb_slope_slides_at_the_closed_form_acceleration():
    """Tracks stopped on a slope steeper than atan mu: the robot slides down at
    g (sin a - mu cos a) (closed form); gentler than atan mu it stays (creep ~ eps only)."""
    from mjtrack.io.robot import G
    from mjtrack.models.coulomb import rollout

    robot = Robot(mu=0.3)
    t = np.linspace(0.0, 1.0, 11)
    steep = rollout(robot, t, 0.0, 0.0, slope=0.5, slope_direction=0.0, n_points=20)
    a = G * (math.sin(0.5) - 0.3 * math.cos(0.5))
    assert steep.pose[-1, 0] == pytest.approx(-0.5 * a * 1.0**2, rel=1e-3)  # downhill is -x
    gentle = rollout(robot, t, 0.0, 0.0, slope=0.2, slope_direction=1.0, n_points=20)
    assert np.hypot(*gentle.pose[-1, :2]) < 1e-3


def test_coulomb_plane_world_round_trip():
    from mjtrack.models.coulomb import plane_to_world, world_to_plane

    pose = np.array([[1.0, 2.0, 0.3], [-0.5, 0.1, -2.0]])
    w = plane_to_world(pose, 0.2, 0.7)
    back = world_to_plane(w[:, 0], w[:, 1], w[:, 3], 0.2, 0.7)
    np.testing.assert_allclose(back, pose[:, :2], atol=1e-12)
    # uphill (direction 0.7) rises by sin(0.2) per metre along it
    up = plane_to_world(np.array([[math.cos(0.7), math.sin(0.7), 0.0]]), 0.2, 0.7)
    assert up[0, 3] == pytest.approx(math.sin(0.2), abs=1e-12)


def test_mujoco_turn_on_an_incline_matches_coulomb():
    """Done-when (short version of benchmarks/terrain_checks.py, which runs 12 s): on a 0.2 rad
    incline a turning robot's path matches the Coulomb reference fed the measured track speeds
    within 6 % of the distance travelled."""
    from mjtrack.models.coulomb import plane_to_world, rollout, world_to_plane

    out = _drive("incline:0.2:1.5707963", v=(0.5, 0.3), seconds=4.0)
    xy0 = world_to_plane(out["x"][:1], out["y"][:1], out["z"][:1], 0.2, 1.5707963)[0]
    ref = rollout(Robot(), out["t"], out["v_left"], out["v_right"], pose0=(xy0[0], xy0[1], out["yaw"][0]),
                  slope=0.2, slope_direction=1.5707963, n_points=20)
    w = plane_to_world(ref.pose, 0.2, 1.5707963)
    dist = float(np.sum(np.hypot(np.diff(out["x"]), np.diff(out["y"]))))
    assert np.hypot(w[-1, 0] - out["x"][-1], w[-1, 1] - out["y"][-1]) < 0.06 * dist


def test_terrain_scenarios_carry_their_terrain(tmp_path):
    out = tmp_path / "hill.csv"
    assert run_cli(["simulate", "--scenario", "hill_climb", "--duration", "2", "--quiet", "--out", out]).rc == 0
    doc = json.loads((tmp_path / "hill.json").read_text())
    assert doc["terrain"]["incline"]["angle"] == 0.25
    rows = out.read_text().splitlines()
    last = dict(zip(rows[0].split(","), map(float, rows[-1].split(","))))
    assert last["z"] == pytest.approx(last["x"] * math.tan(0.25), abs=0.01)
    # --terrain replaces the scenario's
    assert run_cli(["simulate", "--scenario", "hill_climb", "--duration", "1", "--terrain", "flat", "--quiet",
                    "--out", tmp_path / "flat.csv"]).rc == 0
    assert "terrain" not in json.loads((tmp_path / "flat.json").read_text())


@pytest.mark.parametrize("model", MODELS)
def test_contact_sensors_count_each_tracks_element_contacts(model):
    """``ground_<side>`` equals the contacts of that track's elements in MuJoCo's contact list at
    every step of a step climb (idlers, which touch the step, are not counted), and falls below N
    while elements are in the air."""
    config = sim_config(model)
    terrain = parse_terrain("step:0.04:0.6")
    config = config.replace(timestep=timestep_for(config.timestep, terrain))
    m = build_model(Robot(), config, terrain)
    d = mujoco.MjData(m)
    side_of = {}
    for g in range(m.ngeom):
        name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g) or ""
        if name.startswith(("roller_", "track_")):
            side_of[g] = name.split("_")[1]
    assert any((mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g) or "").startswith("idler_") for g in range(m.ngeom))
    n = len(side_of) // 2
    if model == "surfacevel":
        set_track_speeds(m, 0.5, 0.5)
    else:
        d.ctrl[:] = control_matrix(m) @ np.array([0.5, 0.5])
    mujoco.mj_forward(m, d)
    fewest = n
    for _ in range(int(round(3.0 / config.timestep))):
        mujoco.mj_step(m, d)
        geoms = d.contact.geom[:d.ncon]
        for side in ("left", "right"):
            count = sum(1 for g1, g2 in geoms for g in (g1, g2) if side_of.get(g) == side)
            assert d.sensor(f"ground_{side}").data[0] == count
            fewest = min(fewest, count)
    assert fewest < n
