"""Issue 7, tracked-robot part: compensation maps, the online estimator, the MuJoCo loop, `mjtrack track`."""

import json
import math

import numpy as np
import pytest

from mjtrack.control.compensation import (
    SlipCompensation,
    cross_track_errors,
    heading_correction,
    inverse_micr,
    run_tracking,
    scenario_reference,
    track_speeds_from_psi,
)
from mjtrack.control.interface import TrackSpeedAdapter
from mjtrack.errors import InputError
from mjtrack.estimation import icr_from_psi, run_icr_ekf
from mjtrack.estimation.icr_ekf import InverseICR
from mjtrack.estimation.online import OnlineICREstimator
from mjtrack.geometry import se2_step
from mjtrack.io.robot import Robot
from mjtrack.models import MICR
from mjtrack.models.kinematic import integrate


# --- compensation maps -------------------------------------------------------------------

@pytest.mark.parametrize("icr", [(0.3, -0.25, 0.08), (-0.1, -0.5, -0.05), (0.2, 0.6, 0.0)])
def test_inverse_micr_round_trip(icr, rng):
    """MICR(twist(inverse(v, w))) = (v, -x_c w, w), also for y_l - y_r < 0, and the psi form agrees."""
    m = MICR(*icr)
    psi = InverseICR.from_icr(*icr).params
    for v, w in rng.uniform(-1, 1, (5, 2)):
        u = inverse_micr(v, w, icr[0], icr[1])
        np.testing.assert_allclose(m.twist(*u), [v, -icr[2] * w, w], atol=1e-12)
        np.testing.assert_allclose(track_speeds_from_psi(v, w, psi), u, atol=1e-12)


def test_nominal_icrs_reduce_to_the_track_speed_adapter():
    T = 0.4
    for v, w in [(0.5, 0.3), (-0.2, 1.0), (0.0, -0.7)]:
        np.testing.assert_allclose(inverse_micr(v, w, T / 2, -T / 2), TrackSpeedAdapter(T)(v, w), atol=1e-15)
    comp = SlipCompensation(T, "none")
    np.testing.assert_allclose(comp.track_speeds(0.5, 0.3), TrackSpeedAdapter(T)(0.5, 0.3))
    with pytest.raises(InputError):
        inverse_micr(1.0, 1.0, 0.2, 0.2)
    with pytest.raises(InputError):
        SlipCompensation(T, "wheels")


def test_heading_correction_makes_the_centre_move_along_the_path():
    """(2.21): heading theta_d + alpha with v_x = V cos(alpha), v_y = -x_o w gives course theta_d."""
    for x_o, V, w in [(0.1, 0.5, 0.33), (-0.05, 0.3, -0.8), (0.0, 1.0, 2.0)]:
        a = heading_correction(x_o, V, w)
        vx, vy = V * math.cos(a), -x_o * w
        assert math.isclose(a + math.atan2(vy, vx), 0.0, abs_tol=1e-12)
        assert math.isclose(math.hypot(vx, vy), V, rel_tol=1e-12)
    assert heading_correction(0.1, 0.0, 1.0) == 0.0
    assert heading_correction(10.0, 0.1, 1.0) == 0.5  # clipped to max_alpha


# --- online estimator --------------------------------------------------------------------

def _kinematic_log(truth, rng, n=300, dt=0.04):
    t = np.arange(n) * dt
    vl = np.where(t < 6, 0.3, 0.6) + 0.05 * np.sin(t)
    vr = np.where(t < 6, 0.7, 0.2) + 0.05 * np.cos(t)
    p = integrate(truth, np.zeros(3), t, vl, vr)
    # the twist measured at t_k is produced by the command held over [t_{k-1}, t_k)
    tw = truth.twist(np.r_[vl[0], vl[:-1]], np.r_[vr[0], vr[:-1]])
    return t, vl, vr, p + rng.normal(size=p.shape) * 0.01, tw + rng.normal(size=tw.shape) * 0.02


def test_online_estimator_reproduces_the_batch_filter_step_by_step(rng):
    """Pose-only: the online steps with u_{k-1} are exactly run_icr_ekf (same transition, update)."""
    truth = MICR(0.26, -0.24, 0.07)
    t, vl, vr, pose, _ = _kinematic_log(truth, rng)
    kw = dict(pose_std=(0.01, 0.01, 0.01), psi_std0=(0.5, 0.5, 1.0), q_psi_std=(0.01, 0.01, 0.01))
    batch = run_icr_ekf(t, vl, vr, track_gauge=0.4, pose_meas=pose, **kw)
    est = OnlineICREstimator(0.4, **kw)
    est.reset(t[0], pose[0])
    for k in range(1, t.size):
        est.step(t[k], vl[k - 1], vr[k - 1], pose=pose[k])
        np.testing.assert_allclose(est.s, batch.x_post[k - 1], rtol=1e-10, atol=1e-12)


def test_online_estimator_recovers_known_icrs_both_turn_directions(rng):
    truth = MICR(0.26, -0.24, 0.07)
    t, vl, vr, pose, twist = _kinematic_log(truth, rng)
    est = OnlineICREstimator(0.4)
    est.reset(t[0], pose[0])
    for k in range(1, t.size):
        est.step(t[k], vl[k - 1], vr[k - 1], pose=pose[k], twist=twist[k])
    np.testing.assert_allclose(est.icr(), (0.26, -0.24, 0.07), atol=0.01)
    x_o, y_o, tv = est.virtual_robot()
    np.testing.assert_allclose(icr_from_psi(est.psi), est.icr())
    assert math.isclose(y_o + tv / 2, est.icr()[0]) and math.isclose(x_o, est.icr()[2])


def test_online_estimator_refuses_bad_use():
    est = OnlineICREstimator(0.4)
    with pytest.raises(InputError):
        est.step(0.1, 0.1, 0.2, pose=np.zeros(3))
    est.reset(0.0, np.zeros(3))
    with pytest.raises(InputError):
        est.step(0.0, 0.1, 0.2, pose=np.zeros(3))


def test_compensation_on_a_kinematic_slipping_robot_removes_the_drift():
    """Open-loop feed-forward on an MICR truth with x_c = 0: icr compensation tracks a circle, none does not."""
    truth = MICR(0.3, -0.3, 0.0)
    T, dt, v, w = 0.4, 0.04, 0.5, 0.5
    errs = {}
    for mode in ("none", "icr"):
        comp = SlipCompensation(T, mode, estimator=OnlineICREstimator(T, psi_std0=(0.2, 0.2, 0.5)))
        pose, u = np.array([0.0, -1.0, 0.0]), np.zeros(2)
        for k in range(int(12.0 / dt)):
            comp.observe(k * dt, u, pose, truth.twist(*u))
            u = comp.track_speeds(v, w)
            pose = se2_step(pose, truth.twist(*u), dt)
        errs[mode] = abs(math.hypot(pose[0], pose[1]) - 1.0)
    assert errs["none"] > 0.1
    assert errs["icr"] < 0.02


# --- MuJoCo loop and tracking ------------------------------------------------------------

def test_mujoco_loop_reports_in_the_pose0_frame_and_matches_a_rollout():
    from mjtrack.control.mujoco_plant import run_mujoco_loop
    from mjtrack.sim.rollout import drive_log

    robot = Robot()
    pose0 = np.array([1.0, 2.0, 0.7])
    res = run_mujoco_loop(robot, lambda t, p, tw, u, ts: (0.3, 0.5), 2.0, control_dt=0.04, pose0=pose0)
    np.testing.assert_allclose(res.poses[0], pose0, atol=1e-3)
    log = drive_log(robot, (np.array([0.0]), np.array([0.3]), np.array([0.5])), duration=2.0, log_rate=25.0)
    np.testing.assert_allclose(res.twists[-1], [log.vx[-1], log.vy[-1], log.wz[-1]], atol=1e-6)
    # the displacement seen in the rollout's frame, rotated into pose0's frame
    from mjtrack.geometry import compose, relative_pose

    p_log = compose(pose0, relative_pose(np.array([log.x[0], log.y[0], log.yaw[0]]), np.array([log.x[-1], log.y[-1], log.yaw[-1]])))
    np.testing.assert_allclose(res.poses[-1], p_log, atol=1e-6)


def test_cross_track_error_of_points_off_a_circle():
    ref = scenario_reference("circle")
    pts = np.array([[0.0, 0.0], [1.1, 0.0], [0.0, -1.0]])
    np.testing.assert_allclose(cross_track_errors(ref, pts), [1.0, 0.1, 0.0], atol=1e-4)


def test_windowed_cross_track_error_ignores_the_other_branch_of_a_figure_eight():
    """At the crossing of the figure-eight, a point 0.1 m off the branch being driven is 0.1 m off,
    although it is nearer to the other branch."""
    ref = scenario_reference("figure_eight")
    t = 0.5 * ref.path.length / ref.profile.speed_value  # one of the two laps: back at the crossing, heading +45 deg
    s_pose = ref.at(t).pose
    normal = np.array([-math.sin(s_pose[2]), math.cos(s_pose[2])])  # along the other branch (heading 135 deg)
    p = s_pose[:2] + 0.1 * normal
    windowed = cross_track_errors(ref, p[None], t=np.array([t]))[0]
    nearest = cross_track_errors(ref, p[None])[0]
    assert math.isclose(windowed, 0.1, abs_tol=1e-3)
    assert nearest < 0.09


def test_compensated_figure_eight_halves_the_cross_track_error():
    """Issue 7 acceptance: mu 0.4, cg 0.1 L forward, figure-eight at 0.5 m/s, same tracker and gains."""
    robot = Robot(mu=0.4, cg_x=0.1 * Robot().track_length)
    none = run_tracking(robot, compensation="none").metrics["rms_cross_track_m"]
    vir = run_tracking(robot, compensation="vir").metrics["rms_cross_track_m"]
    assert vir <= 0.5 * none, (vir, none)


@pytest.mark.slow
def test_icr_feedforward_alone_improves_every_seed():
    robot = Robot(mu=0.4, cg_x=0.05)
    for seed in range(3):
        none = run_tracking(robot, compensation="none", seed=seed).metrics["rms_cross_track_m"]
        icr = run_tracking(robot, compensation="icr", seed=seed).metrics["rms_cross_track_m"]
        assert icr < 0.9 * none


# --- command ------------------------------------------------------------------------------

@pytest.fixture
def cli(monkeypatch):
    from mjtrack import cli as cli_mod

    monkeypatch.setitem(cli_mod.COMMANDS, "track", "track")
    from cli_helpers import run_cli

    return run_cli


def test_track_command_writes_json_and_figure(cli, tmp_path):
    out = tmp_path / "run"
    res = cli(["track", "--scenario", "circle", "--laps", "0.3", "--compensation", "icr", "--mu", "0.4", "-q", "--out", out])
    assert res.rc == 0, res.err
    doc = json.loads((out / "tracking.json").read_text())
    for key in ("rms_cross_track_m", "max_cross_track_m", "final_pos_err_m"):
        assert math.isfinite(doc[key]) and doc[key] >= 0
    assert doc["settings"]["compensation"] == "icr" and doc["robot"]["mu"] == 0.4
    assert (out / "tracking.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("argv", [["--compensation", "magic"], ["--control-rate", "7"], ["--speed", "-1"]])
def test_track_command_bad_input_exits_2(cli, tmp_path, argv):
    res = cli(["track", "--scenario", "circle", "--laps", "0.1", "-q", "--out", tmp_path / "x", *argv])
    assert res.rc == 2
