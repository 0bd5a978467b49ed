"""``calibrate(train, robot)``: the MuJoCo robot fitted to a measured log, and what it gets wrong.

Stages (timed):
1. windows of the training log (and of the test log), each simulated from its measured state
   (:mod:`mjtrack.sim.windows`);
2. the robot as described (every default it relies on named under ``assumed``) scored on them:
   errors at the horizon binned by curvature, speed, turn direction and time; steady-turn yaw
   ratio and ICRs measured against simulated;
3. the windowed fit (:mod:`mjtrack.calibrate.fit`, ``mujoco.sysid``) of the named parameters;
4. the calibrated robot scored on the same windows and on the test log (never used in the fit);
5. outputs: robot.json (complete, builds the calibrated robot), calibration.json (CONTRACTS §5
   plus extra keys), report.html (:mod:`mjtrack.calibrate.report`).
"""

from __future__ import annotations

import json
import logging
import math
import os
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mjtrack.calibrate.fit import FitResult, fit, objective
from mjtrack.calibrate.params import parse_names, start_values
from mjtrack.diagnose import residuals as rs
from mjtrack.errors import InputError
from mjtrack.geometry import _sinc_terms, relative_pose
from mjtrack.io.atomic import atomic_write_text, make_output_dir
from mjtrack.io.logs import DriveLog
from mjtrack.io.robot import Robot
from mjtrack.sim.config import sim_config
from mjtrack.sim.windows import (DRIVE_DEFAULTS, WindowResult, WindowSet, WindowSim, geometry_robot, make_windows,
                                 measured_window_poses, simulate_windows)

log = logging.getLogger(__name__)

#: robot keys whose defaults a description may silently rely on (named under ``assumed``)
DESCRIBED = ("track_length", "track_width", "mass", "cg_x", "cg_y", "cg_z", "mu", "sprocket_radius")
STEADY_MIN_WZ = 0.3  # [rad/s] nominal yaw rate below which a window's yaw ratio is not used
ICR_MIN_TURN = 0.3  # |turn ratio| below which a window's ICRs are not used (they diverge)


@dataclass
class Scored:
    """A robot scored on a log's windows: per-window errors (M, 3), RMS position error [m], the
    windows' simulated poses and track speeds (for yaw ratios and ICRs)."""

    errors: np.ndarray
    rms: float
    poses: np.ndarray
    speeds: np.ndarray
    diverged: int

    @classmethod
    def of(cls, res: WindowResult, p: int = 0) -> "Scored":
        e = res.errors[p]
        return cls(errors=e, rms=float(np.sqrt(np.mean(e[:, 0] ** 2 + e[:, 1] ** 2))), poses=res.poses[p],
                   speeds=res.speeds[p], diverged=int(res.diverged[p].sum()))


@dataclass
class Calibration:
    """Everything calibrate found; :meth:`to_json` is calibration.json."""

    train_path: str
    test_path: str | None
    robot: Robot
    calibrated: Robot
    track_model: str
    horizon_s: float
    names: list[str]
    fixed: dict[str, float]
    assumed: dict[str, str]
    fit: FitResult
    train_windows: WindowSet
    test_windows: WindowSet | None
    train_log: DriveLog
    test_log: DriveLog | None
    before: Scored
    after: Scored
    test_before: Scored | None
    test_after: Scored | None
    findings: list[dict]
    sentence: str
    config: dict
    timings: dict[str, float] = field(default_factory=dict)

    def to_json(self) -> dict:
        params = {n: self.fit.values[n] for n in self.names}
        out = {
            "simulator": "mujoco", "track_model": self.track_model,
            "parameters": params,
            "intervals": {n: list(self.fit.intervals[n]) for n in self.names},
            "fixed": self.fixed, "assumed": self.assumed,
            "train": {"log": self.train_path, "metric": "pos_err_m", "horizon_s": self.horizon_s,
                      "before": self.before.rms, "after": self.after.rms, "windows": len(self.train_windows)},
            "findings": self.findings,
            "summary": self.sentence,
            "start": self.fit.start, "starts_tried": [{"parameters": p, "cost": c} for p, c in self.fit.starts_tried],
            "method": {"optimizer": self.fit.method, "iterations": self.fit.iterations,
                       "simulated_windows": self.fit.evaluations * len(self.train_windows),
                       "cost_start": self.fit.cost_start, "cost_final": self.fit.cost_final,
                       "intervals": "95 % half-widths from sysid.calculate_intervals on the final Jacobian "
                                    "(residuals treated as independent: a statistical lower bound)",
                       "windows": "each window simulated from the measured state at its start (pose, twist, "
                                  "track speeds); errors at the window's end in its start frame"},
            "sim_config": self.config,
            "timings_s": self.timings,
        }
        if self.test_before is not None and self.test_after is not None:
            b, a = self.test_before.rms, self.test_after.rms
            out["test"] = {"log": self.test_path, "metric": "pos_err_m", "horizon_s": self.horizon_s,
                           "before": b, "after": a, "relative": 1.0 - a / b if b > 0 else 0.0,
                           "windows": len(self.test_windows)}
        return out


# -- measurements on windows ---------------------------------------------------------------------
def _chord_twist(p0: np.ndarray, p1: np.ndarray, dur: np.ndarray) -> np.ndarray:
    """Mean body twist (M, 3) of the constant-twist arc from poses p0 to p1 (M, 3) in dur (M,) s."""
    rel = relative_pose(p0, p1)
    rel[:, 2] = p1[:, 2] - p0[:, 2]
    s, c = _sinc_terms(rel[:, 2])
    den = (s * s + c * c) * dur
    return np.stack([(s * rel[:, 0] + c * rel[:, 1]) / den, (-c * rel[:, 0] + s * rel[:, 1]) / den,
                     rel[:, 2] / dur], -1)


def steady_mask(lg: DriveLog, ws: WindowSet) -> np.ndarray:
    """Windows whose commands do not change (and, when the log has a ``steady`` column, marked 1)."""
    ok = np.array([np.ptp(lg.v_left_cmd[s:e + 1]) < 1e-6 and np.ptp(lg.v_right_cmd[s:e + 1]) < 1e-6
                   for s, e in zip(ws.starts, ws.ends)])
    if "steady" in lg.extra:
        ok &= np.asarray(lg.extra["steady"])[ws.starts] == 1
    return ok


def turn_measures(lg: DriveLog, ws: WindowSet, robot: Robot, poses: np.ndarray, speeds: np.ndarray) -> dict:
    """Yaw ratio and ICRs of steady windows from window poses (M, K, 3) and track speeds (M, K, 2).

    yaw ratio: median over steady windows with |nominal yaw rate| >= STEADY_MIN_WZ of the
    window's yaw rate / ((v_R - v_L) / T) (mean track speeds of the window); ICRs (2.13) from the
    window's chord twist where |turn ratio| >= ICR_MIN_TURN, medians per turn direction.
    """
    n = ws.ends - ws.starts
    M = len(ws)
    p0, p1 = poses[:, 0], poses[np.arange(M), n]
    dur = lg.t[ws.ends] - lg.t[ws.starts]
    tw = _chord_twist(p0, p1, dur)
    v = np.array([np.nanmean(speeds[j, :n[j] + 1], axis=0) for j in range(M)])
    wnom = (v[:, 1] - v[:, 0]) / robot.track_gauge
    steady = steady_mask(lg, ws)
    use = steady & (np.abs(wnom) >= STEADY_MIN_WZ)
    ratio = float(np.median(tw[use, 2] / wnom[use])) if use.any() else float("nan")
    turn = rs.turn_ratio(v)
    keep = steady & (np.abs(turn) >= ICR_MIN_TURN) & (np.abs(tw[:, 2]) > 1e-3)
    icr = {}
    for sign, name in ((1, "left"), (-1, "right")):
        m = keep & (np.sign(tw[:, 2]) == sign)
        if m.sum() >= 3:
            wz = tw[m, 2]
            icr[name] = {"y_l": float(np.median((tw[m, 0] - v[m, 0]) / wz)),
                         "y_r": float(np.median((tw[m, 0] - v[m, 1]) / wz)),
                         "x_c": float(np.median(-tw[m, 1] / wz)), "windows": int(m.sum())}
    return {"yaw_ratio": ratio, "yaw_windows": int(use.sum()), "icr": icr}


def measured_speeds(lg: DriveLog, ws: WindowSet) -> np.ndarray:
    """(M, K, 2) measured (else commanded) track speeds of each window, NaN beyond its end."""
    K = int((ws.ends - ws.starts).max()) + 1
    out = np.full((len(ws), K, 2), np.nan)
    for j, (s, e) in enumerate(zip(ws.starts, ws.ends)):
        sl = slice(s, e + 1)
        v = np.stack([lg.v_left_cmd[sl], lg.v_right_cmd[sl]], -1)
        if lg.has_track_speeds:
            meas = np.stack([lg.v_left[sl], lg.v_right[sl]], -1)
            v = np.where(np.isfinite(meas), meas, v)
        out[j, :e - s + 1] = v
    return out


# -- the calibration -----------------------------------------------------------------------------
def assumed_values(robot: Robot, names: list[str]) -> dict[str, str]:
    """Every value the description did not give that the simulation uses, and where it came from."""
    provided = robot.provided if robot.provided is not None else frozenset(DESCRIBED)
    out = {}
    for k in DESCRIBED:
        if k not in provided:
            v = getattr(robot, k)
            out[k] = f"not in the robot description: default {v:g}" + (" (start value; fitted)" if k in names else "")
    for k in DRIVE_DEFAULTS:
        if k not in provided:
            v = getattr(robot, k, None)
            what = "the simulator's default drive" if v is None else f"default {v:g}"
            out[k] = f"not in the robot description: {what}" + (" (fitted)" if k in names else "")
    for k, v in robot.extra.items():
        if isinstance(k, str) and k.startswith("source_") and isinstance(v, str):
            out[k.removeprefix("source_")] = v
    return out


def calibrated_robot(robot: Robot, values: dict[str, float]) -> Robot:
    """The robot with fitted values written into its description (drive keys, ground parameters)."""
    r = geometry_robot(robot, values)
    fields = {k: values[k] for k in ("mu", "mu_left", "mu_right", "cg_x", "cg_y") if k in values}
    if "mu_left" in fields and "mu_right" in fields:
        fields.setdefault("mu", math.sqrt(fields["mu_left"] * fields["mu_right"]))
    if "lateral_ratio" in values:
        fields["ground"] = type(r.ground)(r.ground.model, tuple({**dict(r.ground.params),
                                                                  "lateral_ratio": values["lateral_ratio"]}.items()))
    r = r.replace(**fields)
    extra = dict(r.extra)
    for k in DRIVE_DEFAULTS:
        if k in values:
            if hasattr(r, k):
                r = r.replace(**{k: values[k]})
            else:
                extra[k] = values[k]
    import dataclasses

    return dataclasses.replace(r, extra=extra)


def _sentence(robot: Robot, cal_values: dict[str, float], meas: dict, before: dict, after: dict,
              rms: tuple[float, float]) -> str:
    """One sentence: what the uncalibrated simulation got wrong and why (from the numbers)."""
    parts = []
    why = []
    ym, yb = meas.get("yaw_ratio", float("nan")), before.get("yaw_ratio", float("nan"))
    if np.isfinite(ym) and np.isfinite(yb) and abs(ym - yb) > 0.03:
        parts.append(f"it turned at {yb:.2f} of the nominal yaw rate where the robot turns at {ym:.2f}")
        if yb < ym:
            g = robot.ground.model
            what = {"coulomb": f"rigid {robot.track_length:.2f} m tracks on isotropic Coulomb ground resist turning "
                               "more than the real contact does"}.get(g, f"its {g} ground resists turning too much")
            moved = [f"{k} {cal_values[k]:.3g}" for k in ("track_length", "lateral_ratio", "span", "concentration")
                     if k in cal_values]
            why.append(what + (f" (fitted: {', '.join(moved)})" if moved else ""))
        else:
            why.append("its ground resists turning less than the real contact does")
    lag = cal_values.get("drive_lag", 0.0)
    delay = cal_values.get("drive_delay", 0.0)
    if lag > 0.05 or delay > 0.05:
        parts.append("its tracks followed the commands at once")
        drive = [f"a {lag:.2f} s lag" if "drive_lag" in cal_values else "",
                 f"a {delay:.2f} s delay" if "drive_delay" in cal_values else ""]
        why.append("the real drives reach a command with " + " and ".join(d for d in drive if d))
    scale = cal_values.get("track_speed_scale", 1.0)
    if abs(scale - 1.0) > 0.03:
        parts.append(f"its tracks ran at the commanded speed where the real ones run at {scale:.2f} of it")
    if not parts:
        return (f"The uncalibrated simulation's {rms[0]:.3g} m error at the horizon has no single dominant cause "
                f"among the fitted parameters (calibrated {rms[1]:.3g} m).")
    text = "The uncalibrated MuJoCo robot was wrong because " + "; ".join(parts)
    if why:
        text += ", since " + " and ".join(why)
    return text + f" (2 s error {rms[0]:.3g} m before, {rms[1]:.3g} m after calibration)."


def calibrate(train: DriveLog, robot: Robot, *, test: DriveLog | None = None, track_model: str = "rollers",
              names: str | list[str] | None = None, horizon_s: float = 2.0, n_rollers: int | None = None,
              max_iter: int = 8, nthread: int = 2, quiet: bool = True, train_path: str | None = None,
              test_path: str | None = None) -> Calibration:
    """Fit the MuJoCo robot to ``train`` (see the module docstring); bad input raises InputError."""
    from mjtrack.progress import Progress

    timings: dict[str, float] = {}
    t0 = time.perf_counter()
    src = train_path or train.source or "train log"
    if track_model != "rollers":
        raise InputError(f"--track-model {track_model}: windows restart the robot through mujoco.rollout, which "
                         "drives actuators; the surfacevel model sets its track speeds from Python every step "
                         "(use --track-model rollers)")
    if isinstance(names, str) or names is None:
        names = parse_names(names, robot)
    config = sim_config("rollers")
    if n_rollers is not None:
        config = config.replace(n_rollers=int(n_rollers))
    start = start_values(robot, names, config)
    ws = make_windows(train, horizon_s)
    if len(ws) == 0:
        longest = max(float(train.t[s][-1] - train.t[s][0]) for s in train.segment_slices())
        raise InputError(f"{src}: too short for one {horizon_s:g} s window (longest segment {longest:.3g} s)")
    tws = None
    if test is not None:
        tws = make_windows(test, horizon_s)
        if len(tws) == 0:
            raise InputError(f"{test_path or test.source}: too short for one {horizon_s:g} s window")
    fixed = {"track_gauge": robot.track_gauge}
    for k in ("track_length", "mass", "sprocket_radius", "cg_z", "track_width"):
        if k not in names and (robot.provided is None or k in robot.provided):
            fixed[k] = getattr(robot, k)
    assumed = assumed_values(robot, names)
    timings["prepare"] = time.perf_counter() - t0

    # the robot as described, and the fit
    t1 = time.perf_counter()
    sim = WindowSim(robot, config)
    before = Scored.of(simulate_windows(sim, train, ws, nthread=nthread))
    test_before = Scored.of(simulate_windows(sim, test, tws, nthread=nthread)) if test is not None else None
    timings["before"] = time.perf_counter() - t1
    t2 = time.perf_counter()
    obj = objective(robot, train, ws, names, config, nthread=nthread)
    obj.sim = sim
    with Progress(total=max_iter, label="calibrate", quiet=quiet) as bar:
        def on_iter(i, cost):
            bar.update()
        result = fit(obj, start, max_iter=max_iter, on_iter=on_iter)
    timings["fit"] = time.perf_counter() - t2

    # the calibrated robot, scored on the same windows and on the test log
    t3 = time.perf_counter()
    values = dict(result.values)
    after = Scored.of(simulate_windows(sim, train, ws, [values], nthread=nthread))
    test_after = Scored.of(simulate_windows(sim, test, tws, [values], nthread=nthread)) if test is not None else None
    cal_robot = calibrated_robot(robot, values)
    timings["after"] = time.perf_counter() - t3

    findings = []
    scope = [("train", train, ws, before, after)]
    if test is not None:
        scope.append(("test", test, tws, test_before, test_after))
    meas_by = {}
    for label, lg, w, b, a in scope:
        meas = turn_measures(lg, w, robot, measured_window_poses(lg, w), measured_speeds(lg, w))
        tb = turn_measures(lg, w, robot, b.poses, b.speeds)
        ta = turn_measures(lg, w, robot, a.poses, a.speeds)
        meas_by[label] = (meas, tb, ta)
        findings.append({"what": "yaw ratio", "part": label, "measured": meas["yaw_ratio"],
                         "simulated_before": tb["yaw_ratio"], "simulated_after": ta["yaw_ratio"],
                         "windows": meas["yaw_windows"],
                         "definition": "median over steady windows of yaw rate / ((v_R - v_L) / T), mean track speeds"})
        for side in ("left", "right"):
            if side in meas["icr"]:
                for key in ("y_l", "y_r", "x_c"):
                    findings.append({"what": f"ICR {key} ({side} turns)", "part": label, "measured": meas["icr"][side][key],
                                     "simulated_before": tb["icr"].get(side, {}).get(key, float("nan")),
                                     "simulated_after": ta["icr"].get(side, {}).get(key, float("nan")),
                                     "windows": meas["icr"][side]["windows"]})
    part = "test" if test is not None else "train"
    m, tb, ta = meas_by[part]
    rms = (test_before.rms, test_after.rms) if test is not None else (before.rms, after.rms)
    sentence = _sentence(robot, values, m, tb, ta, rms)
    timings["total"] = time.perf_counter() - t0
    return Calibration(
        train_path=str(train_path or train.source), test_path=None if test is None else str(test_path or test.source),
        robot=robot, calibrated=cal_robot, track_model=track_model, horizon_s=float(horizon_s), names=list(names),
        fixed=fixed, assumed=assumed, fit=result, train_windows=ws, test_windows=tws, train_log=train, test_log=test,
        before=before, after=after, test_before=test_before, test_after=test_after, findings=_clean(findings),
        sentence=sentence, config=config.to_dict(), timings=timings)


def _clean(obj):
    """JSON-safe copy: NaN -> None."""
    if isinstance(obj, dict):
        return {k: _clean(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_clean(v) for v in obj]
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    if isinstance(obj, np.floating):
        return _clean(float(obj))
    return obj


def write_outputs(cal: Calibration, out: str | os.PathLike) -> None:
    """DIR/robot.json, DIR/calibration.json, DIR/report.html (each written atomically)."""
    from mjtrack.calibrate.report import build_report

    out = Path(out)
    report = build_report(cal)  # built first: a failure here leaves nothing half-written
    make_output_dir(out)
    atomic_write_text(out / "robot.json", json.dumps(_clean(cal.calibrated.to_dict()), indent=2, sort_keys=True) + "\n")
    atomic_write_text(out / "calibration.json", json.dumps(_clean(cal.to_json()), indent=2) + "\n")
    report.write(out / "report.html")


def check_same_robot(train_robot: Robot, test_robot: Robot, test_path: str) -> None:
    """Refuse a test log recorded with another robot (gauge or sprocket radius differ)."""
    for k in ("track_gauge", "sprocket_radius"):
        a, b = getattr(train_robot, k), getattr(test_robot, k)
        provided = test_robot.provided is None or k in test_robot.provided
        if provided and not math.isclose(a, b, rel_tol=1e-6, abs_tol=1e-9):
            raise InputError(f"{test_path}: recorded with another robot ({k} {b:g} m in its description, "
                             f"{a:g} m for the training log)")


__all__ = ["Calibration", "calibrate", "calibrated_robot", "check_same_robot", "write_outputs"]
