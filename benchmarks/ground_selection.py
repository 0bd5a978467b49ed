"""Which ground do the real robots select? The steady yaw ratio by turn class, measured on the
shared DRIVE logs (Marmotte tracked, Husky and Warthog wheeled skid-steer; ../shared/data, BSD-3)
against the steady state of each candidate ground's reference model.

    python benchmarks/ground_selection.py [--robots marmotte,husky,warthog] [--n-points 60]

Measured: the log's windows of 2 s, each window's yaw ratio (chord yaw rate over the nominal
(v_R - v_L)/T of its mean measured track speeds) where calibrate measures one
(:func:`mjtrack.calibrate.run.turn_measures`: steady commands, nominal yaw rate >= 0.3 rad/s), the
median per |turn ratio| class (:data:`mjtrack.calibrate.run.TURN_CLASSES`). Predicted: the same
median of the reference's yaw ratio at each window's mean measured track speeds, for the robot as
the log describes it plus the public specification of what it does not give (the starting robot
of ``benchmarks/real_robots.py``), with inertia and load transfer. Candidates, each fitted by
least squares on the class medians (weighted by their window counts) of the first 70 % of the
windows and scored on the rest:

* ``coulomb``: the Coulomb reference (:mod:`mjtrack.models.coulomb`) as described (nothing fitted);
* ``coulomb_length``: Coulomb with the contact length (tracks) / wheelbase (wheels) fitted;
* ``shear``: the shear-displacement ground (:mod:`mjtrack.models.shear`) with K fitted;
* ``shear_length``: shear with K and the contact length / wheelbase fitted.

A wheel's tyre patch is the reference's default (``mjtrack.models.shear.DEFAULT_PATCH_LENGTH``).
Writes benchmarks/results/ground_selection.json; prints the same and the machine's load.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np
from scipy import optimize

from mjtrack.calibrate.run import TURN_CLASSES, measured_speeds, turn_measures
from mjtrack.diagnose.residuals import turn_ratio
from mjtrack.errors import MjtrackError
from mjtrack.io import read_log_with_robot
from mjtrack.models import coulomb, shear
from mjtrack.sim.windows import make_windows, measured_window_poses

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from real_robots import ROBOTS, starting_robot  # noqa: E402  (the same starting robots)

RESULT = HERE / "results" / "ground_selection.json"
HORIZON_S = 2.0
TRAIN_SHARE = 0.7
K_BOUNDS = (1e-4, 0.3)  # [m] shear modulus searched (log scale)
LENGTH_BOUNDS = (0.3, 2.5)  # contact length / wheelbase searched, as a factor of the described one


def measured_windows(name: str) -> dict:
    """Per window: mean measured track speeds (M, 2), measured yaw ratio (NaN where calibrate
    does not measure one), turn class index (-1: none) and whether it is in the training part."""
    lg, _ = read_log_with_robot(ROBOTS[name]["log"])
    robot = starting_robot(read_log_with_robot(ROBOTS[name]["log"])[1], ROBOTS[name]["public"])
    ws = make_windows(lg, HORIZON_S)
    poses, speeds = measured_window_poses(lg, ws), measured_speeds(lg, ws)
    ratio = np.array([turn_measures(lg, ws.subset([j]), robot, poses[[j]], speeds[[j]])["yaw_ratio"]
                      for j in range(len(ws))])
    v = np.array([np.nanmean(speeds[j, :ws.ends[j] - ws.starts[j] + 1], axis=0) for j in range(len(ws))])
    turn = np.abs(turn_ratio(v))
    cls = np.full(len(ws), -1)
    for c, (lo, hi) in enumerate(TURN_CLASSES):
        cls[(turn >= lo) & ((turn < hi) | (hi >= 1.0))] = c
    train = np.arange(len(ws)) < int(round(TRAIN_SHARE * len(ws)))
    use = np.isfinite(ratio) & (cls >= 0)
    # the class medians of the per-window ratios are calibrate's class yaw ratios (checked here)
    for c in range(len(TURN_CLASSES)):
        m = cls == c
        if (use & m).any():
            whole = turn_measures(lg, ws.subset(m), robot, poses[m], speeds[m])["yaw_ratio"]
            assert np.isclose(whole, np.median(ratio[use & m])), (whole, np.median(ratio[use & m]))
    return {"robot": robot, "v": v[use], "ratio": ratio[use], "cls": cls[use], "train": train[use]}


def class_medians(values: np.ndarray, cls: np.ndarray) -> list:
    """[(median ignoring NaN, windows)] per turn class (None where it has no window)."""
    return [(float(np.nanmedian(values[cls == c])) if np.isfinite(values[cls == c]).any() else float("nan"),
             int((cls == c).sum())) if (cls == c).any() else None for c in range(len(TURN_CLASSES))]


def with_length(robot, factor: float):
    key = "wheelbase" if robot.traction == "wheels" else "track_length"
    return robot.replace(**{key: factor * getattr(robot, key)})


def predicted(robot, v: np.ndarray, K: float | None, n_points: int) -> np.ndarray:
    """The reference's yaw ratio at each window's speeds v (M, 2) (NaN where it has no steady state)."""
    out = np.full(len(v), np.nan)
    T = robot.track_gauge
    for j, (vl, vr) in enumerate(v):
        try:
            s = coulomb.steady_state(robot, vl, vr, n_points=n_points)
            if K is not None:
                s = shear.steady_state(robot, vl, vr, shear_modulus=K, n_points=n_points, start=s)
        except MjtrackError:
            continue
        out[j] = s.wz / ((vr - vl) / T)
    return out


def class_gap(pred: np.ndarray, ratio: np.ndarray, cls: np.ndarray) -> float:
    """Root of the window-count-weighted mean squared gap of the class medians, predicted minus
    measured (a class with most predictions missing counts as a gap of 1)."""
    num = den = 0.0
    for p, m in zip(class_medians(pred, cls), class_medians(ratio, cls)):
        if p is None:
            continue
        gap = 1.0 if not np.isfinite(p[0]) else p[0] - m[0]
        num, den = num + p[1] * gap * gap, den + p[1]
    return float(np.sqrt(num / den))


def fit(meas: dict, candidate: str, n_points: int) -> dict:
    """The candidate's parameters fitted on the training windows, and its class medians."""
    robot, v, tr = meas["robot"], meas["v"], meas["train"]
    shear_k, sized = candidate.startswith("shear"), candidate.endswith("_length")

    def unpack(p):  # (log K, length factor)
        return (float(np.exp(p[0])) if shear_k else None), (float(p[1]) if sized else 1.0)

    def f(p):  # only the training windows enter the fit
        K, factor = unpack(p)
        return class_gap(predicted(with_length(robot, factor), v[tr], K, n_points), meas["ratio"][tr], meas["cls"][tr])

    lk = np.log(K_BOUNDS)
    if candidate == "coulomb":
        p = np.array([0.0, 1.0])
    elif candidate == "coulomb_length":
        res = optimize.minimize_scalar(lambda a: f([0.0, a]), bounds=LENGTH_BOUNDS, method="bounded",
                                       options={"xatol": 2e-3})
        p = np.array([0.0, res.x])
    elif candidate == "shear":
        grid = np.linspace(*lk, 9)
        best = grid[int(np.argmin([f([g, 1.0]) for g in grid]))]
        res = optimize.minimize_scalar(lambda a: f([a, 1.0]), bounds=(max(lk[0], best - 0.9), min(lk[1], best + 0.9)),
                                       method="bounded", options={"xatol": 0.02})
        p = np.array([res.x, 1.0])
    else:
        starts = [np.array([g, a]) for g in np.linspace(*lk, 5) for a in (0.7, 1.0, 1.5)]
        p0 = min(starts, key=f)
        res = optimize.minimize(f, p0, method="Nelder-Mead", options={"xatol": 0.01, "fatol": 1e-6, "maxiter": 80})
        p = np.clip(res.x, [lk[0], LENGTH_BOUNDS[0]], [lk[1], LENGTH_BOUNDS[1]])
    K, factor = unpack(p)
    r = with_length(robot, factor)
    pred = predicted(r, v, K, n_points)
    key = "wheelbase" if robot.traction == "wheels" else "track_length"
    on_bound = (K is not None and not K_BOUNDS[0] * 1.05 < K < K_BOUNDS[1] / 1.05) or (
        sized and not LENGTH_BOUNDS[0] + 0.01 < factor < LENGTH_BOUNDS[1] - 0.01)
    out = {"shear_modulus": K, key: float(getattr(r, key)), "length_factor": factor, "on_bound": bool(on_bound),
           "parameters": int(shear_k) + int(sized)}
    for part, m in (("train", tr), ("test", ~tr), ("all", np.ones_like(tr))):
        rows = zip(class_medians(pred[m], meas["cls"][m]), class_medians(meas["ratio"][m], meas["cls"][m]))
        out[part] = {"classes": [None if p is None else {"predicted": p[0], "measured": q[0], "windows": p[1],
                                                         "gap": p[0] - q[0]} for p, q in rows],
                     "rms_gap": class_gap(pred[m], meas["ratio"][m], meas["cls"][m]),
                     "no_steady_state": int(np.isnan(pred[m]).sum())}
    return out


CANDIDATES = ("coulomb", "coulomb_length", "shear", "shear_length")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--robots", default=",".join(ROBOTS))
    ap.add_argument("--n-points", type=int, default=60, help="contact points per track of the references (default 60)")
    args = ap.parse_args(argv)
    load0 = os.getloadavg()
    old = json.loads(RESULT.read_text()) if RESULT.exists() else {}
    robots = old.get("robots", {})
    for name in args.robots.split(","):
        t0 = time.time()
        meas = measured_windows(name)
        r = {"traction": meas["robot"].traction, "track_gauge": meas["robot"].track_gauge,
             "windows": int(len(meas["ratio"])), "train_windows": int(meas["train"].sum()),
             "turn_classes": [list(c) for c in TURN_CLASSES], "candidates": {}}
        for cand in CANDIDATES:
            r["candidates"][cand] = fit(meas, cand, args.n_points)
            c = r["candidates"][cand]
            print(f"{name:9s} {cand:15s} K={c['shear_modulus'] if c['shear_modulus'] is None else round(c['shear_modulus'], 5)}"
                  f" length x{c['length_factor']:.3f}  rms gap train {c['train']['rms_gap']:.3f} test "
                  f"{c['test']['rms_gap']:.3f}  classes (pred/meas/n, all): "
                  + "; ".join("-" if k is None else f"{k['predicted']:.3f}/{k['measured']:.3f}/{k['windows']}"
                              for k in c["all"]["classes"]), flush=True)
        fair = [c for c in CANDIDATES if not r["candidates"][c]["on_bound"]]
        r["selected"] = min(fair, key=lambda c: r["candidates"][c]["test"]["rms_gap"]) if fair else None
        r["seconds"] = time.time() - t0
        robots[name] = r
        print(f"{name}: selects {r['selected']} (lowest held-out class gap, no parameter on a bound); {r['seconds']:.0f} s")
    RESULT.parent.mkdir(parents=True, exist_ok=True)
    RESULT.write_text(json.dumps({"command": "python benchmarks/ground_selection.py " + " ".join(sys.argv[1:] if argv is None else argv),
                                  "robots": robots, "n_points": args.n_points, "horizon_s": HORIZON_S,
                                  "train_share": TRAIN_SHARE, "k_bounds": list(K_BOUNDS),
                                  "length_bounds": list(LENGTH_BOUNDS), "patch_length": shear.DEFAULT_PATCH_LENGTH,
                                  "load_before": load0, "load_after": os.getloadavg()}, indent=1) + "\n")
    print(f"load average before {load0[0]:.2f}, after {os.getloadavg()[0]:.2f}; wrote {RESULT}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
