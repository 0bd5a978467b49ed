"""Seeded benchmark of `mjtrack diagnose` on logs from an INDEPENDENT physics generator.

The logs come from mjtrack/testing/diagnose_physics.py (its own rigid-body simulation: Gauss-Legendre
contact grids or four wheel contacts, regularised Coulomb friction, plane-pressure load
transfer, linearly implicit Euler), which shares no dynamics code with the diagnosis. Cases:
every single effect at three magnitudes (the smallest near the noise), pairs (ground + ground,
input + input, input + ground), clean logs; three geometries (small and large tracked robots, a
wheeled skid-steer robot), 10 / 20 / 50 Hz, 30 s to 10 min, continuous and DRIVE-layout
(2 s windows of 1.95 s) logs, with and without measured track speeds. The baseline is passed
explicitly (surrogate).

Scoring. A log is named right when every hidden effect is among the effects the diagnosis
found (a finding tied with one by physics counts: cg_offset_y and friction_asymmetry set the
same traction ratio, and the report says so), and a clean log when the cause is "none". Extra
effects named beside the truth are counted separately. Intervals and bias: every parameter of
every hidden effect found: does the 95 % interval cover the truth, and the relative error
(estimate - truth)/|truth| (slope_direction: the angle error over pi).

Detectability floor. The gain test is a blocked bootstrap over blocks of windows: an effect
that acts in k of the log's B blocks shows no gain in a replicate that draws none of them,
probability (1 - k/B)^B, so its one-sided 95 % bound cannot exceed zero unless that is below
5 % (k >= 3 of 40 blocks; ``mjtrack.diagnose.select.min_active_blocks``). Whether a hidden
input effect acts in a block is read off the generator's own noise-free track speeds (with and
without the effect: RMS difference in the block above the speed-sensor noise, the first sample
of each segment left out: the diagnosis starts a segment from its measured speed), the blocks are
the diagnosis's (segments and horizon; the fold cuts ignored). A log whose hidden input effect
acts in fewer blocks than the floor is *below the floor*: it is reported on its own line --
what the diagnosis said, whether it named a wrong cause (fooled) and whether it warned -- and
left out of "named right", which is printed with and without it.

``--seed N`` adds N to every case's seed: the same cases on fresh logs (the benchmark was
developed on offset 0).

    python benchmarks/diagnose_benchmark.py [--fast] [--only N,M] [--seed N] [--json OUT]
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import numpy as np

from mjtrack.diagnose import diagnose
from mjtrack.diagnose.stats import min_active_blocks, sample_blocks
from mjtrack.diagnose.surrogate import MODEL_REL
from mjtrack.diagnose.ties import TRACTION_PAIR
from mjtrack.testing.diagnose_physics import INPUT, SPEED_STD, make_log
from _results import RESULTS
from mjtrack.testing.effect_names import VOCABULARY_NAME, vocabulary_params

MAGNITUDES = {
    "cg_offset_x": [{"cg_offset_x": v} for v in (0.02, 0.05, -0.1)],
    "cg_offset_y": [{"cg_offset_y": v} for v in (-0.02, 0.05, -0.08)],
    "friction_scale": [{"friction_scale": v} for v in (0.7, 0.5, 0.35)],
    "friction_asymmetry": [{"friction_asymmetry": v} for v in (0.85, 0.7, 1.6)],
    "slope": [{"slope": s, "slope_direction": d} for s, d in ((0.03, 0.5), (0.08, -2.0), (0.15, 2.5))],
    "track_speed_scale": [{"track_speed_scale": v} for v in (0.96, 0.9, 0.8)],
    "actuator_lag": [{"actuator_lag": v} for v in (0.08, 0.2, 0.4)],
    "command_delay": [{"command_delay": v} for v in (0.05, 0.15, 0.3)],
    "speed_limit": [{"speed_limit": v} for v in (0.85, 0.7, 0.5)],
    "yaw_rate_limit": [{"yaw_rate_limit": v} for v in (2.5, 1.8, 1.2)],
}
# (geometry, rate Hz, duration s, layout, speeds) cycled over the single-effect cases
SETTINGS = [("small", 20, 180, "continuous", False), ("large", 10, 240, "continuous", True),
            ("small", 50, 120, "continuous", True), ("wheeled", 20, 240, "drive", True),
            ("small", 20, 600, "continuous", False), ("large", 20, 60, "continuous", False),
            ("small", 10, 300, "drive", False), ("wheeled", 20, 180, "continuous", True)]
PAIRS = [  # ground + ground, input + input, input + ground
    ({"cg_offset_x": 0.06, "friction_asymmetry": 0.6}, ("small", 20, 300, "continuous", False)),
    ({"cg_offset_x": -0.08, "slope": 0.1, "slope_direction": 1.0}, ("large", 20, 240, "continuous", False)),
    ({"actuator_lag": 0.25, "speed_limit": 0.6}, ("small", 20, 240, "continuous", True)),
    ({"command_delay": 0.2, "track_speed_scale": 0.85}, ("wheeled", 20, 240, "drive", True)),
    ({"actuator_lag": 0.2, "cg_offset_x": 0.06}, ("small", 20, 240, "continuous", False)),
    ({"speed_limit": 0.6, "friction_asymmetry": 0.6}, ("large", 10, 300, "continuous", True)),
]
CLEAN = [("small", 20, 240, "continuous", False), ("large", 10, 600, "continuous", True),
         ("wheeled", 20, 240, "drive", True), ("small", 50, 30, "continuous", False),
         ("wheeled", 10, 120, "continuous", False)]
SLOW_GROUND = {"friction_scale"}  # acts through the inertial response only: needs fast turns


def cases() -> list[dict]:
    out = []
    i = 0
    for name, mags in MAGNITUDES.items():
        for k, p in enumerate(mags):
            geo, rate, dur, layout, speeds = SETTINGS[i % len(SETTINGS)]
            if name in ("cg_offset_x", "cg_offset_y", "friction_asymmetry", "friction_scale", "slope") and geo == "wheeled":
                geo = "small"  # the ground effects are checked on the tracked robots
            if name == "yaw_rate_limit" and k == 0:
                geo = "wheeled"
            out.append({"id": len(out), "truth": p, "geometry": geo, "rate": rate, "duration": dur, "layout": layout,
                        "speeds": speeds, "seed": 100 + len(out)})
            i += 1
    for p, (geo, rate, dur, layout, speeds) in PAIRS:
        out.append({"id": len(out), "truth": p, "geometry": geo, "rate": rate, "duration": dur, "layout": layout,
                    "speeds": speeds, "seed": 100 + len(out)})
    for geo, rate, dur, layout, speeds in CLEAN:
        out.append({"id": len(out), "truth": {}, "geometry": geo, "rate": rate, "duration": dur, "layout": layout,
                    "speeds": speeds, "seed": 100 + len(out)})
    return out


# the short logs, and a clean and a delay + scale wheeled DRIVE log (the window-chained transient),
# run by the default tests (tests/test_diagnose_benchmark.py)
FAST = [13, 21, 39, 38, 33]


def effects_of(truth: dict) -> set[str]:
    return {k for k in truth if k != "slope_direction"}


def active_blocks(log, v_true: np.ndarray, v_nominal: np.ndarray, horizon_s: float) -> tuple[int, int]:
    """(blocks in which the hidden input effects change the true track speeds by more than the
    speed-sensor noise (RMS over the block), blocks of the log) (module docstring)."""
    seg = np.zeros(len(log.t), dtype=np.int64)
    for k, sl in enumerate(log.segment_slices()):
        seg[sl] = k
    block = sample_blocks(np.asarray(log.t, float), seg, horizon_s)
    # a segment's first speed is no evidence: the diagnosis starts every segment from the speed
    # measured there (a DRIVE window that starts right after a spin would count the spin's last speed)
    first = np.r_[True, seg[1:] != seg[:-1]]
    n = np.bincount(block, weights=(~first).astype(float))
    sq = np.bincount(block, weights=np.where(first, 0.0, np.sum((v_true - v_nominal) ** 2, 1)))
    return int(np.sum(np.sqrt(sq / np.maximum(2 * n, 1)) > SPEED_STD)), int(n.size)


def run_case(c: dict, seed_offset: int = 0) -> dict:
    t0 = time.perf_counter()
    c = {**c, "seed": c["seed"] + seed_offset}
    log, robot, v_true, v_nominal = make_log(c["truth"], geometry=c["geometry"], seed=c["seed"], duration=c["duration"],
                                             rate=c["rate"], speeds=c["speeds"], layout=c["layout"], true_speeds=True)
    t1 = time.perf_counter()
    d = diagnose(log, robot, baseline="surrogate")
    t2 = time.perf_counter()
    hidden = effects_of(c["truth"])  # the generator's names; the diagnosis speaks the vocabulary's
    truth = {VOCABULARY_NAME.get(e, e) for e in hidden}
    truth_params = vocabulary_params(c["truth"], track_gauge=robot.track_gauge)
    floor = None
    if hidden & set(INPUT):
        k, n_blocks = active_blocks(log, v_true, v_nominal, d.horizon_s)
        floor = {"active": k, "blocks": n_blocks, "need": min_active_blocks(n_blocks)}
    below = floor is not None and floor["active"] < floor["need"]
    found = {r.effect.name: r for r in d.findings}
    chosen = [r.effect.name for r in d.chosen]
    named = {}
    for eff in truth:
        if eff in found:
            named[eff] = found[eff]
        elif eff in TRACTION_PAIR:
            other = TRACTION_PAIR[1 - TRACTION_PAIR.index(eff)]
            if other in found and found[other].tie_notes:
                named[eff] = None  # named through the physical tie (the report says so)
    right = (d.cause == "none") if not truth else len(named) == len(truth)
    extra = [n for n in chosen if n not in truth and not (n in TRACTION_PAIR and set(TRACTION_PAIR) & truth)]
    params = []
    for eff, r in named.items():
        if r is None:
            continue
        for j, pname in enumerate(r.effect.params):
            true = truth_params[pname]
            est = float(r.estimate[j])
            lo, hi = (float(x) for x in r.interval[j])
            covered = bool(lo <= true <= hi)
            # a slope component relative to the slope's size (a component may be near zero)
            size = np.hypot(truth_params["slope_x"], truth_params["slope_y"]) if eff == "slope" else abs(true)
            rel = (est - true) / size
            params.append({"param": pname, "truth": true, "estimate": est, "interval": [lo, hi], "covered": covered,
                           "rel_err": float(rel)})
    return {**c, "cause": d.cause, "chosen": chosen, "findings": list(found), "right": bool(right), "extra": extra,
            "floor": floor, "below_floor": bool(below),
            "fooled": bool(below and any(n not in truth for n in chosen)),
            "warned": bool(below and any(n in w for n in truth for w in d.warnings())),
            "params": params, "horizon": d.horizon_s, "warnings": d.warnings(),
            "ties": {r.effect.name: r.tied_with for r in d.findings if r.tied_with},
            "sim_s": t1 - t0, "diagnose_s": t2 - t1}


def summarise(rows: list[dict]) -> dict:
    timing = float(np.median([r["diagnose_s"] for r in rows]))
    below = [r for r in rows if r["below_floor"]]
    all_effect_rows = [r for r in rows if r["truth"]]
    rows = [r for r in rows if not r["below_floor"]]
    effect_rows = [r for r in rows if r["truth"]]
    clean_rows = [r for r in rows if not r["truth"]]
    params = [p for r in rows for p in r["params"]]
    pairs = [r for r in effect_rows if len(effects_of(r["truth"])) > 1]
    return {
        "logs": len(rows) + len(below),
        "below_floor": len(below), "below_floor_fooled": sum(r["fooled"] for r in below),
        "below_floor_warned": sum(r["warned"] for r in below),
        "named_right_all": sum(r["right"] for r in all_effect_rows), "with_effect_all": len(all_effect_rows),
        "named_right": sum(r["right"] for r in effect_rows), "with_effect": len(effect_rows),
        "pairs_right": sum(r["right"] for r in pairs), "pairs": len(pairs),
        "extra_effects": sum(bool(r["extra"]) for r in effect_rows),
        "clean_none": sum(r["right"] for r in clean_rows), "clean": len(clean_rows),
        "covered": sum(p["covered"] for p in params), "params": len(params),
        "median_abs_bias": float(np.median([abs(p["rel_err"]) for p in params])) if params else float("nan"),
        "worst_abs_bias": float(np.max([abs(p["rel_err"]) for p in params])) if params else float("nan"),
        "median_diagnose_s": timing,
        "load": os.getloadavg(),
    }


def model_error_on_mujoco() -> tuple[float, int]:
    """RMS relative error of the surrogate's estimates on the stored MuJoCo matrix
    (benchmarks/diagnose_mujoco_effects.py), as a share of
    the effect size |truth - nominal| (the interval's model term MODEL_REL in
    mjtrack/diagnose/surrogate/baseline.py comes from it): (rms, count)."""
    path = RESULTS / "diagnose_mujoco_effects.json"
    nominal = {"cg_offset_x": 0.0, "cg_offset_y": 0.0, "friction_scale": 1.0, "friction_asymmetry": 1.0,
               "track_speed_scale": 1.0, "slope": 0.0, "actuator_lag": 0.0, "command_delay": 0.0}
    rel = [(row["estimate"][k] - t) / abs(t - nominal[k]) for row in json.loads(path.read_text())["rows"]
           for k, t in row["injected"].items() if k in nominal and k in row.get("estimate", {})]
    return float(np.sqrt(np.mean(np.square(rel)))), len(rel)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--fast", action="store_true", help="the fast subset only")
    ap.add_argument("--only", default="", help="comma-separated case ids")
    ap.add_argument("--json", type=Path, default=None,
                    help="write every case's result here (default, for the whole benchmark: "
                         "benchmarks/results/diagnose_benchmark.json, diagnose_benchmark_seedN.json with --seed N)")
    ap.add_argument("--seed", type=int, default=0, help="add this to every case's seed (fresh logs)")
    args = ap.parse_args()
    all_cases = cases()
    todo = all_cases
    if args.fast:
        todo = [all_cases[i] for i in FAST]
    if args.only:
        todo = [all_cases[int(i)] for i in args.only.split(",")]
    print(f"{len(all_cases)} cases; running {len(todo)}; seed offset {args.seed}; load {os.getloadavg()}", flush=True)
    rows = []
    for c in todo:
        r = run_case(c, args.seed)
        rows.append(r)
        truth = ", ".join(f"{k}={v:g}" for k, v in r["truth"].items()) or "clean"
        est = "; ".join(f"{p['param']}={p['estimate']:.4g} [{p['interval'][0]:.4g}, {p['interval'][1]:.4g}]"
                        f"{'' if p['covered'] else ' MISS'}" for p in r["params"])
        fl = r["floor"]
        floor = f" | acts in {fl['active']}/{fl['blocks']} blocks" if fl else ""
        if r["below_floor"]:
            floor += (f" BELOW FLOOR ({fl['need']}): {'FOOLED' if r['fooled'] else 'not fooled'}, "
                      f"{'warned' if r['warned'] else 'no warning'}")
        print(f"{r['id']:2d} {'ok ' if r['right'] else 'BAD'} {r['geometry']:7s} {r['rate']:2d} Hz {r['duration']:4d} s "
              f"{r['layout']:10s} speeds={int(r['speeds'])} | {truth} -> {'+'.join(r['chosen']) or 'none'}"
              f"{' extra ' + ','.join(r['extra']) if r['extra'] else ''} | {est} | {r['diagnose_s']:.1f} s{floor}", flush=True)
    s = summarise(rows)
    print(f"\nnamed right: {s['named_right']}/{s['with_effect']} logs with effects "
          f"({100 * s['named_right'] / max(s['with_effect'], 1):.1f} %; pairs {s['pairs_right']}/{s['pairs']}; "
          f"{s['extra_effects']} logs with an extra effect named beside the truth)")
    print(f"  logs whose hidden effect acts in fewer blocks than the detectability floor: {s['below_floor']} "
          f"(left out above; {s['below_floor_fooled']} named a wrong cause, {s['below_floor_warned']} warned of the "
          f"effect); counting them as misses: {s['named_right_all']}/{s['with_effect_all']} "
          f"({100 * s['named_right_all'] / max(s['with_effect_all'], 1):.1f} %)")
    print(f"clean logs with cause none: {s['clean_none']}/{s['clean']}")
    print(f"95 % intervals covering the truth: {s['covered']}/{s['params']} "
          f"({100 * s['covered'] / max(s['params'], 1):.1f} %)")
    print(f"median |bias| {100 * s['median_abs_bias']:.1f} % (worst {100 * s['worst_abs_bias']:.1f} %)")
    print(f"median diagnosis time {s['median_diagnose_s']:.1f} s; load {s['load']}")
    rms, n = model_error_on_mujoco()
    print(f"interval model term: the surrogate's RMS relative error on {n} MuJoCo estimates "
          f"(benchmarks/results/diagnose_mujoco_effects.json) is {100 * rms:.1f} % of the effect size "
          f"(MODEL_REL = {MODEL_REL})")
    json_out = args.json
    if json_out is None and not (args.fast or args.only):  # a subset never replaces the stored whole
        json_out = RESULTS / f"diagnose_benchmark{f'_seed{args.seed}' if args.seed else ''}.json"
    if json_out:
        json_out.write_text(json.dumps({"summary": s, "cases": rows}, indent=1, default=float) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
