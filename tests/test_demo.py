"""``mjtrack demo`` and ``mjtrack render``: outputs end to end, the video read back, the CLI."""

from __future__ import annotations

import json

import numpy as np
import pytest

from mjtrack.demo import DEMO_ROBOT, demo_commands, run_demo
from mjtrack.io.logs import read_log_with_robot

imageio = pytest.importorskip("imageio.v2")

DURATION = 8.0  # [s] a short demo: the full one is timed by benchmarks/bench_demo.py
FPS, SPEED = 10.0, 2.0
SIZE = (160, 120)


@pytest.fixture(scope="module")
def demo(tmp_path_factory):
    return run_demo(tmp_path_factory.mktemp("demo"), duration=DURATION, video_size=SIZE, fps=FPS, speed=SPEED,
                    quiet=True)


@pytest.fixture(scope="module")
def frames(demo):
    if demo.video is None:
        pytest.skip(f"no offscreen OpenGL backend here: {demo.video_skipped}")
    with imageio.get_reader(demo.video) as reader:
        meta = reader.get_meta_data()
    return meta, np.stack(imageio.mimread(demo.video))


def test_demo_commands_are_seeded_everyday_manoeuvres():
    a = demo_commands(DEMO_ROBOT, duration=60.0, seed=1)
    b = demo_commands(DEMO_ROBOT, duration=60.0, seed=1)
    for x, y in zip(a, b):
        np.testing.assert_array_equal(x, y)
    t, vl, vr = a
    assert t[0] == 0 and np.all(np.diff(t) >= 3.0) and t[-1] < 60.0
    v, w = (vl + vr) / 2, (vr - vl) / DEMO_ROBOT.track_gauge
    assert np.all((np.abs(v) >= 0.2) & (np.abs(v) <= 0.6))  # never a spin turn (module docstring)
    turning = w != 0
    assert np.all(np.abs(v[turning] / w[turning]) >= 0.5 - 1e-12)


def test_demo_writes_report_metrics_rollout_and_video(demo):
    for path in (demo.report, demo.metrics, demo.log):
        assert path.exists() and path.parent == demo.out_dir
    drive, robot = read_log_with_robot(demo.log)
    assert robot.cg_x == pytest.approx(0.05)
    assert drive.duration == pytest.approx(DURATION, abs=0.05)
    doc = json.loads(demo.metrics.read_text())
    assert doc["headline"] == demo.headline
    assert set(doc["headline"]["pos_rmse_m"]) == {"log", "mpp"}
    assert set(demo.stage_s) == {"rollout", "validate", "video"}
    stages = demo.stage_s
    if demo.video_concurrent:  # the video was made beside the validation: the wall time holds the longer
        assert demo.wall_s >= (stages["rollout"] + max(stages["validate"], stages["video"])) * 0.99
    else:
        assert demo.wall_s >= sum(stages.values()) * 0.99
    assert [line.split(":")[0] for line in demo.ran] == ["rollout", "validate", "video"]
    frames = int(np.floor(DURATION * FPS / SPEED)) + 1
    assert f"{frames} frames of {SIZE[0]}x{SIZE[1]}" in demo.ran[2]


def test_video_shape_and_duration(demo, frames):
    meta, f = frames
    assert f.shape[1:] == (SIZE[1], SIZE[0], 3)
    expected = int(np.floor(DURATION * FPS / SPEED)) + 1  # render_video's frame times
    assert abs(len(f) - expected) <= 1
    assert meta["fps"] == pytest.approx(FPS)
    assert len(f) / FPS == pytest.approx(DURATION / SPEED, abs=1.5 / FPS)


def test_video_frames_are_neither_black_nor_identical(frames):
    _, f = frames
    assert all(frame.mean() > 40 for frame in f[:: max(1, len(f) // 8)])
    assert all(frame.std() > 5 for frame in f[:: max(1, len(f) // 8)])  # not a flat colour
    diffs = [np.abs(f[k].astype(int) - f[k + 5].astype(int)).mean() for k in range(0, len(f) - 5, 5)]
    assert min(diffs) > 0.5  # the grid slides under the following camera while the robot drives


# -- command line ----------------------------------------------------------------------------
@pytest.fixture
def cli(monkeypatch):
    import mjtrack.cli
    from support.cli import run_cli

    for name in ("validate", "render", "demo"):
        monkeypatch.setitem(mjtrack.cli.COMMANDS, name, name)
    return run_cli


def test_cli_render_a_log_with_gif(cli, demo, tmp_path):
    if demo.video is None:
        pytest.skip(f"no offscreen OpenGL backend here: {demo.video_skipped}")
    from PIL import Image

    out, gif = tmp_path / "v.mp4", tmp_path / "paths.gif"
    res = cli(["render", demo.log, "--out", out, "--width", "96", "--height", "64", "--fps", "5", "--speed", "4",
               "--gif", gif, "--quiet"])
    assert res.rc == 0, res.err
    video = np.stack(imageio.mimread(out))
    assert video.shape == (int(DURATION * 5 / 4) + 1, 64, 96, 3)
    with Image.open(gif) as g:
        assert g.n_frames > 5


def test_cli_render_refuses_bad_input(cli, demo, tmp_path):
    from support.cli import assert_usage_error

    res = cli(["render", demo.log, "--out", tmp_path / "v.mp4", "--width", "101"])
    assert res.rc == 2 and "even" in res.err
    assert_usage_error(cli(["render", demo.log, "--out", tmp_path / "v.avi"]), r"\.mp4")
    assert_usage_error(cli(["render", demo.log, "--out", tmp_path / "v.mp4", "--gif", tmp_path / "p.png"]), r"\.gif")
    assert_usage_error(cli(["render", demo.log, "--out", tmp_path / "v.mp4", "--speed", "0"]), "--speed")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.slow
def test_cli_demo_end_to_end(cli, tmp_path):
    res = cli(["demo", "--out", tmp_path / "d", "--quiet"])
    assert res.rc == 0, res.err
    for name in ("report.html", "metrics.json", "rollout.csv", "rollout.json"):
        assert (tmp_path / "d" / name).exists()
        assert name in res.out
    assert "2-s position RMSE" not in res.out  # --quiet keeps only where the outputs are


@pytest.mark.slow  # a second whole demo run; the default demo test stays in the default run
def test_demo_on_terrain_records_it_and_logs_height(tmp_path):
    from mjtrack.sim.terrain import parse_terrain

    res = run_demo(tmp_path / "d", duration=4.0, video=False, quiet=True, terrain=parse_terrain("incline:0.1"))
    drive, robot = read_log_with_robot(res.log)
    assert robot.extra["terrain"]["spec"] == "incline:0.1"
    assert drive.z is not None and np.ptp(drive.z) > 0.01  # it drove up or down the slope


@pytest.mark.slow  # two more demos; the first renders in this process, which a forked worker would hang on
def test_video_beside_the_validation_changes_no_output(tmp_path):
    runs = {w: run_demo(tmp_path / f"w{w}", duration=4.0, video_size=SIZE, fps=FPS, speed=SPEED, quiet=True,
                        workers=w) for w in (1, 2)}
    assert not runs[1].video_concurrent and runs[2].video_concurrent == (runs[2].video is not None)
    for name in ("rollout.csv", "rollout.json", "metrics.json"):
        assert (tmp_path / "w1" / name).read_bytes() == (tmp_path / "w2" / name).read_bytes(), name
    if runs[1].video is None:
        pytest.skip(f"no offscreen OpenGL backend here: {runs[1].video_skipped}")
    one, two = (np.stack(imageio.mimread(runs[w].video)) for w in (1, 2))
    np.testing.assert_array_equal(one, two)  # the same frames: the worker renders the written rollout


def test_bench_demo_sums_the_profile_into_parts():
    from support.repo import load_benchmark

    bench = load_benchmark("bench_demo")
    functions = [  # (file, line, function, cumulative seconds, calls), as the benchmark's child reports them
        ["/x/mjtrack/sim/builder.py", 10, "build_model", 2.0, 3],
        ["/x/other/builder.py", 1, "build_model", 100.0, 1],  # another package's function of that name
        ["/x/mjtrack/estimation/slip_ekf.py", 5, "run_slip_ekf", 4.0, 2],
        ["/x/mjtrack/estimation/icr_ekf.py", 5, "run_icr_ekf", 3.0, 2],
        ["/x/mjtrack/estimation/vir_filter.py", 5, "run_vir_filter", 1.0, 2],
        ["/x/mjtrack/validate/evaluate.py", 99, "evaluate_case", 10.0, 2],
        ["~", 0, "<built-in method mujoco._render.mjr_render>", 1.5, 100],
        ["~", 0, "<built-in method mujoco._render.mjr_readPixels>", 2.5, 100],
        ["/x/mjtrack/render/decor.py", 1, "draw_belt", 0.7, 200],
        ["/x/mjtrack/render/decor.py", 1, "draw_grid", 0.3, 100],
    ]
    out = bench.profile_parts(functions)
    parts = out["parts_s"]
    assert parts["compile MuJoCo models"] == 2.0
    assert parts["slip EKF (MPP)"] == 4.0 and parts["rollout"] == 0
    assert parts["scoring the predictors"] == pytest.approx(2.0)  # 10 s less the three filters' 8 s
    assert parts["render frames (OpenGL)"] == 4.0
    assert parts["decorations (grid, trail, belts, ICRs)"] == pytest.approx(1.0)
    assert out["frames"] == 100 and out["render_ms_per_frame"] == pytest.approx(40.0)
    assert out["decorations_ms_per_frame"] == pytest.approx(10.0)
