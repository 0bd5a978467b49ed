"""The MuJoCo robot calibrated on three real robots' logs: Marmotte (tracked), Husky and Warthog
(wheeled skid-steer), from the DRIVE data in ../shared/data/ (BSD-3; see each folder's README).

    python benchmarks/real_robots.py [--robots marmotte,husky,warthog] [--rollers 6] [--diagnose]
    python benchmarks/real_robots.py --diagnose-only        # diagnose the stored calibrated robots
    python benchmarks/real_robots.py --starts --robots marmotte [--rounds 8]  # two starting descriptions, one answer?
    python benchmarks/real_robots.py --shear-scan 0,0.05,0.1,0.2 --robots husky,warthog  # the shear ground alone
    python benchmarks/real_robots.py --class-scatter --robots marmotte,husky,warthog  # a class median's own scatter

For each robot: its log's description plus the public specification of what the log does not give
(every such value named, with its source, under ``assumed`` in calibration.json), calibrated with
calibrate's default candidates on the first part of the log and scored on the next part, never
fitted: Marmotte trains on the first 50 % of its windows and tests on the next 20 %; Husky and
Warthog train on the first 70 % and test on the remaining 30 % of what the shared folder holds.
Each fit uses 150 windows spread over the training part (``FIT_WINDOWS``; calibrate's default is
fewer, to bound a user's time; these are the reference results, and precision is their point).
Every robot is calibrated with calibrate's default drive input (``auto``), whose choice and reason
each calibration.json records. It chooses ``fitted`` for the Husky and the Warthog: their own
speed controllers cap and reshape the DRIVE protocol's commands (``command_following`` in the
result: once settled, the measured track speeds differ from the commands by a large share of
them), so the drivetrain (lag, dead time, speed and acceleration limits, the controller's turn and
mean-speed stages) is first fitted to the measured track speeds, then the contact and the
effective rolling radius to the poses under the speeds the drivetrain predicts; the calibrated
robot predicts from commands. For the Marmotte it chooses ``commanded``.
Writes benchmarks/results/real_robots.json: per robot the held-out 2 s position error before and
after, the steady-turn yaw ratio measured and simulated (before, after) on the test part, every
candidate's value, interval and whether the log determines it, the causes and the summary; the
calibrated robot.json and calibration.json go to benchmarks/results/real_robots/. With
``--diagnose`` the test part then goes through ``diagnose --baseline mujoco`` against the calibrated
robot (what the calibrated simulation still gets wrong), recorded under ``diagnose``. Prints the
same and the machine's load.

``--starts``: does the answer hang on the start? Each robot calibrated, with calibrate's defaults (as
a user runs it: its default windows; ``--rounds N`` gives the fit more rounds to settle) and the
drive input of the reference run above (``fitted`` for Husky and Warthog, the commands for
Marmotte), from two descriptions: the log's own as
shipped (gauge and sprocket radius; every other key a default) and the starting robot above (the
public specification), on the same split, with the first 70 % of the log for training and the rest
for testing. Per parameter both values and intervals, and whether each value lies in the other's
interval where both are determined (a drive force limit per kilogram of each description's mass,
which the log does not determine: the log fixes how fast the drives can speed the robot up, not
the force; a value beyond the other description's search range, which follows its geometry, compared
with the nearest end of that range, the closest the other fit could come), and the weaker reading
beside it: whether their difference lies within its own 95 % interval, the half-widths added in
quadrature; and, since the turn candidates are fixed together by the steady turns rather than one
by one (their intervals wide), whether the two calibrated robots turn alike: per turn class with
enough steady test windows, their yaw ratios within 0.03 of each other; the causes, summaries
and held-out errors of both. Writes
benchmarks/results/start_independence.json; ``--starts --agreement-only`` recomputes the
agreement of the stored file with the rule now.

``--advance-speeds S``: the reference calibrations above with each log's measured track speeds taken
S seconds later than logged (:func:`advance_speeds`), as if their clock had dated them S late: does
setting the wheel speeds' clock by the gyro's (benchmarks/peers.py, ``gyro_evidence``) change what
the contact fit finds? Written to real_robots_advanced.json and real_robots_advanced/NAME/.
``--shear-scan K,K,...``: what the shear ground alone does to a real robot, with nothing fitted to
its poses. For each modulus K (0: Coulomb) the starting robot above on the shear ground of modulus
K, scored on the test part of the reference split as calibrate scores a description before it fits
anything ("before": the drives, with calibrate's default drive input (``fitted`` for the Husky and the
Warthog), fitted to the measured track speeds,
the contact as described): the held-out 2 s position error, and per turn class the steady yaw
ratio and the forward speed ratio, measured and simulated. The scores are calibrate's "before" of
a calibration of ``cg_y`` alone, which does not depend on what the calibration then fits. Writes
benchmarks/results/shear_scan.json.

``--class-scatter``: how far a turn class's measured steady yaw ratio moves from one stretch of a
log to the next, with nothing simulated. Each log cut into ``SCATTER_PARTS`` consecutive parts
of equal segment counts; per part and class the median yaw ratio of its steady turns and their
number (:func:`mjtrack.calibrate.measures.turn_measures`, the windows calibrate scores), and per
class the standard deviation of the medians of the parts with at least ``SCATTER_MIN`` such turns:
the scatter a class median of that many turns has on this log before any model is asked to follow
it. Writes benchmarks/results/yaw_class_scatter.json.
"""

from __future__ import annotations

import argparse
import math
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

from mjtrack.calibrate.params import default_names, specs_for
from mjtrack.calibrate.result import write_outputs
from mjtrack.calibrate.run import calibrate
from mjtrack.io import read_log_with_robot
from mjtrack.io.robot import Robot, read_robot
from mjtrack.windows import left_out_counts

HERE = Path(__file__).resolve().parent
DATA = HERE.parents[1] / "shared" / "data"
RESULT = HERE / "results" / "real_robots.json"
STARTS_RESULT = HERE / "results" / "start_independence.json"
SCAN_RESULT = HERE / "results" / "shear_scan.json"
SCATTER_RESULT = HERE / "results" / "yaw_class_scatter.json"
SCATTER_PARTS = 10  # consecutive parts of each log (--class-scatter)
SCATTER_MIN = 10  # steady turns a part's class needs to count in the scatter
STARTS_SPLIT = (0.7, 0.3)  # the held-out split of --starts, the same for every robot
OUTPUTS = HERE / "results" / "real_robots"

SUBT = "osrf/subt submitted_models/ctu_cras_norlab_marmotte_sensor_config_1"
HUSKY = "husky/husky_description urdf/husky.urdf.xacro"
WARTHOG = "warthog-cpr/warthog warthog_description/urdf/warthog_params.xacro"
FIT_WINDOWS = 150  # windows each fit uses (module docstring)
ROBOTS = {
    "marmotte": {
        "log": DATA / "marmotte" / "marmotte_boreal.csv", "split": (0.5, 0.2),
        "public": {
            "mass": (52.0, f"public specification, about 52 kg ({SUBT}/specifications.md)"),
            "track_length": (0.72, f"public model: road wheels at x = +-0.36 m, contact 0.72 m ({SUBT}/model.sdf)"),
            "cg_x": (0.016, f"public model: 10.4 kg sensor rack 0.08 m ahead of the 41 kg chassis ({SUBT}/model.sdf)"),
            "cg_z": (0.155, f"public model: wheel centres 0.129 m above ground, rack 0.13 m higher ({SUBT}/model.sdf)"),
            "mu": (0.5, "no public value: start value"),
        }},
    "husky": {
        "log": DATA / "husky" / "husky_drive.csv", "split": (0.7, 0.3),
        "public": {
            "mass": (50.0, "public specification of the Clearpath Husky A200, 50 kg"),
            "wheelbase": (0.512, f"public model: wheelbase 0.512 m ({HUSKY})"),
            "cg_z": (0.2, "assumed: about the height of the chassis' middle"),
            "mu": (0.5, "no public value: start value"),
        }},
    "warthog": {
        "log": DATA / "warthog" / "warthog_drive.csv", "split": (0.7, 0.3),
        "public": {
            "mass": (260.0, f"public model: chassis 100 kg + two rocker units 50 kg + four wheels 15 kg ({WARTHOG})"),
            "wheelbase": (0.92, f"public model: axles at +-0.46 m ({WARTHOG})"),
            "cg_x": (-0.015, f"public model: the chassis 0.04 m behind the axles' centre ({WARTHOG})"),
            "cg_z": (0.35, "assumed: about the height of the chassis' middle"),
            "mu": (0.5, "no public value: start value"),
        }},
}


#: --advance-speeds: the measured track speeds taken this many seconds later than logged (0: as logged)
ADVANCE_S = 0.0


def advance_speeds(log, seconds: float):
    """``log`` with each measured track speed replaced by the one logged ``seconds`` later (rounded to
    whole samples) in its segment, NaN where the segment has none: a log whose speeds were dated
    that much late, dated right."""
    k = int(round(seconds / float(np.median(np.diff(log.t)))))
    seg = np.zeros(len(log.t), int) if log.window is None else np.asarray(log.window)
    i = np.arange(len(log.t)) + k
    ok = (i >= 0) & (i < len(log.t))
    ok[ok] &= seg[i[ok]] == seg[ok]
    j = np.clip(i, 0, len(log.t) - 1)
    return log.replace(**{c: np.where(ok, getattr(log, c)[j], np.nan) for c in ("v_left", "v_right")})


def read(spec: dict):
    """The robot's log and description (:data:`ADVANCE_S` applied to its measured speeds)."""
    log, base = read_log_with_robot(spec["log"])
    return (advance_speeds(log, ADVANCE_S) if ADVANCE_S else log), base


def split(log, first: float, second: float):
    """Rows of the first ``first`` share of the segments, and of the next ``second`` share."""
    sl = log.segment_slices()
    n = len(sl)
    a, b = int(round(first * n)), min(n, int(round((first + second) * n)))
    return log.slice(sl[0].start, sl[a - 1].stop), log.slice(sl[a].start, sl[b - 1].stop)


def starting_robot(base: Robot, public: dict) -> Robot:
    d = base.to_dict()
    for k, (v, why) in public.items():
        d[k] = v
        d[f"source_{k}"] = why
    for k in ("mu_left", "mu_right"):
        d.pop(k, None)
    return Robot.from_dict(d, source="starting robot")


def command_following(log) -> dict:
    """How far the measured track speeds are from the commands once a command has settled (the
    second half of every window, where the DRIVE protocol's command has held for at least 1 s):
    the RMS difference over the RMS command, for the mean and the difference of the two tracks.
    Near 0: the drives follow their commands; near 1: they do something else."""
    ok = np.isfinite(log.v_left) & np.isfinite(log.v_right)
    late = np.zeros_like(ok)
    for sl in log.segment_slices():
        t = log.t[sl]
        late[sl] = t - t[0] >= 0.5 * (t[-1] - t[0])
    ok &= late
    c = np.stack([log.v_left_cmd[ok], log.v_right_cmd[ok]], -1)
    m = np.stack([log.v_left[ok], log.v_right[ok]], -1)
    rel = lambda a, b: float(np.sqrt(np.mean((a - b) ** 2)) / max(np.sqrt(np.mean(b ** 2)), 1e-12))
    return {"rows": int(ok.sum()), "mean_speed": rel(m.mean(1), c.mean(1)),
            "speed_difference": rel(m[:, 1] - m[:, 0], c[:, 1] - c[:, 0])}


def kinematic_model(train, train_ws, test, test_ws, gauge: float) -> dict:
    """A planar kinematic model driven by the measured track speeds, on the same windows as the
    calibration: body speed v = k (v_L + v_R) / 2, yaw rate k (v_R - v_L) / (a T), lateral speed -x_c
    times the yaw rate (the ICR model of an effective gauge a T, a speed scale k and an ICR offset
    x_c), each row's speeds held to the next row, integrated from each window's measured start pose
    and scored as calibrate scores (RMS position error at the window's end). ``fitted_on_train``: k,
    a, x_c fitted on the training windows and scored on the test windows, a baseline to beat;
    ``fitted_on_test``: fitted on the test windows themselves, a bound no model of this family can
    beat there."""
    from scipy.optimize import least_squares

    from mjtrack.windows import window_errors

    def errors(lg, ws, p):
        n = ws.ends - ws.starts
        K, M = int(n.max()) + 1, len(ws)
        vl = np.where(np.isfinite(lg.v_left), lg.v_left, lg.v_left_cmd)
        vr = np.where(np.isfinite(lg.v_right), lg.v_right, lg.v_right_cmd)
        k, a, xc = p
        out = np.full((1, M, K, 3), np.nan)
        for j, (s, e) in enumerate(zip(ws.starts, ws.ends)):
            dt = np.diff(lg.t[s:e + 1])
            v = k * 0.5 * (vl[s:e] + vr[s:e])
            w = k * (vr[s:e] - vl[s:e]) / (a * gauge)
            yaw = lg.yaw[s] + np.concatenate([[0.0], np.cumsum(w * dt)])
            vy = -xc * w
            c, si = np.cos(yaw[:-1]), np.sin(yaw[:-1])
            x = lg.x[s] + np.concatenate([[0.0], np.cumsum((v * c - vy * si) * dt)])
            y = lg.y[s] + np.concatenate([[0.0], np.cumsum((v * si + vy * c) * dt)])
            out[0, j, :e - s + 1] = np.column_stack([x, y, yaw])
        return window_errors(lg, ws, out)[0][:, :2]

    def fitted(lg, ws):
        return least_squares(lambda p: errors(lg, ws, p).ravel(), [1.0, 1.0, 0.0],
                             bounds=([0.3, 0.3, -2.0], [3.0, 5.0, 2.0])).x

    def scored(p):
        r = errors(test, test_ws, p)
        return {"rms": float(np.sqrt(np.mean(np.sum(r ** 2, 1)))), "speed_scale": float(p[0]),
                "gauge_factor": float(p[1]), "icr_x": float(p[2]), "windows": len(test_ws)}

    return {"model": "v = k (v_L + v_R)/2, yaw rate k (v_R - v_L)/(a T), lateral -x_c yaw rate, driven by the "
                     "measured track speeds",
            "fitted_on_train": scored(fitted(train, train_ws)), "fitted_on_test": scored(fitted(test, test_ws))}


#: |turn ratio| classes of :func:`yaw_by_sample` (calibrate's sharp class split at 0.75: a pivot apart)
SAMPLE_CLASSES = ((0.15, 0.5), (0.5, 0.75), (0.75, 1.0))
SAMPLE_MIN_WZ = 0.3  # [rad/s] ideal yaw rate below which a sample is not counted (calibrate's steady-turn floor)


def yaw_by_sample(lg, ws, gauge: float, measured: tuple, simulated: tuple) -> list[dict]:
    """The yaw ratio over every sample of the windows, not only their steady turns: per |turn ratio|
    class (of the measured track speeds, so that both count the same samples) the least-squares gain
    of the yaw rate on the ideal one, (v_R - v_L) / T, each of its own speeds -- measured (poses,
    speeds) and simulated (poses, speeds), arrays (M, K, 3) and (M, K, 2) of the windows."""
    cols = {"measured": ([], []), "simulated": ([], [])}
    rho_all = []
    for j in range(len(ws)):
        n = int(ws.ends[j] - ws.starts[j]) + 1
        t = lg.t[ws.starts[j]:ws.ends[j] + 1]
        vm = measured[1][j, :n]
        rho_all.append((vm[:, 1] - vm[:, 0]) / np.maximum(np.abs(vm).sum(axis=1), 1e-9))
        for key, (poses, speeds) in (("measured", measured), ("simulated", simulated)):
            cols[key][0].append(np.gradient(poses[j, :n, 2], t))
            cols[key][1].append((speeds[j, :n, 1] - speeds[j, :n, 0]) / gauge)
    rho = np.abs(np.concatenate(rho_all))
    w = {k: (np.concatenate(a), np.concatenate(b)) for k, (a, b) in cols.items()}
    out = []
    for lo, hi in SAMPLE_CLASSES:
        m = (rho >= lo) & ((rho < hi) | (hi >= 1.0)) & (np.abs(w["measured"][1]) >= SAMPLE_MIN_WZ)
        for key in w:
            m &= np.isfinite(w[key][0]) & np.isfinite(w[key][1])
        row = {"turn_class": [lo, hi], "samples": int(m.sum())}
        for key, (wz, ideal) in w.items():
            row[key] = float(wz[m] @ ideal[m] / (ideal[m] @ ideal[m])) if m.any() else None
        out.append(row)
    return out


def context_of_stored(name: str, spec: dict, *, rollers: int, worst: int = 10) -> dict:
    """What puts a stored calibration's test error in context, on the windows it scored (the same
    split, the same windows left out): ``kinematic`` (:func:`kinematic_model`); ``start_at_rest``: the
    described robot's test error with every window started with the body at rest instead of the
    twist estimated from the poses (how much the start state the log gives matters);
    ``concentration``: the share of the calibrated robot's squared test error carried by its
    ``worst`` worst windows, with their start times; ``with_left_out``: the described and the calibrated
    robot's test error over every test window, the windows the ground cannot explain included (what
    leaving them out does to the comparison); ``yaw_by_sample``: the measured and the calibrated
    robot's yaw ratio over every sample of the test windows per |turn ratio| class
    (:func:`yaw_by_sample`), beside the steady turns alone that calibrate reports."""
    from mjtrack.sim.config import robot_sim_settings, sim_config
    from mjtrack.sim.windows import WindowSim, simulate_windows
    from mjtrack.windows import WARMUP_S, make_windows, measured_drive_log, without_contradicting

    log, base = read(spec)
    parts = list(split(log, *spec["split"]))
    cj = json.loads((OUTPUTS / name / "calibration.json").read_text())
    horizon = cj["train"]["horizon_s"]
    # a slope the calibration fitted belongs to the log's ground, not to robot.json: applied here, so
    # that the calibrated robot is the one the calibration scored
    ground = {k: cj["parameters"][k] for k in ("slope_x", "slope_y") if k in cj["parameters"]}
    wins = [without_contradicting(lg, make_windows(lg, horizon), base.track_gauge)[0] for lg in parts]
    kin = kinematic_model(parts[0], wins[0], parts[1], wins[1], base.track_gauge)
    test, tws, every = parts[1], wins[1], make_windows(parts[1], horizon)
    if spec.get("drive_input") == "measured":
        test = measured_drive_log(test, f"{spec['log'].name} (test part)")

    def errors(robot, lg, twists=None, ws=tws, variant=None, keep=None):
        config = sim_config(None, robot=robot)
        if robot.traction != "wheels" and "n_rollers" not in robot_sim_settings(robot):  # as the calibration ran
            config = config.replace(n_rollers=rollers)
        res = simulate_windows(WindowSim(robot, config, resisted=True), lg, ws, [variant or {}], warmup_s=WARMUP_S,
                               twists=twists)
        if keep is not None:
            keep.append(res)
        return np.hypot(res.errors[0][:, 0], res.errors[0][:, 1])

    described, calibrated = starting_robot(base, spec["public"]), read_robot(OUTPUTS / name / "robot.json")
    e_rest = errors(described, test, twists=np.zeros((len(tws), 3)))
    kept = []
    e_cal = errors(calibrated, test, variant=ground, keep=kept)
    from mjtrack.calibrate.measures import measured_speeds
    from mjtrack.windows.define import measured_window_poses

    by_sample = yaw_by_sample(test, tws, base.track_gauge, (measured_window_poses(test, tws), measured_speeds(test, tws)),
                              (kept[0].poses[0], kept[0].speeds[0]))
    order = np.argsort(e_cal)[::-1][:worst]

    def rms(e):
        return float(np.sqrt(np.mean(e ** 2)))

    with_left_out = {"windows": len(every), "before": rms(errors(described, test, ws=every)),
                     "after": rms(errors(calibrated, test, ws=every, variant=ground))}
    with_left_out["relative"] = 1.0 - with_left_out["after"] / with_left_out["before"]
    return {"kinematic": kin,
            "start_at_rest": {"rms": rms(e_rest), "windows": len(tws)},
            "concentration": {"worst": worst, "share": float(np.sum(e_cal[order] ** 2) / np.sum(e_cal ** 2)),
                              "median_m": float(np.median(e_cal)), "rms_m": rms(e_cal),
                              "t0": [float(test.t[tws.starts[j]]) for j in order]},
            "with_left_out": with_left_out, "yaw_by_sample": by_sample}


def run_robot(name: str, spec: dict, *, rollers: int, coulomb: bool = False, lateral: bool = False) -> dict:
    log, base = read(spec)
    train, test = split(log, *spec["split"])
    robot = starting_robot(base, spec["public"])
    t0 = time.time()
    drive_input = spec.get("drive_input", "auto")
    # --coulomb: calibrate's default candidates (those of its drive input) less the shear ground's moduli
    # --lateral: those plus the shear ground's modulus across over the one along
    names = None
    if coulomb or lateral:
        from mjtrack.calibrate.run import COMMAND_PARAMS, MEASURED_PARAMS, auto_drive_input

        names = [n for n in default_names(robot, train) if not (coulomb and n == "shear_modulus")]
        names += ["lateral_shear_ratio"] if lateral else []
        mode = auto_drive_input(train, robot, None)[0] if drive_input == "auto" else drive_input
        if mode != "commanded":
            names = [n for n in names if n not in COMMAND_PARAMS] + list(MEASURED_PARAMS)
    cal = calibrate(train, robot, test=test, n_rollers=rollers, quiet=not sys.stderr.isatty(), drive_input=drive_input,
                    fit_windows=FIT_WINDOWS, names=names,
                    train_path=f"{spec['log'].name} (first {100 * spec['split'][0]:.0f} %)",
                    test_path=f"{spec['log'].name} (next {100 * spec['split'][1]:.0f} %)")
    wall = time.time() - t0
    out = OUTPUTS / name
    write_outputs(cal, out)
    cj = cal.to_json()
    yaw = next(f for f in cj["findings"] if f["what"] == "yaw ratio" and f["part"] == "test")
    speed = {f["what"].removeprefix("forward speed ratio "): {"measured": f["measured"], "before": f["simulated_before"],
                                                             "after": f["simulated_after"], "windows": f["windows"]}
             for f in cj["findings"] if f["what"].startswith("forward speed ratio") and f["part"] == "test"}
    return {"traction": robot.traction, "drive_input": cj["drive_input_mode"], "drive_input_why": cj["drive_input_why"],
            "command_following": command_following(log),
            "windows": {"train": len(cal.train_windows), "fit": len(cal.fitted_windows), "test": len(cal.test_windows)},
            "test": cj["test"], "train": cj["train"],
            "yaw_ratio": {"measured": yaw["measured"], "before": yaw["simulated_before"], "after": yaw["simulated_after"],
                          "windows": yaw["windows"]},
            "speed_ratio": speed,
            "parameters": cj["parameters"], "intervals": cj["intervals"], "determined": cj["determined"],
            "described": cj["described"], "causes": cj["causes"], "summary": cj["summary"],
            "assumed": cj["assumed"], "left_out": cj["left_out"],
            "seconds": wall, "advance_speeds_s": ADVANCE_S, **context_of_stored(name, spec, rollers=rollers)}


def starts_robot(name: str, spec: dict, rounds: int | None = None) -> dict:
    """The robot calibrated from the shipped description and from the public one (module docstring);
    ``rounds``: calibrate's rounds (None: its default)."""
    from mjtrack.calibrate.rounds import MAX_ROUNDS

    log, base = read_log_with_robot(spec["log"])
    train, test = split(log, *STARTS_SPLIT)
    out = {"split": list(STARTS_SPLIT), "rounds": MAX_ROUNDS if rounds is None else rounds, "starts": {}}
    for start, robot in (("shipped", base), ("public", starting_robot(base, spec["public"]))):
        t0 = time.time()
        cal = calibrate(train, robot, test=test, quiet=not sys.stderr.isatty(),
                        drive_input=spec.get("drive_input", "auto"), rounds=out["rounds"],
                        train_path=f"{spec['log'].name} (first {100 * STARTS_SPLIT[0]:.0f} %)",
                        test_path=f"{spec['log'].name} (next {100 * STARTS_SPLIT[1]:.0f} %)")
        cj = cal.to_json()
        out["starts"][start] = {"seconds": time.time() - t0, "test": cj["test"], "parameters": cj["parameters"],
                                "intervals": cj["intervals"], "determined": cj["determined"],
                                "described": cj["described"], "causes": cj["causes"], "summary": cj["summary"],
                                "assumed": cj["assumed"], "drive_input": cj.get("drive_input_mode", "commanded"),
                                "mass": robot.mass, "bounds": _bounds(robot),
                                "yaw_by_class": yaw_by_class(cj, "test"), "turn_stage": turn_stage(cj)}
        print(f"  {name} from the {start} description: test {cj['test']['before']:.4f} -> {cj['test']['after']:.4f} m, "
              f"{time.time() - t0:.0f} s", flush=True)
    out.update(agreement(out["starts"]["shipped"], out["starts"]["public"]))
    return out


def yaw_by_class(cj: dict, part: str) -> list[dict]:
    """The steady-turn yaw ratio per |turn ratio| class of ``part`` in a calibration.json: measured,
    calibrated, the class's steady windows and the bootstrap interval of measured minus calibrated
    over them (how far the class's few windows alone move the gap)."""
    return [{"class": f["turn_class"], "measured": f["measured"], "calibrated": f["simulated_after"],
             "windows": f["windows"], "gap_interval": f.get("gap_after_interval")}
            for f in cj["findings"] if f["part"] == part and "turn_class" in f and f["what"].startswith("yaw ratio")]


def turn_stage(cj: dict) -> dict:
    """Whether calibrate's turn stage ran, its answer was taken, what refused it, whether the robot
    judged was the one with the others refitted, the training end poses' gap interval and how
    strongly the data spoke against each robot."""
    t = cj["method"].get("turns")
    if t is None:
        return {"ran": False}
    return {"ran": True, "accepted": t["accepted"], "refused_by": t["refused_by"],
            "refit_kept": None if t.get("refit") is None else t["refit"]["kept"],
            "train_mse_gap_interval_m2": t.get("train_mse_gap_interval_m2"), "evidence": t.get("evidence")}


def turning_agreement(a: dict, b: dict) -> dict | None:
    """Whether two calibrations of one log turn alike: per |turn ratio| class with at least
    YAW_CLASS_MIN steady test windows, both calibrated yaw ratios and whether they lie within
    YAW_CLASS_GAP of each other (the criterion's own yardstick), with each one's bootstrap interval of
    measured minus calibrated over the class's windows where the record has it; None when a record
    lacks them."""
    from mjtrack.calibrate.causes import YAW_CLASS_GAP, YAW_CLASS_MIN

    if "yaw_by_class" not in a or "yaw_by_class" not in b:
        return None
    other = {tuple(c["class"]): c for c in b["yaw_by_class"]}
    out = {}
    for c in a["yaw_by_class"]:
        d = other.get(tuple(c["class"]))
        if d is None or c["windows"] < YAW_CLASS_MIN or c["calibrated"] is None or d["calibrated"] is None:
            continue
        out[f"{c['class'][0]:g} to {c['class'][1]:g}"] = {
            "measured": c["measured"], "shipped": c["calibrated"], "public": d["calibrated"], "windows": c["windows"],
            "within_gap": abs(c["calibrated"] - d["calibrated"]) <= YAW_CLASS_GAP,
            "gap_interval": {"shipped": c.get("gap_interval"), "public": d.get("gap_interval")}}
    return out


def _bounds(robot: Robot) -> dict[str, list[float]]:
    """Every candidate's search range for this description (the centre of mass's follows its geometry)."""
    return {n: [float(s.lo), float(s.hi)] for n, s in specs_for(robot).items()}


# parameters that scale with the robot's mass, which the log does not determine and the two starting
# descriptions give differently: compared per kilogram (the log determines the drive's force per unit
# mass, how fast it can speed up the robot, not the force)
PER_KG = ("drive_force_limit",)


def agreement(a: dict, b: dict) -> dict:
    """Whether two calibrations of one log agree: in their turning (:func:`turning_agreement`) and
    per parameter: both values and, where both determine it, whether each lies in the other's interval (a value kept at its description, which the log
    confirms, has no interval: its own value stands for it); :data:`PER_KG` parameters per kilogram
    of each description's mass. A value beyond the other description's search range (a centre of
    mass's range follows the described geometry) is compared with the nearest end of that range, the
    closest the other fit could come, and marked ``beyond_the_other_range``."""
    agree = {}
    for n in a["parameters"]:
        if n not in b["parameters"]:
            continue
        da, db = a["determined"].get(n, {}), b["determined"].get(n, {})
        both = bool(da.get("determined")) and bool(db.get("determined"))
        ka, kb = (a["mass"], b["mass"]) if n in PER_KG else (1.0, 1.0)
        va, vb = a["parameters"][n] / ka, b["parameters"][n] / kb
        ia = [x / ka for x in a["intervals"][n]] if a["intervals"].get(n) else [va, va]
        ib = [x / kb for x in b["intervals"][n]] if b["intervals"].get(n) else [vb, vb]
        ra = [x / ka for x in a.get("bounds", {}).get(n, [-np.inf, np.inf])]
        rb = [x / kb for x in b.get("bounds", {}).get(n, [-np.inf, np.inf])]
        ca, cb = float(np.clip(va, *rb)), float(np.clip(vb, *ra))  # each as near as the other's range allows
        tol = 1e-9 * max(abs(va), abs(vb), 1e-12)
        inside = ib[0] - tol <= ca <= ib[1] + tol and ia[0] - tol <= cb <= ia[1] + tol
        # the weaker reading: the difference of the two estimates within its own 95 % interval, the
        # half-widths added in quadrature (two fits of one log are not independent: an approximation)
        dha, dhb = (ia[1] - ia[0]) / 2, (ib[1] - ib[0]) / 2
        consistent = abs(ca - cb) <= math.hypot(dha, dhb) + tol
        agree[n] = {"shipped": a["parameters"][n], "public": b["parameters"][n], "determined_in_both": both,
                    "each_in_the_other_interval": inside if both else None,
                    "difference_within_its_interval": consistent if both else None,
                    **({"beyond_the_other_range": True} if both and (ca != va or cb != vb) else {}),
                    **({"per_kg": {"shipped": va, "public": vb}} if n in PER_KG else {})}
    turning = turning_agreement(a, b)
    params = all(v["each_in_the_other_interval"] is not False for v in agree.values())
    turns = None if turning is None else all(v["within_gap"] for v in turning.values())
    return {"agreement": agree, "parameters_agree": params, "turning": turning, "turning_agrees": turns,
            "agree": params and turns is not False}


def shear_scan_robot(name: str, spec: dict, moduli: list[float]) -> dict:
    """The starting robot on the shear ground of each modulus, scored without a fit (module docstring)."""
    log, base = read_log_with_robot(spec["log"])
    train, test = split(log, *spec["split"])
    robot = starting_robot(base, spec["public"])
    out = {"split": list(spec["split"]), "drive_input": spec.get("drive_input", "auto"), "moduli": {}}
    for K in moduli:
        t0 = time.time()
        r = robot.replace(ground={"model": "shear", "shear_modulus": K} if K > 0 else {"model": "coulomb"})
        cj = calibrate(train, r, test=test, names=["cg_y"], quiet=True, drive_input=out["drive_input"],
                       fit_windows=FIT_WINDOWS).to_json()
        classes = {f["what"]: {"measured": f["measured"], "simulated": f["simulated_before"], "windows": f["windows"]}
                   for f in cj["findings"] if f["part"] == "test" and f["measured"] is not None
                   and f["what"].startswith(("yaw ratio (", "forward speed ratio ("))}
        out["moduli"][f"{K:g}"] = {"shear_modulus": K, "test_error": cj["test"]["before"], "windows": cj["test"]["windows"],
                                   "classes": classes, "seconds": time.time() - t0}
        print(f"  {name} K = {K:g} m: held-out {cj['test']['before']:.4f} m; "
              + "; ".join(f"{w} {c['measured']:.3f} / {c['simulated']:.3f}" for w, c in classes.items()), flush=True)
    return out


def _each_robot(args, path: Path, run, load0, **top) -> int:
    """Run ``run(name, spec)`` for each robot of ``--robots`` whose log is there and write ``path``
    after each (the robots already in it kept, each with the command that made it; ``top``: more
    top-level keys), then print the load."""
    stored = json.loads(path.read_text()) if path.exists() else {}
    robots = stored.get("robots", {})
    command = "python benchmarks/real_robots.py " + " ".join(sys.argv[1:])
    for name in args.robots.split(","):
        spec = ROBOTS[name]
        if not spec["log"].exists():
            print(f"{spec['log']} not found (the shared data); skipped")
            continue
        robots[name] = {**run(name, spec), "command": command}
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps({"command": "; ".join(sorted({r["command"] for r in robots.values()})), **top,
                                    "robots": robots, "load_before": load0, "load_after": os.getloadavg()},
                                   indent=1, default=_plain) + "\n")
    print(f"\nload average before {load0}, after {os.getloadavg()} ({os.cpu_count()} cores)")
    return 0


def _shear_scan(args, load0) -> int:
    moduli = [float(k) for k in args.shear_scan.split(",")]
    return _each_robot(args, SCAN_RESULT, lambda name, spec: shear_scan_robot(name, spec, moduli), load0)


def class_scatter_robot(name: str, spec: dict) -> dict:
    """Per consecutive part of the log and turn class, the measured steady yaw ratio's median and
    count; per class the standard deviation of the parts' medians (module docstring)."""
    from mjtrack.calibrate.measures import measured_speeds, turn_measures
    from mjtrack.windows import make_windows, measured_window_poses, without_contradicting

    log, base = read_log_with_robot(spec["log"])
    robot = starting_robot(base, spec["public"])
    sl = log.segment_slices()
    n = len(sl)
    parts, by_class = [], {}
    for k in range(SCATTER_PARTS):
        a, b = int(round(k * n / SCATTER_PARTS)), int(round((k + 1) * n / SCATTER_PARTS))
        lg = log.slice(sl[a].start, sl[b - 1].stop)
        ws, _ = without_contradicting(lg, make_windows(lg, 2.0), robot.track_gauge)
        m = turn_measures(lg, ws, robot, measured_window_poses(lg, ws), measured_speeds(lg, ws))
        row = {f"{lo:g}-{hi:g}": {"median": v, "turns": c} for (lo, hi), (v, c) in m["yaw_ratio_by_class"].items()}
        parts.append({"segments": [a, b], "classes": row})
        for cls, x in row.items():
            if x["turns"] >= SCATTER_MIN:
                by_class.setdefault(cls, []).append(x)
    classes = {cls: {"parts": len(xs), "median_turns": float(np.median([x["turns"] for x in xs])),
                     "sd_of_medians": float(np.std([x["median"] for x in xs], ddof=1)) if len(xs) > 1 else None,
                     "lowest": float(min(x["median"] for x in xs)), "highest": float(max(x["median"] for x in xs))}
               for cls, xs in by_class.items()}
    for cls, c in classes.items():
        print(f"== {name} |turn ratio| {cls}: {c['parts']} parts of about {c['median_turns']:.0f} steady turns, "
              f"medians {c['lowest']:.3f} to {c['highest']:.3f}, standard deviation "
              + ("n/a" if c["sd_of_medians"] is None else f"{c['sd_of_medians']:.3f}"))
    return {"parts": parts, "classes": classes, "segments": n}


def _class_scatter(args, load0) -> int:
    return _each_robot(args, SCATTER_RESULT, class_scatter_robot, load0, parts=SCATTER_PARTS, min_turns=SCATTER_MIN)


def diagnose_robot(name: str, spec: dict) -> dict:
    """``diagnose --baseline mujoco`` of the test part against the stored calibrated robot (its drives
    following what they followed in the calibration: the commands, or the measured track speeds)."""
    from mjtrack.diagnose import diagnose
    from mjtrack.windows import measured_drive_log

    log, _ = read_log_with_robot(spec["log"])
    _, test = split(log, *spec["split"])
    if spec.get("drive_input") == "measured":  # driven as calibrated: by the measured track speeds
        test = measured_drive_log(test, f"{spec['log'].name} (test part)")
    robot = read_robot(OUTPUTS / name / "robot.json")
    t0 = time.time()
    d = diagnose(test, robot, baseline="mujoco", quiet=not sys.stderr.isatty())
    return {"cause": d.cause, "findings": [{"effect": f.effect.name, "estimate": [float(v) for v in f.estimate],
                                            "interval": [[float(a), float(b)] for a, b in f.interval],
                                            "tied_with": list(f.tied_with), "relative_gain": float(f.relative)}
                                           for f in d.findings],
            "seconds": time.time() - t0}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--robots", default=",".join(ROBOTS))
    ap.add_argument("--rollers", type=int, default=6, help="contact rollers per track (tracked robots; default 6)")
    ap.add_argument("--diagnose", action="store_true", help="then diagnose the test part against the calibrated robot")
    ap.add_argument("--diagnose-only", action="store_true", help="only diagnose the stored calibrated robots")
    ap.add_argument("--context-only", action="store_true",
                    help="only recompute, for the stored robots, the kinematic model, the start-state sensitivity, "
                         "the error concentration and the errors over every test window (seconds to minutes)")
    ap.add_argument("--agreement-only", action="store_true",
                    help="--starts: only recompute the agreement of the stored start_independence.json")
    ap.add_argument("--rounds", type=int, default=None,
                    help="--starts: calibrate's rounds (default: its own); more let a fit that has not settled reach "
                         "what the log points at")
    ap.add_argument("--coulomb", action="store_true",
                    help="the reference calibrations without the shear ground's modulus among the candidates (a "
                         "wheeled robot's default); written to real_robots_coulomb.json and real_robots_coulomb/NAME/")
    ap.add_argument("--lateral", action="store_true",
                    help="the reference calibrations with the shear ground's lateral_shear_ratio among the candidates "
                         "as well; written to real_robots_lateral.json and real_robots_lateral/NAME/")
    ap.add_argument("--advance-speeds", type=float, default=0.0, metavar="S",
                    help="the reference calibrations with each log's measured track speeds taken S seconds later "
                         "than logged (a clock that dated them late, set right); written to real_robots_advanced.json "
                         "and real_robots_advanced/NAME/")
    ap.add_argument("--starts", action="store_true",
                    help="calibrate each robot from its shipped description and from the public one; write "
                         "start_independence.json (module docstring)")
    ap.add_argument("--shear-scan", metavar="K,K,...", default=None,
                    help="score the starting robot on the shear ground of each modulus K [m] (0: Coulomb) without "
                         "fitting its contact; write shear_scan.json (module docstring)")
    ap.add_argument("--class-scatter", action="store_true",
                    help="the measured steady yaw ratio per turn class over consecutive parts of each log, nothing "
                         "simulated; write yaw_class_scatter.json (module docstring)")
    args = ap.parse_args(argv)
    load0 = os.getloadavg()
    if args.shear_scan:
        return _shear_scan(args, load0)
    if args.class_scatter:
        return _class_scatter(args, load0)
    if sum(map(bool, (args.coulomb, args.lateral, args.advance_speeds))) > 1:
        ap.error("--coulomb, --lateral and --advance-speeds are different variants of the reference calibrations: "
                 "give one")
    if args.coulomb or args.lateral or args.advance_speeds:
        global RESULT, OUTPUTS, ADVANCE_S
        ADVANCE_S = args.advance_speeds
        variant = "coulomb" if args.coulomb else "lateral" if args.lateral else "advanced"
        RESULT, OUTPUTS = RESULT.with_name(f"real_robots_{variant}.json"), OUTPUTS.with_name(f"real_robots_{variant}")
    if args.starts and args.agreement_only:
        return _agreement_only(args)
    if args.starts:
        return _starts(args, load0)
    old = json.loads(RESULT.read_text()) if RESULT.exists() else {}
    robots = old.get("robots", {})
    for name in args.robots.split(","):
        spec = ROBOTS[name]
        if not spec["log"].exists():
            print(f"{spec['log']} not found (the shared data); skipped")
            continue
        if args.context_only:
            robots[name] = {**robots[name], **context_of_stored(name, spec, rollers=args.rollers)}
            r = robots[name]
            k, c = r["kinematic"], r["concentration"]
            print(f"== {name}: test error {r['test']['before']:.4f} -> {r['test']['after']:.4f} m; kinematic model "
                  f"{k['fitted_on_train']['rms']:.4f} m (fitted on train), {k['fitted_on_test']['rms']:.4f} m (fitted "
                  f"on test); described robot started at rest {r['start_at_rest']['rms']:.4f} m; the calibrated "
                  f"robot's {c['worst']} worst test windows carry {100 * c['share']:.0f} % of its squared error; "
                  f"over every test window, left-out ones included: {r['with_left_out']['before']:.4f} -> "
                  f"{r['with_left_out']['after']:.4f} m ({100 * r['with_left_out']['relative']:.1f} % lower)")
            _write(robots, args, load0)
            continue
        if args.diagnose_only:
            r = robots[name]
        else:
            r = run_robot(name, spec, rollers=args.rollers, coulomb=args.coulomb, lateral=args.lateral)
        if args.diagnose or args.diagnose_only:
            r["diagnose"] = diagnose_robot(name, spec)
            print(f"== {name}: diagnose --baseline mujoco on the test part against the calibrated robot: "
                  f"{r['diagnose']['cause']} ({r['diagnose']['seconds']:.0f} s)")
        robots[name] = r
        if args.diagnose_only:
            _write(robots, args, load0)
            continue
        t, y = r["test"], r["yaw_ratio"]
        print(f"\n== {name}: {r['windows']['train']} training windows, {r['windows']['test']} test windows, "
              f"{r['seconds']:.0f} s")
        cf = r["command_following"]
        print(f"  drives follow: {r['drive_input']} speeds; measured vs commanded once settled: RMS difference "
              f"{cf['mean_speed']:.2f} of the mean speed, {cf['speed_difference']:.2f} of the speed difference")
        print(f"  test 2 s position RMSE {t['before']:.4f} -> {t['after']:.4f} m ({100 * t['relative']:.1f} % lower)")
        kin = r["kinematic"]
        print(f"  a kinematic ICR model on the measured track speeds: {kin['fitted_on_train']['rms']:.4f} m fitted on "
              f"the training windows, {kin['fitted_on_test']['rms']:.4f} m fitted on the test windows themselves "
              "(a bound)")
        for part, lo in r["left_out"].items():
            at = ", ".join(f"{w['t0']:.1f}" for w in lo["windows"])
            print(f"  left out of the {part} part: {left_out_counts(lo['windows'])} (at t = {at} s)")
        f3 = lambda v: "n/a" if v is None else f"{v:.3f}"
        print(f"  test yaw ratio: measured {f3(y['measured'])}, simulated {f3(y['before'])} -> {f3(y['after'])} "
              f"({y['windows']} steady-turn windows)")
        for n, v in r["determined"].items():
            iv = r["intervals"].get(n)
            print(f"  {n:18s} {r['described'][n]:8.4g} -> {r['parameters'][n]:8.4g} "
                  f"{'' if iv is None else f'[{iv[0]:.4g}, {iv[1]:.4g}]':24s} "
                  f"{'determined' if v['determined'] else 'NOT determined'}, {'changed' if v['changed'] else 'kept'}"
                  + (f" (the log points at {v['points_at']:.4g}, not reached)" if "points_at" in v else ""))
        print(f"  {r['summary']}")
        _write(robots, args, load0)
    print(f"\nload average before {load0}, after {os.getloadavg()} ({os.cpu_count()} cores)")
    return 0


def _write(robots: dict, args, load0) -> None:
    """Write this run's robots into the result file, keeping the others as the file holds them now
    (runs of different robots may overlap)."""
    RESULT.parent.mkdir(parents=True, exist_ok=True)
    ran = args.robots.split(",")
    stored = json.loads(RESULT.read_text()) if RESULT.exists() else {}
    now = {k: {"command": stored.get("command", ""), **v} for k, v in stored.get("robots", {}).items()}
    command = "python benchmarks/real_robots.py " + " ".join(sys.argv[1:])
    # a run that only adds to a stored calibration keeps the command that made it and says its own
    key = "context_command" if args.context_only else "diagnose_command" if args.diagnose_only else "command"
    merged = {**now, **{k: {**v, key: command} for k, v in robots.items() if k in ran}}
    # runs of different robots merge into one file: each robot says which commands made it
    commands = {v.get(c, "") for v in merged.values() for c in ("command", "diagnose_command", "context_command")}
    RESULT.write_text(json.dumps({"command": "; ".join(sorted(commands - {""})),
                                  "robots": merged, "rollers": args.rollers, "load_before": load0,
                                  "load_after": os.getloadavg()}, indent=1, default=_plain) + "\n")


def _starts(args, load0) -> int:
    def run(name: str, spec: dict) -> dict:
        r = starts_robot(name, spec, args.rounds)
        for n, v in r["agreement"].items():
            print(f"  {n:20s} shipped {v['shipped']:.4g}  public {v['public']:.4g}  "
                  + ("not determined in both" if not v["determined_in_both"]
                     else f"each in the other's interval: {v['each_in_the_other_interval']}"
                     + (" (a value beyond the other's range, compared with its end)"
                        if v.get("beyond_the_other_range") else "")))
        for c, v in (r["turning"] or {}).items():
            print(f"  yaw ratio |turn ratio| {c:12s} measured {v['measured']:.3f}  shipped {v['shipped']:.3f}  "
                  f"public {v['public']:.3f}  alike: {v['within_gap']}")
        return r

    return _each_robot(args, STARTS_RESULT, run, load0)


def _agreement_only(args) -> int:
    stored = json.loads(STARTS_RESULT.read_text())
    for name, r in stored["robots"].items():
        if any("mass" not in r["starts"][s] or "bounds" not in r["starts"][s] for s in ("shipped", "public")):
            # the descriptions' masses and search ranges, as starts_robot records them
            _, base = read_log_with_robot(ROBOTS[name]["log"])
            for s, robot in (("shipped", base), ("public", starting_robot(base, ROBOTS[name]["public"]))):
                r["starts"][s]["mass"], r["starts"][s]["bounds"] = robot.mass, _bounds(robot)
        r.update(agreement(r["starts"]["shipped"], r["starts"]["public"]))
        print(f"{name}: agree {r['agree']}")
    stored["agreement_command"] = "python benchmarks/real_robots.py --starts --agreement-only"
    STARTS_RESULT.write_text(json.dumps(stored, indent=1, default=_plain) + "\n")
    return 0


def _plain(o):
    if isinstance(o, np.generic):
        return o.item()
    raise TypeError(type(o).__name__)


if __name__ == "__main__":
    raise SystemExit(main())
