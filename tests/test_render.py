"""Offscreen videos and animated path plots (mjtrack.render), on a tiny model of their own.

Rendering is checked loosely but with properties that a broken renderer fails: the right
shape and frame count, frames neither black nor all identical, the followed body stays in
the middle of the image while the fixed camera sees it move, the trail and the ICR marker
appear in their colours. Input errors are checked without any OpenGL.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from mjtrack.errors import InputError
from mjtrack.render import gl
from mjtrack.icr import icr_from_twist
from mjtrack.render.animation import animate_paths, footprint_corners
from mjtrack.render.decor import (ICR_LABELS, ICR_RGBA, BeltGeometry, belt_geometry, icr_markers, legend_image,
                                  roller_geoms)
from mjtrack.render.video import (
    clock_text,
    frame_times,
    interpolate_qpos,
    qpos_from_poses,
    render_video,
    track_travel_from_speeds,
)

imageio = pytest.importorskip("imageio.v2")

BOX_RGBA = (0.8, 0.1, 0.1)
TEST_XML = """
<mujoco model="render_test">
  <worldbody>
    <light name="sun" pos="0 0 4" dir="0 0 -1" directional="true"/>
    <geom name="floor" type="plane" size="20 20 0.1" rgba="0.8 0.8 0.75 1"/>
    <body name="chassis" pos="0 0 0.1">
      <freejoint name="root"/>
      <geom name="hull" type="box" size="0.3 0.2 0.1" rgba="0.8 0.1 0.1 1"/>
    </body>
  </worldbody>
</mujoco>
"""
RADIUS = 1.5  # [m] of the test turn
YAW_RATE = 0.5  # [rad/s]


@pytest.fixture(scope="module")
def model():
    return mujoco.MjModel.from_xml_string(TEST_XML)


@pytest.fixture(scope="module")
def backend():
    try:
        return gl.select_backend()
    except gl.RenderUnavailableError as exc:
        pytest.skip(f"no offscreen OpenGL backend: {exc}")


def turn(duration: float = 2.0, n: int = 101):
    """Times (n,) and poses (n, 3) of a CCW circle of RADIUS about (0, RADIUS), starting at the origin."""
    t = np.linspace(0.0, duration, n)
    yaw = YAW_RATE * t
    return t, np.column_stack([RADIUS * np.sin(yaw), RADIUS * (1 - np.cos(yaw)), yaw])


def colour_mask(frame: np.ndarray, rgb, tol: int = 60) -> np.ndarray:
    """Pixels whose hue matches ``rgb`` (0..1): the ratio of channels, robust to shading."""
    f = frame.astype(float) + 1.0
    ref = np.asarray(rgb, float) * 255 + 1.0
    ratio = f / f.sum(axis=2, keepdims=True)
    ref_ratio = ref / ref.sum()
    return (np.abs(ratio - ref_ratio).max(axis=2) < tol / 765) & (f.max(axis=2) > 40)


def centroid(mask: np.ndarray) -> np.ndarray:
    rows, cols = np.nonzero(mask)
    return np.array([cols.mean(), rows.mean()])


# --- resampling and poses (no OpenGL) -----------------------------------------------------------

def test_frame_times_span_the_trajectory_at_fps_over_speed():
    t = np.array([0.5, 1.0, 3.5])
    for fps, speed in ((30, 1.0), (25, 2.0), (10, 0.5)):
        tf = frame_times(t, fps=fps, speed=speed)
        assert tf[0] == 0.5 and tf[-1] <= 3.5 + 1e-12
        assert 3.5 - tf[-1] < speed / fps  # the last frame is within one frame of the end
        np.testing.assert_allclose(np.diff(tf), speed / fps)


def test_qpos_from_poses_places_the_body(model):
    _, poses = turn()
    q = qpos_from_poses(model, poses)
    data = mujoco.MjData(model)
    for k in (0, 37, 100):
        data.qpos[:] = q[k]
        mujoco.mj_kinematics(model, data)
        xmat = data.xmat[1].reshape(3, 3)
        np.testing.assert_allclose(data.xpos[1, :2], poses[k, :2], atol=1e-12)
        assert math.isclose(math.atan2(xmat[1, 0], xmat[0, 0]), poses[k, 2], abs_tol=1e-12)
        assert data.xpos[1, 2] == pytest.approx(0.1)  # the height of qpos0


def test_interpolation_is_exact_at_samples_and_slerps_between(model):
    t = np.array([0.0, 1.0])
    poses = np.array([[0.0, 0.0, 0.0], [1.0, 2.0, 1.2]])
    q = qpos_from_poses(model, poses)
    out = interpolate_qpos(model, q, t, np.array([0.0, 0.25, 1.0]))
    np.testing.assert_allclose(out[[0, 2]], q, atol=1e-12)
    quat = out[1, 3:7]
    assert np.linalg.norm(quat) == pytest.approx(1.0, abs=1e-12)
    # a rotation about z: slerp at 1/4 gives a quarter of the yaw, and positions move linearly
    np.testing.assert_allclose(quat, [math.cos(0.15), 0, 0, math.sin(0.15)], atol=1e-12)
    np.testing.assert_allclose(out[1, :2], [0.25, 0.5], atol=1e-12)


def test_icr_markers_of_a_circle_sit_at_its_centre():
    _, poses = turn()
    n = len(poses)
    vx, wz = np.full(n, RADIUS * YAW_RATE), np.full(n, YAW_RATE)
    vx[0] = wz[0] = 0.0  # at rest: no ICR, no marker
    icr = icr_from_twist(vx, np.zeros(n), wz, vx - 0.2 * wz, vx + 0.2 * wz, on_singular="mask")
    world = icr_markers(poses, icr)  # (N, 3 ICRs, xyz)
    assert world.shape == (n, 3, 3) and np.all(np.isnan(world[0, :, :2]))
    np.testing.assert_allclose(world[1:, 2, :2], np.tile([0.0, RADIUS], (n - 1, 1)), atol=1e-12)
    left = poses[1:, :2] + 0.2 * np.column_stack([-np.sin(poses[1:, 2]), np.cos(poses[1:, 2])])
    np.testing.assert_allclose(world[1:, 0, :2], left, atol=1e-12)  # y_l = 0.2 m left of the centre


def test_footprint_corners_rotate_a_rectangle():
    corners = footprint_corners((1.0, 2.0, math.pi / 2), 0.6, 0.4)
    np.testing.assert_allclose(corners[0], [1.0 - 0.2, 2.0 + 0.3], atol=1e-12)  # front-left
    sides = np.linalg.norm(np.roll(corners, -1, axis=0) - corners, axis=1)
    np.testing.assert_allclose(sides, [0.6, 0.4, 0.6, 0.4], atol=1e-12)


# --- input errors (no OpenGL) -------------------------------------------------------------------

@pytest.mark.parametrize(
    "change, match",
    [
        (dict(qpos_traj=np.zeros((101, 5))), r"qpos_traj must have shape \(N, nq=7\)"),
        (dict(times=np.linspace(0, 1, 100)), r"times must have shape \(101,\)"),
        (dict(times=np.r_[np.linspace(0, 1, 100), 0.5]), "strictly increasing.*sample 100"),
        (dict(follow_body="tank"), "no body named 'tank'.*chassis"),
        (dict(width=641), "width must be an even number"),
        (dict(height=0), "height must be an even number"),
        (dict(speed=0.0), "fps and speed must be positive"),
        (dict(out_path="video.avi"), r"must be a \.mp4 file"),
        (dict(icr=np.zeros((101, 4))), r"icr must have shape"),
        (dict(track_travel=np.zeros((101, 3))), r"track_travel must be finite with shape \(101, 2\)"),
        (dict(segment_starts=[101]), r"segment_starts must lie in 1..100"),
        (dict(segment_starts=[100]), "every segment needs at least 2 samples"),
        (dict(times=np.r_[np.linspace(0, 1, 50), np.linspace(0, 1, 51)]), "strictly increasing within a segment"),
    ],
)
def test_render_video_refuses_bad_input(model, tmp_path, change, match):
    t, poses = turn()
    args = dict(qpos_traj=qpos_from_poses(model, poses), times=t, out_path=tmp_path / "v.mp4")
    args.update(change)
    if not str(args["out_path"]).startswith(str(tmp_path)):
        args["out_path"] = tmp_path / args["out_path"]
    with pytest.raises(InputError, match=match):
        render_video(model, args.pop("qpos_traj"), args.pop("times"), args.pop("out_path"), **args)
    assert list(tmp_path.iterdir()) == []


def test_qpos_from_poses_refuses_a_body_without_free_joint(model):
    with pytest.raises(InputError, match="no free joint"):
        qpos_from_poses(model, np.zeros((3, 3)), body="world")


@pytest.mark.parametrize(
    "change, match",
    [
        (dict(paths={"a": np.zeros((5, 2))}), r"path 'a' must have shape \(6, 3\)"),
        (dict(paths={}), "no paths"),
        (dict(times=np.array([0, 1, 1, 2, 3, 4.0])), "strictly increasing"),
        (dict(paths={"a": np.full((6, 3), np.nan)}), "non-finite"),
        (dict(out_path="p.png"), r"must be a \.gif file"),
        (dict(max_frames=10), "frames > max_frames=10"),
    ],
)
def test_animate_paths_refuses_bad_input(tmp_path, change, match):
    args = dict(times=np.linspace(0, 5, 6), paths={"a": np.zeros((6, 3))}, out_path="p.gif", fps=10)
    args.update(change)
    args["out_path"] = tmp_path / args["out_path"]
    with pytest.raises(InputError, match=match):
        animate_paths(args.pop("times"), args.pop("paths"), args.pop("out_path"), **args)
    assert list(tmp_path.iterdir()) == []


# --- OpenGL backend selection -------------------------------------------------------------------

def test_disabled_backend_is_refused(monkeypatch):
    monkeypatch.setattr(gl, "_chosen", None)
    monkeypatch.setenv("MUJOCO_GL", "off")
    with pytest.raises(gl.RenderUnavailableError, match="disabled by MUJOCO_GL='off'"):
        gl.select_backend()


def test_no_working_backend_says_what_was_tried_and_what_to_install(monkeypatch):
    monkeypatch.setattr(gl, "_chosen", None)
    monkeypatch.delenv("MUJOCO_GL", raising=False)
    monkeypatch.setattr(gl, "CANDIDATES", ("nosuchgl",))
    with pytest.raises(gl.RenderUnavailableError, match=r"tried nosuchgl: .*nosuchgl.*apt-get install libegl1"):
        gl.select_backend()


# --- rendering ----------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def turn_video(model, backend, tmp_path_factory):
    """A 2 s video of the test turn at the default size, with trail and ICR, and its frames."""
    t, poses = turn()
    icr = np.column_stack([np.zeros_like(t), np.full_like(t, RADIUS)])
    icr[:10] = np.nan  # no ICR (e.g. straight driving) during the first 0.2 s: no marker
    out = tmp_path_factory.mktemp("video") / "turn.mp4"
    stats = render_video(model, qpos_from_poses(model, poses), t, out, fps=30, icr=icr, progress=False)
    with imageio.get_reader(out) as reader:
        meta = reader.get_meta_data()
    frames = np.stack(imageio.mimread(out))
    return stats, meta, frames


def test_video_shape_and_duration(turn_video):
    stats, meta, frames = turn_video
    assert frames.shape[1:] == (480, 640, 3)
    assert abs(len(frames) - 2.0 * 30 / 1.0) <= 1  # duration / speed * fps, within one frame
    assert len(frames) == stats.frames
    assert meta["fps"] == pytest.approx(30)
    assert meta["codec"] == "h264"


def test_video_frames_show_the_followed_robot_trail_and_icr(turn_video):
    _, _, frames = turn_video
    assert all(f.mean() > 40 for f in frames[::10])  # not black
    diffs = [np.abs(frames[k].astype(int) - frames[k + 15].astype(int)).mean() for k in range(0, 45, 15)]
    assert min(diffs) > 1.0  # the grid slides under the following camera: frames differ
    h, w = frames.shape[1:3]
    for f in (frames[0], frames[-1]):  # the following camera keeps the robot near the image centre
        red = colour_mask(f, BOX_RGBA)
        assert red.sum() > 500
        assert np.linalg.norm(centroid(red) - [w / 2, h / 2]) < 0.1 * w
    blue = [colour_mask(f, (0.05, 0.35, 0.95)).sum() for f in (frames[0], frames[-1])]
    assert blue[0] < 20 and blue[1] > 80  # the trail grows (172 px measured at the end)
    magenta = [colour_mask(f, (0.9, 0.1, 0.6)).sum() for f in (frames[0], frames[-1])]
    assert magenta[0] < 10 and magenta[1] > 50  # the ICR marker, absent while the ICR is NaN


def test_fixed_camera_sees_the_robot_move_and_speed_shortens(model, backend, tmp_path):
    t, poses = turn()
    out = tmp_path / "fixed.mp4"
    stats = render_video(model, qpos_from_poses(model, poses), t, out, width=320, height=240, fps=20,
                         speed=2.0, follow=False, trail=False, progress=False)
    frames = np.stack(imageio.mimread(out))
    assert frames.shape == (stats.frames, 240, 320, 3)
    assert abs(len(frames) - 2.0 * 20 / 2.0) <= 1
    moved = centroid(colour_mask(frames[-1], BOX_RGBA)) - centroid(colour_mask(frames[0], BOX_RGBA))
    assert np.linalg.norm(moved) > 20  # [px]
    assert [p.name for p in tmp_path.iterdir()] == ["fixed.mp4"]  # no temporary left behind


def test_frames_wider_than_the_model_buffer_leave_the_model_alone(model, backend, tmp_path):
    assert model.vis.global_.offwidth == 640
    t, poses = turn(duration=0.1, n=3)
    out = tmp_path / "wide.mp4"
    render_video(model, qpos_from_poses(model, poses), t, out, width=800, height=600, fps=20, progress=False)
    assert imageio.mimread(out)[0].shape == (600, 800, 3)
    assert model.vis.global_.offwidth == 640


def test_frames_without_antialiasing_look_alike_and_leave_the_model_alone(model, backend, tmp_path):
    t, poses = turn(duration=0.5, n=26)
    samples = model.vis.quality.offsamples
    assert samples > 0  # MuJoCo's default multisampling, which antialias=False turns off
    frames = {}
    for aa in (True, False):
        out = tmp_path / f"aa{aa:d}.mp4"
        render_video(model, qpos_from_poses(model, poses), t, out, width=320, height=240, fps=10, antialias=aa,
                     progress=False)
        frames[aa] = np.stack(imageio.mimread(out)).astype(int)
    assert model.vis.quality.offsamples == samples
    assert frames[True].shape == frames[False].shape
    diff = np.abs(frames[True] - frames[False]).max(axis=-1)
    assert diff.max() > 30  # the setting is applied: edges change
    assert np.median(diff) <= 2  # [grey levels] the rest only by the encoder's rounding
    assert (diff > 30).mean() < 0.1  # edges are a small share of the picture (4 % on the demo's 640 x 480 frames)
    for f in (frames[False][0], frames[False][-1]):  # the same picture: the robot at the image centre
        assert np.linalg.norm(centroid(colour_mask(f, BOX_RGBA)) - [160, 120]) < 0.1 * 320


def test_failure_while_rendering_leaves_no_file(model, backend, tmp_path, monkeypatch):
    from mjtrack.render import offscreen

    def boom(self, *args):
        raise RuntimeError("boom")

    monkeypatch.setattr(offscreen.OffscreenRenderer, "render", boom)
    t, poses = turn(duration=0.2, n=5)
    with pytest.raises(RuntimeError, match="boom"):
        render_video(model, qpos_from_poses(model, poses), t, tmp_path / "v.mp4", progress=False)
    assert list(tmp_path.iterdir()) == []


# --- animated plot ------------------------------------------------------------------------------

def test_animated_paths_gif_has_distinct_frames(tmp_path):
    from PIL import Image

    t, truth = turn(duration=3.0)
    model_path = truth.copy()
    model_path[:, :2] *= 0.9
    out = tmp_path / "paths.gif"
    stats = animate_paths(t, {"MuJoCo": truth, "MPP": model_path}, out, fps=5, speed=1.0,
                          footprint=(0.6, 0.4), size_px=(320, 240))
    assert stats.frames == 16  # 3 s * 5 fps + 1
    with Image.open(out) as gif:
        assert gif.n_frames == stats.frames and gif.size == (320, 240)
        frames = []
        for k in range(gif.n_frames):
            gif.seek(k)
            frames.append(np.asarray(gif.convert("RGB"), dtype=int))
    assert len({f.tobytes() for f in frames}) == len(frames)
    assert np.abs(frames[0] - frames[-1]).mean() > 0.5
    assert [p.name for p in tmp_path.iterdir()] == ["paths.gif"]


# --- belts, clock, segments ---------------------------------------------------------------------

TRACKED_XML = """
<mujoco model="belt_test">
  <worldbody>
    <light name="sun" pos="0 0 4" dir="0 0 -1" directional="true"/>
    <geom name="floor" type="plane" size="20 20 0.1" rgba="0.8 0.8 0.75 1"/>
    <body name="chassis" pos="0 0 0">
      <freejoint name="root"/>
      <geom name="hull" type="box" pos="0 0 0.15" size="0.3 0.15 0.05" rgba="0.2 0.3 0.8 1"/>
""" + "".join(
    f'      <body name="r{side}{i}" pos="{x} {y} 0.04"><geom type="sphere" size="0.04" rgba="0.1 0.9 0.1 1"/></body>\n'
    for side, y in (("l", 0.22), ("r", -0.22)) for i, x in enumerate((-0.25, -0.083, 0.083, 0.25))
) + """    </body>
  </worldbody>
</mujoco>
"""


@pytest.fixture(scope="module")
def tracked():
    return mujoco.MjModel.from_xml_string(TRACKED_XML)


def test_belt_geometry_wraps_the_rollers_of_each_side(tracked):
    belts = belt_geometry(tracked, 1, radius=0.05)
    assert [b.y for b in belts] == pytest.approx([0.22, -0.22])
    for b in belts:
        assert b.z_bottom == pytest.approx(0.0) and b.width == pytest.approx(0.08)
        assert b.x_front - b.x_rear == pytest.approx(0.58 - 0.1)  # roller extent 0.58 m minus two end radii
    assert len(roller_geoms(tracked, 1)) == 8


def test_belt_outline_is_a_closed_stadium_and_travel_moves_the_bottom_run_back():
    """Closed form of the stadium: points at arc length s; material on the bottom run moves by -travel in x."""
    b = BeltGeometry(y=0.2, x_front=0.3, x_rear=-0.1, z_bottom=0.0, radius=0.05, width=0.06)
    assert b.perimeter == pytest.approx(2 * 0.4 + 2 * math.pi * 0.05)
    s = np.linspace(0, b.perimeter, 2001)
    p, t = b.point(s)
    np.testing.assert_allclose(p[0], p[-1], atol=1e-12)  # closed
    np.testing.assert_allclose(np.linalg.norm(np.diff(p, axis=0), axis=1), s[1] - s[0], rtol=1e-3)  # unit speed
    np.testing.assert_allclose(np.linalg.norm(t, axis=1), 1.0)
    zc = b.z_bottom + b.radius  # every point is on a run or on an end circle
    on_run = np.isclose(p[:, 2], b.z_bottom) | np.isclose(p[:, 2], b.z_bottom + 2 * b.radius)
    on_arc = np.isclose(np.hypot(np.minimum(np.abs(p[:, 0] - b.x_front), np.abs(p[:, 0] - b.x_rear)), p[:, 2] - zc), b.radius)
    assert np.all(on_run | on_arc)
    q, _ = b.point(np.array([0.05, 0.1]) + 0.07)
    p2, _ = b.point(np.array([0.05, 0.1]))
    np.testing.assert_allclose(q - p2, [[-0.07, 0, 0]] * 2, atol=1e-12)


def test_track_travel_integrates_speeds_and_clock_text():
    t = np.linspace(0, 2, 41)
    travel = track_travel_from_speeds(t, np.full_like(t, 0.3), 0.5 * t)
    np.testing.assert_allclose(travel[-1], [0.6, 1.0])  # 0.3 * 2 and the integral of 0.5 t
    assert clock_text(12.34, 1.0) == "t = 12.3 s   x1.0 playback"
    assert clock_text(3.0, 0.25, "segment 2/3") == "segment 2/3   t = 3.0 s   x0.25 playback"


@pytest.fixture(scope="module")
def belt_video(tracked, backend, tmp_path_factory):
    """2 s of the tracked test robot standing still, its belts running at 0.1 m/s, two segments."""
    t = np.r_[np.linspace(0.0, 1.0, 11), np.linspace(0.0, 1.0, 11)]
    qpos = qpos_from_poses(tracked, np.zeros((22, 3)))
    travel = np.column_stack([np.r_[0.1 * t[:11], 0.1 * t[11:]]] * 2)
    out = tmp_path_factory.mktemp("belts") / "belts.mp4"
    stats = render_video(tracked, qpos, t, out, width=320, height=240, fps=10, grid=None, trail=False,
                         track_travel=travel, segment_starts=[11], azimuth=90, elevation=-15, distance=1.2,
                         progress=False)
    return stats, np.stack(imageio.mimread(out)).astype(int)


def test_belts_hide_the_rollers_and_their_grousers_move(tracked, belt_video):
    stats, frames = belt_video
    assert stats.frames == len(frames) == 2 * 11  # both segments, 1 s each at 10 fps
    assert tracked.geom_rgba[2, 3] == 1.0  # the caller's model keeps its roller colour
    green = [colour_mask(f, (0.1, 0.9, 0.1)).sum() for f in frames]
    assert max(green) < 20  # rollers hidden
    yellow = colour_mask(frames[0], (0.95, 0.75, 0.1))
    assert yellow.sum() > 100  # grousers drawn
    body = np.s_[60:, :]  # below the clock text: the robot stands still, only the grousers move
    moving = np.abs(frames[3][body] - frames[0][body]).mean()
    assert moving > 0.3
    # 0.5 s of travel later (0.05 m = one grouser pitch) the pattern is back where it was
    assert np.abs(frames[5][body] - frames[0][body]).mean() < 0.5 * moving


def test_clock_is_written_and_each_segment_restarts(belt_video):
    _, frames = belt_video
    text = np.s_[:40, :200]
    assert np.abs(frames[1][text] - frames[0][text]).mean() > 1.0  # t = 0.0 s -> 0.1 s
    # frame 11 is the second segment's t = 0: only the segment label differs from frame 0
    assert np.abs(frames[11][60:] - frames[0][60:]).mean() < 0.5
    assert np.abs(frames[11][text] - frames[0][text]).mean() > 1.0


def test_qpos_from_poses_places_height_roll_and_pitch_like_a_terrain_log(model):
    """Z-Y-X Euler angles: read back with the rollout's own yaw_of / roll_pitch_of."""
    from mjtrack.sim.rollout import roll_pitch_of, yaw_of

    poses = np.array([[1.0, 2.0, 0.7], [0.0, 0.0, -2.0], [0.5, -0.5, 3.0]])
    roll, pitch, z = np.array([0.1, -0.2, 0.0]), np.array([0.2, 0.05, -0.3]), np.array([0.3, 0.1, 0.0])
    q = qpos_from_poses(model, poses, z=z, roll=roll, pitch=pitch)
    np.testing.assert_allclose(q[:, 2], z)
    np.testing.assert_allclose(np.linalg.norm(q[:, 3:7], axis=1), 1.0)
    r, p = roll_pitch_of(q[:, 3:7])
    np.testing.assert_allclose(r, roll, atol=1e-12)
    np.testing.assert_allclose(p, pitch, atol=1e-12)
    np.testing.assert_allclose(np.unwrap(yaw_of(q[:, 3:7])), np.unwrap(poses[:, 2]), atol=1e-12)


@pytest.mark.parametrize("spec", ["incline:0.2", "step:0.04:0.6"])
def test_terrain_geoms_are_in_the_groups_the_renderer_shows(spec):
    from mjtrack.io.robot import Robot
    from mjtrack.sim.builder import build_model
    from mjtrack.sim.terrain import parse_terrain

    m = build_model(Robot(), terrain=parse_terrain(spec))
    shown = np.asarray(mujoco.MjvOption().geomgroup)
    world = [g for g in range(m.ngeom) if m.geom_bodyid[g] == 0]  # floor and terrain
    assert len(world) >= 2 or spec.startswith("incline")
    assert all(shown[m.geom_group[g]] for g in world)
    assert all(m.geom_rgba[g, 3] > 0 for g in world)


def test_icr_legend_names_each_marker_colour(model, backend, tmp_path):
    """The three ICR markers have their own colours and a legend in the top-right corner names them:
    the legend image holds each colour, and a frame rendered with labels differs from one without
    in that corner only (the camera, the scene and the markers are the same)."""
    legend = legend_image(ICR_LABELS, height_px=480)
    rgb = (legend[..., :3] * 255).astype(np.uint8)
    opaque = legend[..., 3] > 0.5
    for rgba in ICR_RGBA:  # every marker colour is drawn in the legend (its circle and line)
        assert (colour_mask(rgb, rgba[:3]) & opaque).sum() > 20, rgba
    assert (rgb[opaque].min(axis=1) > 200).mean() > 0.5  # a light box behind black text

    t, poses = turn(duration=0.2, n=11)
    icr = np.repeat([[[0.0, RADIUS, 0.0], [0.0, RADIUS + 0.3, 0.0], [0.0, RADIUS - 0.3, 0.0]]], len(t), axis=0)
    frames = {}
    for name, labels in (("plain", None), ("legend", ICR_LABELS)):
        out = tmp_path / f"{name}.mp4"
        render_video(model, qpos_from_poses(model, poses), t, out, fps=10, icr=icr, icr_labels=labels,
                     progress=False)
        frames[name] = np.stack(imageio.mimread(out)).astype(int)
    diff = np.abs(frames["legend"] - frames["plain"]).max(axis=(0, 3))  # (H, W) largest change
    h, w = legend.shape[:2]
    corner = diff[:h + 8, -(w + 8):]
    # measured 0.19 of the corner: the text, markers and box edge (the light box on the light ground
    # changes little); a missing legend gives 0
    assert (corner > 60).mean() > 0.1
    rest = diff.copy()
    rest[:h + 16, -(w + 16):] = 0  # outside the corner (with the codec's block margin)
    # elsewhere only the codec's noise: measured 0.02 % of pixels above 30 (the encoder spends its
    # bits differently), against 19 % above 60 in the corner
    assert (rest > 30).mean() < 0.002
    last = frames["legend"][-1][:h + 8, -(w + 8):].astype(np.uint8)
    for rgba in ICR_RGBA:  # the colours survive the video codec
        assert colour_mask(last, rgba[:3]).sum() > 5, rgba


@pytest.mark.parametrize("traction, side", [("tracks", "track"), ("wheels", "wheels")])
def test_video_legend_names_the_robots_own_sides(traction, side, tmp_path, monkeypatch):
    """The legend of a wheeled robot's video speaks of its wheels (the frames themselves: above)."""
    import mjtrack.render
    from mjtrack.io.robot import Robot
    from mjtrack.sim.rollout import drive_log
    from mjtrack.validate.video import render_log

    robot = Robot(traction=traction, sprocket_radius=0.1) if traction == "wheels" else Robot()
    log = drive_log(robot, (np.array([0.0]), np.array([0.3]), np.array([0.6])), duration=0.2)
    seen = {}
    monkeypatch.setattr(mjtrack.render, "render_video", lambda *a, **kw: seen.update(kw))
    render_log(log, robot, tmp_path / "v.mp4")
    assert seen["icr_labels"] == (f"ICR left {side}", f"ICR right {side}", "ICR body")


def test_an_interrupt_never_cuts_a_frame_being_written(model, backend, tmp_path, monkeypatch):
    """A signal that arrives while a frame goes to the encoder takes effect once the frame is
    written (a frame cut in half makes ffmpeg print errors beside the command's one line)."""
    import os
    import signal

    import imageio.v2 as iio

    from mjtrack import interrupts

    class Writer:  # records whether each frame was written whole
        def __init__(self):
            self.whole, self.closed = [], False

        def append_data(self, frame):
            if not self.whole:
                os.kill(os.getpid(), signal.SIGINT)  # delivered in the middle of the first write
            self.whole.append(frame.shape)

        def close(self):
            self.closed = True

    writer = Writer()
    monkeypatch.setattr(iio, "get_writer", lambda *a, **k: writer)
    t, poses = turn()
    with pytest.raises(interrupts.Interrupted):
        with interrupts.handling():
            render_video(model, qpos_from_poses(model, poses), t, tmp_path / "cut.mp4", width=64, height=48,
                         fps=10, progress=False)
    assert writer.whole == [(48, 64, 3)] and writer.closed  # the first frame whole, then stopped
    assert not (tmp_path / "cut.mp4").exists()
