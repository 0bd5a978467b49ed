"""validate on a wheeled robot: the wheeled-robot thesis's four models scored by horizon error.

The independent checks build their logs here, from the thesis's equations written out in closed
form (no code shared with mjtrack.models): on a log that is one model's exact motion, that model's
prediction error is ~0; the other models are not required to be.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from mjtrack.io.logs import DriveLog
from mjtrack.io.robot import G, Robot
from mjtrack.validate import Noise, case_from_log
from mjtrack.validate.wheeled import KEYS, evaluate_wheeled, wheeled_predictors

HUSKY = Robot(traction="wheels", track_gauge=0.555, wheelbase=0.512, sprocket_radius=0.165, track_width=0.1,
              mass=50.0, cg_z=0.2)
DT = 0.02  # [s] log sample period
EXACT_M = 1e-6  # [m] "~0": RK4 steps of a model whose exact motion the log is (round-off and O(dt^5))
EXACT_DEG = 1e-4  # [deg]


def _arc(pose, twist, dt):
    """Pose after a constant body twist (vx, vy, wz) held for dt from pose (SE(2) exponential)."""
    x, y, th = pose
    vx, vy, wz = twist
    if abs(wz) < 1e-12:
        dx, dy = vx * dt, vy * dt
    else:
        s, c = math.sin(wz * dt), math.cos(wz * dt)
        dx, dy = (s * vx - (1 - c) * vy) / wz, ((1 - c) * vx + s * vy) / wz
    ct, st = math.cos(th), math.sin(th)
    return (x + ct * dx - st * dy, y + st * dx + ct * dy, th + wz * dt)


def _log(twists, measured, commanded) -> DriveLog:
    """A log whose row k holds the twist, measured and commanded speeds of the interval after it."""
    n = len(twists)
    pose = [(0.3, -0.2, 0.4)]
    for k in range(n - 1):
        pose.append(_arc(pose[-1], twists[k], DT))
    p, tw = np.array(pose), np.array(twists)
    meas, cmd = np.array(measured), np.array(commanded)
    return DriveLog(t=np.arange(n) * DT, v_left_cmd=cmd[:, 0], v_right_cmd=cmd[:, 1], x=p[:, 0], y=p[:, 1],
                    yaw=p[:, 2], v_left=meas[:, 0], v_right=meas[:, 1], vx=tw[:, 0], vy=tw[:, 1], wz=tw[:, 2])


def _score(drive: DriveLog, robot: Robot = HUSKY, horizons=(0.5, 1.0), max_starts=6):
    case = case_from_log(drive, noise=Noise(scale=0.0))
    return evaluate_wheeled(case, drive, robot, horizons=horizons, max_starts=max_starts).metrics


def _parameters(key):
    """The parameters validate gives model ``key`` on the Husky (as its metrics report them)."""
    return next(p.parameters for p in wheeled_predictors(HUSKY) if p.key == key)


def _worst(metrics, key):
    hz = metrics["models"][key]["horizons"]
    return max(h["pos_max_m"] for h in hz.values()), max(h["yaw_max_deg"] for h in hz.values())


@pytest.fixture(scope="module")
def husky_validation(tmp_path_factory):
    from mjtrack.sim.rollout import drive_log
    from mjtrack.sim.scenarios import scenario_commands
    from mjtrack.validate import validate

    table, duration = scenario_commands("random_steps", HUSKY, duration=3.0, seed=2)
    drive = drive_log(HUSKY, table, duration=duration)
    out = tmp_path_factory.mktemp("wheeled_val")
    return validate(drive, HUSKY, out, horizons=(0.5, 1.0), quiet=True, wheeled_max_starts=3), out


def test_validate_on_a_wheeled_mujoco_log_scores_the_four_thesis_models(husky_validation):
    val, out = husky_validation
    metrics = json.loads((out / "metrics.json").read_text())
    wm = metrics["wheeled_models"]
    assert list(wm["models"]) == list(KEYS)
    for key, entry in wm["models"].items():
        assert entry["diverged_windows"] == 0, key
        assert set(entry["horizons"]) == {"0.5", "1", "2"}
        for h, row in entry["horizons"].items():
            assert row["n"] >= 1, (key, h)
            for f in ("pos_median_m", "pos_max_m", "yaw_median_deg", "yaw_max_deg"):
                assert row[f] is not None and math.isfinite(row[f]), (key, h, f)
            assert row["pos_median_m"] <= row["pos_max_m"]
    for h, best in wm["best"].items():
        assert best["position"] == min(KEYS, key=lambda k: wm["models"][k]["horizons"][h]["pos_median_m"])
    # what the description lacks is stated, per model
    assert "inertia" in wm["models"]["dynamic1"]["assumed"]
    assert "stiffness" in wm["models"]["skidsteer4"]["assumed"]
    assert wm["models"]["kinematic"]["assumed"] == {}
    assert "Wheeled-robot models" in (out / "report.html").read_text()


def test_kinematic_model_is_exact_on_a_differential_drive_log():
    """(1.1)-(1.4): wheel speeds that change every 0.5 s, each interval an exact arc of v = (V_L + V_R)/2,
    ω = (V_R − V_L)/T."""
    rng = np.random.default_rng(5)
    T = HUSKY.track_gauge
    twists, speeds = [], []
    for _ in range(8):
        vl, vr = rng.uniform(-0.8, 0.8, 2)
        twists += [((vl + vr) / 2, 0.0, (vr - vl) / T)] * 25
        speeds += [(vl, vr)] * 25
    m = _score(_log(twists, speeds, speeds))
    pos, yaw = _worst(m, "kinematic")
    assert pos < EXACT_M and yaw < EXACT_DEG
    assert m["best"]["1"]["position"] == "kinematic"


def test_skid_steer_is_exact_on_a_slow_spin_of_the_four_wheel_robot():
    """(1.16)-(1.20), slow spin V_R = −V_L = V in the linear friction range, COG at the centre: equal
    loads, the robot spins about the centre; the moment of the four forces C(V − (b/2)φ̇) at arm
    b/2 and C (a/2)φ̇ at arm a/2 vanishes at φ̇ = V (b/2)/((a/2)² + (b/2)²)."""
    a, b = HUSKY.contact_length, HUSKY.track_gauge
    V = 0.01  # [m/s] slip speeds ~0.7 V, far below the saturation speed (linear range)
    rate = V * (b / 2) / ((a / 2) ** 2 + (b / 2) ** 2)
    n = 150
    m = _score(_log([(0.0, 0.0, rate)] * n, [(-V, V)] * n, [(-V, V)] * n), horizons=(1.0, 2.0))
    assert V * 0.7 < m["slip_speed_m_s"]
    pos, yaw = _worst(m, "skidsteer4")
    assert pos < EXACT_M and yaw < EXACT_DEG
    # the no-slip kinematic model turns at 2V/b: (2V/b − φ̇)·2 s of heading error at 2 s
    kin = m["models"]["kinematic"]["horizons"]["2"]["yaw_median_deg"]
    assert kin == pytest.approx(math.degrees((2 * V / b - rate) * 2.0), rel=1e-6)


def test_dynamic2_is_exact_on_its_steady_circle():
    """(1.9)-(1.15) on a steady circle (linear friction range): the lateral forces −C v_y on both wheels
    carry the centripetal M ω v_x, so v_y = −M ω v_x/(2C); the body's x balance needs F_L + F_R = −M ω v_y,
    equal by the moment balance; each wheel turns at r ω_i = v_F,i + F_i/C and is asked for
    ω_i + r F_i/K_T (its torque K_T(ω_req − ω_i) = r F_i)."""
    p = _parameters("dynamic2")
    M, C, KT, r, b = p["mass"], p["stiffness"], p["torque_gain"], p["wheel_radius"], p["track"]
    assert p["wheel_load"] == pytest.approx(M * G / 2)
    vx, wz = 0.5, 0.4
    vy = -M * wz * vx / (2 * C)
    F = -M * wz * vy / 2
    meas = (vx - wz * b / 2 + F / C, vx + wz * b / 2 + F / C)
    cmd = tuple(v + r * r * F / KT for v in meas)
    n = 120
    m = _score(_log([(vx, vy, wz)] * n, [meas] * n, [cmd] * n), horizons=(0.5, 2.0))
    pos, yaw = _worst(m, "dynamic2")
    assert pos < EXACT_M and yaw < EXACT_DEG


def test_dynamic1_follows_its_force_limited_straight_start():
    """(1.5)-(1.8), straight: after a step of the requested speed both wheel forces saturate at F_max,
    v grows at 2 F_max/M until it reaches the request. Not exact: once |F| < F_max the regulator closes
    the last F_max r/K of speed with time constant M r/(2K) (well under a millimetre of distance here)."""
    p = _parameters("dynamic1")
    acc = 2 * p["force_max"] / p["mass"]
    v0, v1 = 0.2, 0.2 + 0.5 * acc * DT * 3  # the ramp lasts 1.5 samples: held speeds cannot follow it
    n, step = 120, 60
    t = np.arange(n) * DT
    x = np.where(t <= t[step], v0 * t, 0.0)
    tr = (v1 - v0) / acc
    after = t - t[step]
    ramp = v0 * t[step] + v0 * after + acc * after**2 / 2
    flat = v0 * t[step] + v0 * tr + acc * tr**2 / 2 + v1 * (after - tr)
    x = np.where(t <= t[step], x, np.where(after <= tr, ramp, flat))
    v = np.where(t < t[step], v0, np.minimum(v0 + acc * after, v1))
    cmd = np.where(t < t[step], v0, v1)
    drive = DriveLog(t=t, v_left_cmd=cmd, v_right_cmd=cmd, x=x, y=np.zeros(n), yaw=np.zeros(n), v_left=v, v_right=v,
                     vx=v, vy=np.zeros(n), wz=np.zeros(n))
    m = _score(drive, horizons=(0.5,), max_starts=10)  # starts every 12 samples: one at the step, one before it
    tail = p["force_max"] * p["wheel_radius"] / p["gain"] * p["mass"] * p["wheel_radius"] / (2 * p["gain"])
    pos, yaw = _worst(m, "dynamic1")
    assert pos < 2 * tail + EXACT_M and yaw < EXACT_DEG  # why 2x: the tail's distance is the speed gap x τ
    assert _worst(m, "kinematic")[0] > 10 * pos  # the held measured speeds miss the ramp


def test_validate_help_documents_the_wheeled_models():
    from support.cli import run_cli

    out = run_cli(["validate", "--help"])
    assert out.rc == 0
    text = " ".join(out.out.split())
    assert "wheel" in text and "skid" in text and "dynamic" in text


@pytest.mark.parametrize("traction, side", [("tracks", "track"), ("wheels", "wheels")])
def test_the_validate_icr_figure_names_what_carries_a_side(traction, side):
    """Made-up ICRs (no filter run): the axes' words only."""
    from types import SimpleNamespace

    import numpy as np

    from mjtrack.validate.figures import icr_figure

    t = np.linspace(0.0, 1.0, 5)
    icr = SimpleNamespace(valid=np.ones(5, bool), y_l=t + 0.3, y_r=-t - 0.3, x_c=0 * t)
    keys = ("mpp_slip_ekf", "micr_icr_ekf", "mvir_vir_filter")
    res = SimpleNamespace(case=SimpleNamespace(t=t), icr_true=icr, icrs={k: icr for k in keys},
                          predictors=[SimpleNamespace(key=k, causal=True, label=k) for k in keys])
    fig = icr_figure(res, 0.05, traction)
    assert [ax.get_ylabel() for ax in fig.axes[:2]] == [f"left-{side} ICR y_l [m]", f"right-{side} ICR y_r [m]"]
