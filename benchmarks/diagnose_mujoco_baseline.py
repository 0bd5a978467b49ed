"""``diagnose --baseline mujoco`` on MuJoCo logs with one hidden effect each: named and estimated?

    python benchmarks/diagnose_mujoco_baseline.py [--duration 60] [--hidden a,b] [--all] [--out FILE.json]

Logs: mjtrack/testing/mujoco_effects.py (the MuJoCo robot with one hidden effect, seeded random step
commands, 20 Hz, noisy poses; written without mjtrack.diagnose; the anisotropic ground there is
its own implementation, not mjtrack.sim.ground), and a clean log. The diagnosis is given the
nominal robot (with the generator's drive force limit, 600 N m at the 6 cm sprocket = 10 kN per
track) and runs as ``mjtrack diagnose LOG --baseline mujoco`` does
(:func:`mjtrack.diagnose.diagnose` with ``baseline="mujoco"``: the surrogate pre-screens its 3 best
effects, plus the two MuJoCo-only grounds; ``--all``: every MuJoCo candidate, no pre-screen), 5 folds.

Printed per log: the cause, the hidden effect's estimate with its 95 % interval, whether the
interval holds the truth, the held-out gain and its one-sided 95 % bound, the effects tied with
it, the candidates MuJoCo fitted, and the wall time with the machine's load average (shared
2-core machine). Then: the MuJoCo baseline's own error on an effect's size (RMS of |estimate -
truth| / |truth - nominal| over the hidden effects: :data:`MODEL_REL` of
mjtrack.diagnose.mujoco_baseline is set from it), and the intervals' coverage with the model
term measured on the other nine effects only (leave one effect out: no effect's own error
widens its own interval).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import time
from pathlib import Path

import numpy as np

from mjtrack.diagnose import diagnose
from mjtrack.diagnose import mujoco_baseline as mb
from mjtrack.diagnose.stats import t_quantile
from mjtrack.io.robot import Robot
from mjtrack.testing.effect_names import VOCABULARY_NAME, vocabulary_params
from mjtrack.testing.mujoco_effects import HIDDEN, ROBOT, make_log
from _results import RESULTS


DRIVE_FORCE_LIMIT = 600.0 / ROBOT.sprocket_radius  # [N] the generator's drives (mujoco_effects.DRIVES)


def nominal_robot() -> Robot:
    """The robot the diagnosis is told about: the generator's nominal robot and drives."""
    return Robot.from_dict({**ROBOT.to_dict(), "drive_force_limit": DRIVE_FORCE_LIMIT})


def truth_of(effect: str) -> dict[str, float]:
    """A hidden effect's true parameters in the diagnosis's names (a slope as its components)."""
    return vocabulary_params(HIDDEN[effect].params)


def run_one(effect: str | None, *, duration: float, seed: int, n_folds: int, screen: int | None) -> dict:
    lg, _ = make_log(effect, seed=seed, duration=duration)
    t0 = time.perf_counter()
    d = diagnose(lg, nominal_robot(), baseline="mujoco", n_folds=n_folds, screen=screen)
    wall = time.perf_counter() - t0
    blocks = d.results[0].gain.blocks if d.results else 0
    row = {"hidden": effect or "none", "cause": d.cause, "wall_s": wall, "load_average": os.getloadavg(),
           "windows": int(d.starts.size), "diverged": d.diverged, "blocks": blocks, "before": d.before,
           "fitted": [c.effect.name for c in d.results], "screened": d.choice.get("screened_by_surrogate"),
           "findings": [c.effect.name for c in d.findings], "timings_s": d.timings}
    if effect is None:
        return row
    name = VOCABULARY_NAME.get(effect, effect)  # the generator's name -> the diagnosis's
    row["truth"] = truth_of(effect)
    c = next((c for c in d.results if c.effect.name == name), None)
    row["named"] = bool(c is not None and c.passed and (d.cause == name or d.cause in c.tied_with))
    if c is None:
        return row
    # sizes as vectors (one component for every effect but the slope, whose size is the length of
    # its in-plane gravity (slope_x, slope_y), as its model-form term is)
    truth = np.array([row["truth"][n] for n in c.effect.params])
    nominal, est = np.asarray(c.nominal, float), np.asarray(c.estimate, float)
    row.update(finding=bool(c.passed), decision=c.why, estimate={n: float(v) for n, v in zip(c.effect.params, c.estimate)},
               interval={n: [float(a), float(b)] for n, (a, b) in zip(c.effect.params, c.interval)}, after=c.after,
               relative=c.relative, gain_lower=c.gain.lower, tied_with=c.tied_with, tie_notes=c.tie_notes,
               se_stat=float(c.se_stat[0]), nominal=float(nominal[0]), size=float(np.linalg.norm(est - nominal)),
               n_blocks=blocks, covered=bool(np.all((c.interval[:, 0] <= truth) & (truth <= c.interval[:, 1]))),
               rel_error=float(np.linalg.norm(est - truth) / np.linalg.norm(truth)),
               size_error=float(np.linalg.norm(est - truth) / np.linalg.norm(truth - nominal)))
    return row


def summary(rows: list[dict]) -> dict:
    """Model term (RMS size error), leave-one-effect-out coverage, error median / worst."""
    hid = [r for r in rows if r["hidden"] != "none" and "size_error" in r]
    out = {"named": sum(bool(r.get("named")) for r in rows if r["hidden"] != "none"),
           "hidden": sum(r["hidden"] != "none" for r in rows),
           "covered_statistical_and_model": sum(r["covered"] for r in hid),
           "clean_cause": next((r["cause"] for r in rows if r["hidden"] == "none"), None)}
    if not hid:
        return out
    errs = np.array([r["size_error"] for r in hid])
    out["model_rel"] = float(np.sqrt(np.mean(errs ** 2)))
    loo = []
    for i, r in enumerate(hid):
        rel = float(np.sqrt(np.mean(np.delete(errs, i) ** 2))) if len(hid) > 1 else 0.0
        # each parameter's error against the first's half-width (the slope's two components have one size)
        miss = max(abs(r["estimate"][k] - v) for k, v in r["truth"].items())
        half = t_quantile(r["n_blocks"]) * math.hypot(r["se_stat"], rel * r["size"])
        stat_half = t_quantile(r["n_blocks"]) * r["se_stat"]
        loo.append({"hidden": r["hidden"], "model_rel_others": rel, "half_width": half,
                    "covered": bool(miss <= half), "covered_statistical": bool(miss <= stat_half)})
    out["leave_one_out"] = loo
    out["covered_leave_one_out"] = sum(x["covered"] for x in loo)
    out["covered_statistical_only"] = sum(x["covered_statistical"] for x in loo)
    rel = sorted(r["rel_error"] for r in hid)
    out["rel_error_median"], out["rel_error_worst"] = float(np.median(rel)), float(rel[-1])
    out["worst"] = max(hid, key=lambda r: r["rel_error"])["hidden"]
    return out


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--duration", type=float, default=60.0, help="seconds of driving per log (default 60)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--folds", type=int, default=5)
    ap.add_argument("--hidden", default=None, help="comma-separated hidden effects, 'none' for the clean log "
                                                   "(default: the clean log and all ten)")
    ap.add_argument("--all", action="store_true", help="fit every MuJoCo candidate (no surrogate pre-screen)")
    ap.add_argument("--merge", default=None, help="earlier results JSON whose rows are kept unless rerun here")
    ap.add_argument("--out", default=None, help="result file (default benchmarks/results/diagnose_mujoco_baseline"
                                                "[_all].json)")
    args = ap.parse_args(argv)
    args.out = args.out or str(RESULTS / f"diagnose_mujoco_baseline{'_all' if args.all else ''}.json")
    hidden = args.hidden.split(",") if args.hidden else ["none", *HIDDEN]
    rows = json.loads(Path(args.merge).read_text())["rows"] if args.merge else []
    print(f"MODEL_REL in use {mb.MODEL_REL}; load average {os.getloadavg()}", flush=True)
    print(f"{'hidden':<19} {'cause':<19} {'estimate [95 % interval]':<46} {'truth in':<8} {'gain (bound)':>13} "
          f"{'s':>5} {'load':>5}  tied / fitted")
    for h in hidden:
        r = run_one(None if h == "none" else h, duration=args.duration, seed=args.seed, n_folds=args.folds,
                    screen=None if args.all else 3)
        rows = [x for x in rows if x["hidden"] != r["hidden"]] + [r]
        est = ", ".join(f"{k}={v:.4g} [{r['interval'][k][0]:.4g}, {r['interval'][k][1]:.4g}]"
                        for k, v in r["estimate"].items()) if "estimate" in r else "-"
        cov = "-" if "covered" not in r else ("yes" if r["covered"] else "NO")
        gain = f"{100 * r['relative']:.0f} % ({100 * r['gain_lower']:.0f})" if "relative" in r else "-"
        mark = "" if r["hidden"] == "none" or r.get("named") else " NOT NAMED"
        print(f"{r['hidden']:<19} {r['cause']:<19} {est:<46} {cov:<8} {gain:>13} {r['wall_s']:5.0f} "
              f"{r['load_average'][0]:5.1f}  {','.join(r.get('tied_with', []))} / {','.join(r['fitted'])}{mark}",
              flush=True)
        if r["hidden"] != "none" and not r.get("named"):
            print(f"    decision: {r.get('decision', 'not fitted (pre-screened out)')}", flush=True)
        Path(args.out).parent.mkdir(parents=True, exist_ok=True)
        Path(args.out).write_text(json.dumps({"duration_s": args.duration, "seed": args.seed, "folds": args.folds,
                                              "all_candidates": args.all, "rows": rows,
                                              "summary": summary(rows)}, indent=2, default=float) + "\n")
    s = summary(rows)
    print(f"named {s['named']}/{s['hidden']}; clean log cause: {s['clean_cause']}")
    if "model_rel" in s:
        print(f"relative estimate error median {s['rel_error_median']:.3f}, worst {s['rel_error_worst']:.3f} "
              f"({s['worst']}); the baseline's own error on an effect's size (RMS over {len(s['leave_one_out'])} "
              f"effects): {s['model_rel']:.3f}")
        print(f"truth inside the 95 % interval: {s['covered_statistical_and_model']}/{len(s['leave_one_out'])} "
              f"(MODEL_REL {mb.MODEL_REL}); with the model term measured on the other effects only "
              f"{s['covered_leave_one_out']}/{len(s['leave_one_out'])}; statistical only "
              f"{s['covered_statistical_only']}/{len(s['leave_one_out'])}")
        for x in s["leave_one_out"]:
            print(f"    {x['hidden']:<19} model term of the others {x['model_rel_others']:.3f}, half width "
                  f"{x['half_width']:.4g}, covered {x['covered']} (statistical only {x['covered_statistical']})")
    print(f"per-log wall time median {np.median([r['wall_s'] for r in rows]):.0f} s, max "
          f"{max(r['wall_s'] for r in rows):.0f} s; load average now {os.getloadavg()}")


if __name__ == "__main__":
    main()
