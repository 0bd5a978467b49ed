"""Which ground do the real robots select? The steady yaw ratio by turn class, measured on the
shared DRIVE logs (Marmotte tracked, Husky and Warthog wheeled skid-steer; ../shared/data, BSD-3)
against the steady state of each candidate ground's reference model.

    python benchmarks/ground_selection.py [--robots marmotte,husky,warthog] [--n-points 60]
                                          [--candidates coulomb,shear,...]   # the others kept from the file
    python benchmarks/ground_selection.py --fidelity   # the MuJoCo shear ground against its reference

Measured: the log's windows of 2 s, each window's yaw ratio (chord yaw rate over the nominal
(v_R - v_L)/T of its mean measured track speeds) where calibrate measures one
(:func:`mjtrack.calibrate.measures.turn_measures`: steady commands, nominal yaw rate >= 0.3 rad/s), the
median per |turn ratio| class (:data:`mjtrack.calibrate.measures.TURN_CLASSES`). Predicted: the same
median of the reference's yaw ratio at each window's mean measured track speeds, for the robot as
the log describes it plus the public specification of what it does not give (the starting robot
of ``benchmarks/real_robots.py``), with inertia and load transfer. Candidates, each fitted by
least squares on the class medians (weighted by their window counts) of the first 70 % of the
windows and scored on the rest:

* ``coulomb``: the Coulomb reference (:mod:`mjtrack.models.coulomb`) as described (nothing fitted);
* ``coulomb_length``: Coulomb with the contact length (tracks) / wheelbase (wheels) fitted;
* ``shear``: the shear-displacement ground (:mod:`mjtrack.models.shear`) with K fitted;
* ``shear_length``: shear with K and the contact length / wheelbase fitted;
* ``resistance``: Coulomb with a motion resistance f_r (robot key ``rolling_resistance``, eq. S5
  of the shear reference, evaluated there at K = 0: Coulomb's law, on tyre patches for wheels)
  fitted, the load-dependent resistance candidate;
* ``resistance_length``: the same with the contact length / wheelbase fitted too.

A robot selects, among the candidates with no parameter within 1 % of its search range's ends (a
fit that ends on a bound describes something else), the one with the fewest parameters whose
held-out class gap is within one bootstrap standard error of the lowest (:func:`select`).

A wheel's tyre patch is the reference's default (``mjtrack.models.shear.DEFAULT_PATCH_LENGTH``).
Writes benchmarks/results/ground_selection.json; prints the same and the machine's load.

``--fidelity``: the MuJoCo robot on the shear ground against the same reference, and its Coulomb
limit. For the default robot (T 0.4, L 0.5 m, 20 kg) and the long-track robot of
benchmarks/fidelity.py (T 0.6, L 0.9 m, 60 kg), on the surfacevel track model with its settings
(:func:`mjtrack.sim.config.surfacevel_config`): steady turns from a pivot to a gentle one, slow
and fast, both directions, on the shear ground (``{"model": "shear", "shear_modulus": K}``)
for several K; each case's steady ICRs (:func:`mjtrack.sim.steady.steady_state`) against the
shear reference's (:func:`mjtrack.models.shear.steady_state`, the model's 12 elements as its
contact points). The limit: the same turns at K = 1e-4 m against the MuJoCo robot on the
Coulomb ground. Errors over half the gauge T/2 (the ICR x_c also over the contact length L).
Pass: every ICR within 0.02 T/2 of the reference, and within 0.005 T/2 of the Coulomb robot in
the limit. Writes benchmarks/results/shear_fidelity.json; prints the same and the load.

``--fidelity --track-model rollers``: the same on the roller chain (its default settings, the
reference with the chain's 10 rollers as its contact points) for both tracked robots, and on two
wheeled robots (a small and a large four-wheeler); a wheel's case is also held against the
reference with the wheel touching at one point under its axle (``point_contact``), as MuJoCo's
sphere does (docs/theory/shear.md, "In MuJoCo"). Writes
benchmarks/results/shear_fidelity_rollers.json.

``--fidelity --track-model rollers --lateral-shear-ratios 0.5,2``: the same grid with the shear
modulus across the track or tyre that many times the one along it (``lateral_shear_ratio``, S6 of
mjtrack.models.shear; the MuJoCo contacts on the track's tangent frames), each case against the
reference with that ratio; the limit K = 1e-6 m against the MuJoCo robot on the Coulomb ground with
the same contact frames (the anisotropic ground at lateral ratio 1). Writes
benchmarks/results/shear_fidelity_lateral.json.
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

from mjtrack.calibrate.measures import TURN_CLASSES, measured_speeds, turn_measures
from mjtrack.errors import MjtrackError
from mjtrack.io import read_log_with_robot
from mjtrack.io.robot import Robot
from mjtrack.models import coulomb, shear
from mjtrack.windows import make_windows, measured_window_poses, turn_ratio

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from real_robots import ROBOTS, starting_robot  # noqa: E402  (the same starting robots)

RESULT = HERE / "results" / "ground_selection.json"
HORIZON_S = 2.0
TRAIN_SHARE = 0.7
K_BOUNDS = (1e-4, 0.3)  # [m] shear modulus searched (log scale)
LENGTH_BOUNDS = (0.3, 2.5)  # contact length / wheelbase searched, as a factor of the described one
F_R_BOUNDS = (0.0, 0.5)  # motion resistance searched [-]
BOOTSTRAP = 400  # resamples of the held-out windows (selection's standard error)


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
            if K is not None or robot.rolling_resistance > 0:  # (the Coulomb reference has no resistance)
                s = shear.steady_state(robot, vl, vr, shear_modulus=K or 0.0, n_points=n_points, start=s)
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


#: each candidate's fitted parameters: "K" the shear modulus (searched in log K), "length" the
#: contact length (wheelbase) as a factor of the described one, "f_r" the motion resistance
CANDIDATES = {"coulomb": (), "coulomb_length": ("length",), "shear": ("K",), "shear_length": ("K", "length"),
              "resistance": ("f_r",), "resistance_length": ("f_r", "length")}
BOUNDS = {"K": tuple(np.log(K_BOUNDS)), "length": LENGTH_BOUNDS, "f_r": F_R_BOUNDS}
GRIDS = {"K": 9, "length": 5, "f_r": 9}  # starting grid points of a one-parameter fit
STARTS = {"K": np.linspace(*np.log(K_BOUNDS), 5), "length": (0.7, 1.0, 1.5), "f_r": (0.02, 0.1, 0.3)}


def fit(meas: dict, candidate: str, n_points: int) -> dict:
    """The candidate's parameters fitted on the training windows (a grid, then a bounded scalar
    search for one parameter; the best of a grid of starts, then Nelder-Mead for two), and its
    class medians on the training windows, the held-out ones and all."""
    robot, v, tr = meas["robot"], meas["v"], meas["train"]
    names = CANDIDATES[candidate]

    def model(p):  # (robot, K)
        d = dict(zip(names, p))
        r = with_length(robot, d.get("length", 1.0)).replace(rolling_resistance=float(d.get("f_r", 0.0)))
        return r, (float(np.exp(d["K"])) if "K" in d else None)

    def f(p):  # only the training windows enter the fit
        r, K = model(p)
        return class_gap(predicted(r, v[tr], K, n_points), meas["ratio"][tr], meas["cls"][tr])

    lo, hi = np.array([BOUNDS[n][0] for n in names]), np.array([BOUNDS[n][1] for n in names])
    if not names:
        p = np.zeros(0)
    elif len(names) == 1:
        grid = np.linspace(lo[0], hi[0], GRIDS[names[0]])
        best = grid[int(np.argmin([f([g]) for g in grid]))]
        step = grid[1] - grid[0]
        res = optimize.minimize_scalar(lambda a: f([a]), bounds=(max(lo[0], best - step), min(hi[0], best + step)),
                                       method="bounded", options={"xatol": 1e-3 * (hi[0] - lo[0])})
        p = np.array([res.x])
    else:
        starts = [np.array(q) for q in np.stack(np.meshgrid(*(STARTS[n] for n in names)), -1).reshape(-1, len(names))]
        p0 = min(starts, key=f)
        res = optimize.minimize(f, p0, method="Nelder-Mead", bounds=list(zip(lo, hi)),
                                options={"xatol": 0.01, "fatol": 1e-6, "maxiter": 80})
        p = np.clip(res.x, lo, hi)
    r, K = model(p)
    pred = predicted(r, v, K, n_points)
    key = "wheelbase" if robot.traction == "wheels" else "track_length"
    margin = 0.01 * (hi - lo)
    out = {"shear_modulus": K, key: float(getattr(r, key)), "length_factor": float(getattr(r, key) / getattr(robot, key)),
           "rolling_resistance": r.rolling_resistance, "parameters": len(names),
           "on_bound": bool(np.any((p < lo + margin) | (p > hi - margin)))}
    for part, m in (("train", tr), ("test", ~tr), ("all", np.ones_like(tr))):
        rows = zip(class_medians(pred[m], meas["cls"][m]), class_medians(meas["ratio"][m], meas["cls"][m]))
        out[part] = {"classes": [None if p is None else {"predicted": p[0], "measured": q[0], "windows": p[1],
                                                         "gap": p[0] - q[0]} for p, q in rows],
                     "rms_gap": class_gap(pred[m], meas["ratio"][m], meas["cls"][m]),
                     "no_steady_state": int(np.isnan(pred[m]).sum())}
    out["window_predictions"] = [None if np.isnan(x) else float(x) for x in pred]  # for the selection's bootstrap
    return out


def select(r: dict, seed: int = 0) -> dict:
    """The ground a robot selects: among the candidates with no parameter on a bound, the one with
    the fewest parameters whose held-out class gap is within one bootstrap standard error (held-out
    windows resampled, ``BOOTSTRAP`` times, seeded) of the lowest (the one-standard-error rule: a
    parameter is kept only when the held-out windows show it helps)."""
    ratio, cls = np.array(r["window_ratios"]), np.array(r["window_classes"])
    test = ~np.array(r["window_train"])
    fair = {c: np.array([np.nan if x is None else x for x in k["window_predictions"]])
            for c, k in r["candidates"].items() if not k["on_bound"]}
    if not fair:
        return {"selected": None}
    gaps = {c: class_gap(p[test], ratio[test], cls[test]) for c, p in fair.items()}
    best = min(gaps, key=gaps.get)
    rng = np.random.default_rng(seed)
    idx = np.flatnonzero(test)
    boot = []
    for _ in range(BOOTSTRAP):
        b = rng.choice(idx, idx.size)
        boot.append(class_gap(fair[best][b], ratio[b], cls[b]))
    se = float(np.std(boot))
    near = [c for c in fair if gaps[c] <= gaps[best] + se]
    chosen = min(near, key=lambda c: (r["candidates"][c]["parameters"], gaps[c]))
    return {"selected": chosen, "lowest": best, "lowest_gap": gaps[best], "standard_error": se,
            "within_one_se": sorted(near)}


FIDELITY_RESULT = HERE / "results" / "shear_fidelity.json"
# --fidelity: the MuJoCo shear ground against its reference
GEOMETRIES = {"default": Robot(), "long": Robot(track_gauge=0.6, track_length=0.9, mass=60.0, cg_z=0.2)}
SPEEDS = [(-0.5, 0.5), (0.0, 0.6), (0.2, 0.6), (0.6, 0.2), (0.5, 0.7), (1.0, 1.4)]
MODULI = (0.01, 0.03, 0.1)  # [m]
LIMIT_K = 1e-4  # [m]
# [m] the limit of the run with lateral_shear_ratio values: a wheel's 0.1 m patch in a gentle turn
# builds up a shear displacement of about 1e-4 m, so at K = 1e-4 m the modulus across (ratio x K) is not
# yet the limit there (measured: the reference itself moves by up to 0.035 T/2 from Coulomb at ratio 3)
LATERAL_LIMIT_K = 1e-6
TOLERANCE = 0.02  # of T/2, against the reference
LIMIT_TOLERANCE = 0.005  # of T/2, against the Coulomb robot


def mujoco_icr(robot, vl: float, vr: float, config) -> np.ndarray:
    from mjtrack.sim.steady import steady_state

    s = steady_state(robot, vl, vr, config=config)
    return np.array([s.y_l, s.y_r, s.x_c])


# the wheeled robots of the roller-chain run: a small and a large four-wheeler (gauge, wheelbase, wheel
# radius, mass, cg height about those of the shared Husky and Warthog logs' descriptions)
WHEELED = {"wheels_small": Robot(traction="wheels", track_gauge=0.55, wheelbase=0.51, sprocket_radius=0.165,
                                 mass=50.0, cg_z=0.2),
           "wheels_large": Robot(traction="wheels", track_gauge=1.1, wheelbase=1.1, sprocket_radius=0.3,
                                 mass=280.0, cg_z=0.4)}


def fidelity(command: str, track_model: str = "surfacevel", ratios: tuple[float, ...] = (1.0,)) -> int:
    """The ``--fidelity`` run (module docstring); 0 when every case passes. ``ratios``: the shear
    ground's ``lateral_shear_ratio`` values (other than 1: the roller chain and the wheels only)."""
    from mjtrack.sim.config import SimConfig, surfacevel_config

    load0 = os.getloadavg()
    config = surfacevel_config() if track_model == "surfacevel" else SimConfig()
    geometries = GEOMETRIES if track_model == "surfacevel" else {**GEOMETRIES, **WHEELED}
    t0 = time.time()
    cases, limit, no_reference = [], [], []
    for geometry, base in geometries.items():
        half, L = base.track_gauge / 2, base.contact_length
        for vl, vr in SPEEDS:
            for K, ratio in ((K, ratio) for K in MODULI for ratio in ratios):
                robot = base.replace(ground={"model": "shear", "shear_modulus": K, "lateral_shear_ratio": ratio})
                try:
                    ref = np.array(shear.steady_state(robot, vl, vr, n_points=config.n_rollers).icr)
                except MjtrackError as e:  # the reference's own solve failed: no case, counted
                    no_reference.append({"geometry": geometry, "v_left": vl, "v_right": vr, "shear_modulus": K,
                                         "lateral_shear_ratio": ratio, "why": str(e)})
                    print(f"{geometry:8s} ({vl:+.1f}, {vr:+.1f}) K={K:<5g} no reference: {e}", flush=True)
                    continue
                got = mujoco_icr(robot, vl, vr, config)
                err = np.abs(got - ref)
                case = {"geometry": geometry, "traction": base.traction, "v_left": vl, "v_right": vr,
                        "shear_modulus": K, "lateral_shear_ratio": ratio, "mujoco": got.tolist(), "reference": ref.tolist(),
                        "err_over_half_gauge": float(err.max() / half), "err_x_over_length": float(err[2] / L),
                        "passed": bool(err.max() <= TOLERANCE * half)}
                if base.traction == "wheels":
                    point = np.array(shear.steady_state(robot, vl, vr, point_contact=True).icr)
                    case["point_contact_reference"] = point.tolist()
                    case["err_point_over_half_gauge"] = float(np.abs(got - point).max() / half)
                    case["err_y_over_half_gauge"] = float(err[:2].max() / half)
                cases.append(case)
                print(f"{geometry:8s} ({vl:+.1f}, {vr:+.1f}) K={K:<5g} ratio {ratio:g} mujoco {np.round(got, 4)} reference "
                      f"{np.round(ref, 4)}  max err {err.max() / half:.4f} T/2", flush=True)
            # the Coulomb robot with the same contacts: a ratio other than 1 puts them on the track's frames
            framed = ratios != (1.0,)
            coulomb_robot = mujoco_icr(base.replace(ground={"model": "anisotropic", "lateral_ratio": 1.0}) if framed
                                       else base, vl, vr, config)
            limit_k = LATERAL_LIMIT_K if framed else LIMIT_K
            for ratio in ratios:
                near = mujoco_icr(base.replace(ground={"model": "shear", "shear_modulus": limit_k,
                                                       "lateral_shear_ratio": ratio}), vl, vr, config)
                d = np.abs(near - coulomb_robot)
                limit.append({"geometry": geometry, "v_left": vl, "v_right": vr, "shear_modulus": limit_k,
                              "lateral_shear_ratio": ratio, "shear": near.tolist(), "coulomb": coulomb_robot.tolist(),
                              "diff_over_half_gauge": float(d.max() / half),
                              "passed": bool(d.max() <= LIMIT_TOLERANCE * half)})
                print(f"{geometry:8s} ({vl:+.1f}, {vr:+.1f}) K={limit_k:g} ratio {ratio:g} vs the Coulomb robot: "
                      f"{d.max() / half:.5f} T/2", flush=True)
    summary = {"cases": len(cases), "passed": sum(c["passed"] for c in cases), "no_reference": len(no_reference),
               "max_err_over_half_gauge": max(c["err_over_half_gauge"] for c in cases),
               "max_err_x_over_length": max(c["err_x_over_length"] for c in cases),
               "limit_cases": len(limit), "limit_passed": sum(c["passed"] for c in limit),
               "limit_max_diff_over_half_gauge": max(c["diff_over_half_gauge"] for c in limit)}
    for traction in sorted({c["traction"] for c in cases}):
        own = [c for c in cases if c["traction"] == traction]
        lim = [c for c, g in zip(limit, [c["geometry"] for c in limit]) if geometries[g].traction == traction]
        part = {"cases": len(own), "passed": sum(c["passed"] for c in own),
                "max_err_over_half_gauge": max(c["err_over_half_gauge"] for c in own),
                "limit_cases": len(lim), "limit_passed": sum(c["passed"] for c in lim),
                "limit_max_diff_over_half_gauge": max(c["diff_over_half_gauge"] for c in lim)}
        if traction == "wheels":
            part |= {"max_err_y_over_half_gauge": max(c["err_y_over_half_gauge"] for c in own),
                     "max_err_point_over_half_gauge": max(c["err_point_over_half_gauge"] for c in own),
                     "passed_point": sum(c["err_point_over_half_gauge"] <= TOLERANCE for c in own)}
        summary[traction] = part
    out = (FIDELITY_RESULT if track_model == "surfacevel" else
           FIDELITY_RESULT.with_name("shear_fidelity_rollers.json" if ratios == (1.0,) else "shear_fidelity_lateral.json"))
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps({"command": command,
                                  "track_model": track_model, "n_elements": config.n_rollers,
                                  "lateral_shear_ratios": list(ratios),
                                  "tolerance_over_half_gauge": TOLERANCE, "limit_tolerance_over_half_gauge": LIMIT_TOLERANCE,
                                  "summary": summary, "cases": cases, "limit": limit, "no_reference": no_reference, "elapsed_s": time.time() - t0,
                                  "load_before": load0, "load_after": os.getloadavg()}, indent=1) + "\n")
    print(f"{summary['passed']}/{summary['cases']} within {TOLERANCE} T/2 (worst {summary['max_err_over_half_gauge']:.4f}); "
          f"limit {summary['limit_passed']}/{summary['limit_cases']} within {LIMIT_TOLERANCE} T/2 (worst "
          f"{summary['limit_max_diff_over_half_gauge']:.5f}); {time.time() - t0:.0f} s; load {load0[0]:.2f} -> "
          f"{os.getloadavg()[0]:.2f}")
    return 0 if summary["passed"] == summary["cases"] and summary["limit_passed"] == summary["limit_cases"] else 1


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--robots", default=",".join(ROBOTS))
    ap.add_argument("--n-points", type=int, default=60, help="contact points per track of the references (default 60)")
    ap.add_argument("--candidates", default=",".join(CANDIDATES),
                    help="candidates to fit (default all); the others keep what the result file holds")
    ap.add_argument("--fidelity", action="store_true",
                    help="instead: the MuJoCo shear ground against its reference (benchmarks/results/shear_fidelity.json)")
    ap.add_argument("--track-model", choices=("surfacevel", "rollers"), default="surfacevel",
                    help="--fidelity: the track model (rollers: the roller chain and two wheeled robots, "
                         "benchmarks/results/shear_fidelity_rollers.json)")
    ap.add_argument("--lateral-shear-ratios", default=None,
                    help="--fidelity --track-model rollers: the shear ground's lateral_shear_ratio values, comma "
                         "separated (benchmarks/results/shear_fidelity_lateral.json)")
    args = ap.parse_args(argv)
    load0 = os.getloadavg()
    command = "python benchmarks/ground_selection.py " + " ".join(sys.argv[1:] if argv is None else argv)
    if args.fidelity:
        try:
            ratios = (1.0,) if args.lateral_shear_ratios is None else tuple(
                float(v) for v in args.lateral_shear_ratios.split(","))
        except ValueError:
            ap.error(f"--lateral-shear-ratios: numbers separated by commas, got {args.lateral_shear_ratios!r}")
        if ratios != (1.0,) and args.track_model != "rollers":
            ap.error("--lateral-shear-ratios needs --track-model rollers (the surfacevel model has the isotropic shear ground)")
        return fidelity(command.strip(), args.track_model, ratios)
    old = json.loads(RESULT.read_text()) if RESULT.exists() else {}
    robots = old.get("robots", {})
    for name in args.robots.split(","):
        t0 = time.time()
        meas = measured_windows(name)
        r = {"traction": meas["robot"].traction, "track_gauge": meas["robot"].track_gauge,
             "windows": int(len(meas["ratio"])), "train_windows": int(meas["train"].sum()),
             "turn_classes": [list(c) for c in TURN_CLASSES], "window_ratios": meas["ratio"].tolist(),
             "window_classes": meas["cls"].tolist(), "window_train": meas["train"].tolist(),
             "candidates": robots.get(name, {}).get("candidates", {}), "commands": robots.get(name, {}).get("commands", [])}
        for cand in args.candidates.split(","):
            r["candidates"][cand] = fit(meas, cand, args.n_points)
            c = r["candidates"][cand]
            print(f"{name:9s} {cand:15s} K={c['shear_modulus'] if c['shear_modulus'] is None else round(c['shear_modulus'], 5)}"
                  f" length x{c['length_factor']:.3f}  rms gap train {c['train']['rms_gap']:.3f} test "
                  f"{c['test']['rms_gap']:.3f}  classes (pred/meas/n, all): "
                  + "; ".join("-" if k is None else f"{k['predicted']:.3f}/{k['measured']:.3f}/{k['windows']}"
                              for k in c["all"]["classes"]), flush=True)
        r["selection"] = select(r)
        r["selected"] = r["selection"]["selected"]
        r["seconds"] = robots.get(name, {}).get("seconds", 0.0) + time.time() - t0  # over every run that made it
        r["commands"] = r["commands"] + [command]
        robots[name] = r
        print(f"{name}: selects {r['selected']} ({r['selection']}); {r['seconds']:.0f} s")
    RESULT.parent.mkdir(parents=True, exist_ok=True)
    RESULT.write_text(json.dumps({"command": "; ".join(sorted({c for r in robots.values() for c in r["commands"]})),
                                  "robots": robots, "n_points": args.n_points, "horizon_s": HORIZON_S,
                                  "train_share": TRAIN_SHARE, "k_bounds": list(K_BOUNDS),
                                  "length_bounds": list(LENGTH_BOUNDS), "patch_length": shear.DEFAULT_PATCH_LENGTH,
                                  "load_before": load0, "load_after": os.getloadavg()}, indent=1) + "\n")
    print(f"load average before {load0[0]:.2f}, after {os.getloadavg()[0]:.2f}; wrote {RESULT}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
