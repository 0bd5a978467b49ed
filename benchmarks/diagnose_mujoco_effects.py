"""Diagnosis on MuJoCo logs: every hidden effect of diagnosis.json's vocabulary, pose only and with track speeds.

    python benchmarks/diagnose_mujoco_effects.py [--duration 180] [--seed 11] [--effects a,b,...]
                                                  [--variants pose,speeds] [--default-drives] [--steps]
                                                  [--out PATH.json]

Each log comes from the MuJoCo generator of the tests (mjtrack/testing/mujoco_effects.py: the robot of
mjtrack.sim with one hidden effect, pose noise 1 cm / 0.3 deg, track-speed noise 0.01 m/s), plus
clean logs. Prints one row per log: effect, injected value(s), named cause, estimate of the
injected effect's parameter(s) with its 95 % interval, pooled held-out gain, the checks of
the requirements (right cause, estimate within 25 %, positive held-out gain; "none" on clean logs) and
the seconds spent (simulation, diagnosis). Writes benchmarks/results/diagnose_mujoco_effects.json.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from mjtrack.diagnose import diagnose
from mjtrack.sim.config import SimConfig
from mjtrack.testing.mujoco_effects import HIDDEN, make_log
from _results import RESULTS


REL_TOL = 0.25  # the requirement: estimate within +-25 %
DIR_TOL = 0.25  # [rad] slope_direction: an angle, compared on the circle


def check(effect: str | None, d) -> dict:
    """One log's row: what the diagnosis said and whether the requirements hold."""
    row = {"cause": d.cause, "findings": [r.effect.name for r in d.findings],
           "before": float(d.before)}
    if effect is None:
        row["ok"] = d.cause == "none"
        best = d.results[0] if d.results else None
        if best is not None:
            row["best_candidate"] = {"effect": best.effect.name, "relative": float(best.relative),
                                     "estimate": dict(zip(best.effect.params, (float(v) for v in best.estimate))),
                                     "t": float(best.t_stat), "why": best.why}
        return row
    r = next(x for x in d.results if x.effect.name == effect)
    est = dict(zip(r.effect.params, (float(v) for v in r.estimate)))
    itv = {n: [float(a), float(b)] for n, (a, b) in zip(r.effect.params, r.interval)}
    ok_est = True
    for name, truth in HIDDEN[effect].params.items():
        if name == "slope_direction":
            ok_est &= abs(float(np.angle(np.exp(1j * (est[name] - truth))))) < DIR_TOL
        else:
            ok_est &= abs(est[name] - truth) <= REL_TOL * abs(truth)
    top = d.findings[0] if d.findings else None
    named = d.cause == effect or (top is not None and effect in top.tied_with and r.passed)
    row.update({"estimate": est, "interval": itv, "relative": float(r.relative), "after": float(r.after),
                "t": float(r.t_stat), "passed": bool(r.passed), "named": bool(named), "estimate_ok": bool(ok_est),
                "gain_ok": bool(r.passed and r.relative > 0), "why": r.why,
                "tied_with": list(r.tied_with)})
    row["ok"] = bool(named and ok_est and row["gain_ok"])
    return row


STEPS = [((0.0, 0.0), (0.6, 0.6)), ((0.4, 0.4), (0.8, 0.8)), ((0.6, 0.6), (0.6, 0.0)), ((0.3, 0.3), (0.6, 0.0)),
         ((0.6, 0.0), (0.0, 0.6)), ((0.5, -0.5), (-0.5, 0.5))]


def step_responses() -> list[dict]:
    """Equivalent dead time int (x_final - x)/(x_final - x_0) dt of vx and wz after a step of the
    track speeds on the clean MuJoCo robot (ideal drives), against the diagnosis's baseline with
    its friction-limited transient (Surrogate(..., transient=True), surrogate.friction_limited),
    the time-domain rigid-track Coulomb reference (coulomb.rollout, box yaw inertia) and the
    mode-wise mu g ramp the baseline used before (dead time D / (2 mu g) for a step of D m/s)."""
    from mjtrack.testing.mujoco_effects import DRIVES, ROBOT

    from mjtrack.diagnose.surrogate import Surrogate
    from mjtrack.diagnose.residuals import DriveData
    from mjtrack.io.robot import G
    from mjtrack.models import coulomb
    from mjtrack.sim.rollout import simulate

    dt = DRIVES.timestep
    a = ROBOT.mu * G
    surrogate = Surrogate(ROBOT, "coulomb", transient=True)
    rows = []
    for (l0, r0), (l1, r1) in STEPS:
        steps = np.concatenate([np.tile([l0, r0], (400, 1)), np.tile([l1, r1], (200, 1))])
        out = simulate(ROBOT, steps, config=DRIVES, log_rate=1.0 / dt)
        n = steps.shape[0]
        model = surrogate.twist(DriveData(t=np.arange(n) * dt, seg=np.zeros(n, int), cmd=steps, meas=None,
                                          poses=np.zeros((n, 3))), steps)[400:]
        tw0 = (l0, 0.0, 0.0) if l0 == r0 else tuple(coulomb.steady_state(ROBOT, l0, r0).twist)
        ref = coulomb.rollout(ROBOT, np.arange(200) * dt, l1, r1, twist0=tw0, n_points=20).twist
        row = {"from": [l0, r0], "to": [l1, r1]}
        for j, name, mode in ((0, "vx", lambda lv, rv: (lv + rv) / 2), (2, "wz", lambda lv, rv: (rv - lv) / 2)):
            def dead(x, x0=None):  # samples from the step on (left sums), or per-step means with x0 given
                x0, x1 = float(x[0] if x0 is None else x0), float(x[-1])
                return float(np.sum((x1 - x) / (x1 - x0)) * dt) if abs(x1 - x0) > 1e-2 else None

            x = out[name][400:]
            change = abs(mode(l1, r1) - mode(l0, r0))
            # the model gives per-step means (their sum is the integral); x0: the first command's steady twist
            x0 = surrogate.twist(DriveData(t=np.zeros(1), seg=np.zeros(1, int), cmd=steps[:1], meas=None,
                                           poses=np.zeros((1, 3))), steps[:1])[0, j]
            row[name] = {"measured_s": dead(x), "model_s": dead(model[:, j], x0), "coulomb_s": dead(ref[:, j]),
                         "ramp_s": change / (2 * a) if change > 0 else None}
        rows.append(row)

        def f(v):
            return f"{v:.3f}" if v is not None else "  -  "

        print(f"  step {row['from']} -> {row['to']}: dead time [s] measured / model / coulomb / old ramp: "
              f"vx {f(row['vx']['measured_s'])} / {f(row['vx']['model_s'])} / {f(row['vx']['coulomb_s'])} / "
              f"{f(row['vx']['ramp_s'])}, wz {f(row['wz']['measured_s'])} / {f(row['wz']['model_s'])} / "
              f"{f(row['wz']['coulomb_s'])} / {f(row['wz']['ramp_s'])}")
    return rows


def _fmt(d: dict | None) -> str:
    return ", ".join(f"{v:.3g}" for v in d.values()) if d else "-"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=180.0, help="seconds of driving per log")
    ap.add_argument("--seed", type=int, default=11)
    # the surrogate's vocabulary: the MuJoCo-only grounds (kind "model") are diagnosed with
    # --baseline mujoco (benchmarks/diagnose_mujoco_baseline.py)
    surrogate_effects = [name for name, h in HIDDEN.items() if h.kind != "model"]
    ap.add_argument("--effects", default=",".join(["clean", *surrogate_effects]),
                    help="comma-separated; 'clean' = no effect (default: every effect the surrogate diagnosis knows)")
    ap.add_argument("--variants", default="pose,speeds")
    ap.add_argument("--default-drives", action="store_true",
                    help="simulate with SimConfig() (60 N m drives: ramps of ~4.8 m/s^2) instead of the ideal drives")
    ap.add_argument("--out", default=str(RESULTS / "diagnose_mujoco_effects.json"))
    ap.add_argument("--steps", action="store_true", help="also measure the step responses of the clean robot")
    args = ap.parse_args(argv)
    steps = None
    if args.steps:
        print("step responses of the clean MuJoCo robot (equivalent dead time; model = the baseline's friction-limited "
              "transient, coulomb = rigid-track Coulomb rollout, old ramp = mode-wise mu g ramp):")
        steps = step_responses()
    rows = []
    print(f"{'effect':19s} {'variant':7s} {'injected':14s} {'cause':19s} {'estimate':14s} {'interval':26s} "
          f"{'gain':>6s} {'t':>6s} {'ok':3s} {'sim_s':>5s} {'diag_s':>6s}")
    for name in args.effects.split(","):
        effect = None if name == "clean" else name
        for variant in args.variants.split(","):
            t0 = time.perf_counter()
            log, robot = make_log(effect, seed=args.seed, duration=args.duration, speeds=variant == "speeds",
                                  config=SimConfig() if args.default_drives else None)
            t1 = time.perf_counter()
            d = diagnose(log, robot, baseline="surrogate", max_effects=1)
            t2 = time.perf_counter()
            row = {"effect": name, "variant": variant, "transient": d.transient,
                   "drives": "default" if args.default_drives else "ideal", "seed": args.seed, "duration_s": args.duration,
                   "injected": dict(HIDDEN[effect].params) if effect else {}, **check(effect, d),
                   "sim_s": t1 - t0, "diagnose_s": t2 - t1}
            rows.append(row)
            itv = "; ".join(f"[{a:.3g}, {b:.3g}]" for a, b in row.get("interval", {}).values()) or "-"
            gain = f"{100 * row['relative']:.0f}%" if "relative" in row else "-"
            t = f"{row['t']:.1f}" if "t" in row else "-"
            print(f"{name:19s} {variant:7s} {_fmt(row['injected']):14s} {row['cause']:19s} "
                  f"{_fmt(row.get('estimate')):14s} {itv:26s} {gain:>6s} {t:>6s} {'yes' if row['ok'] else 'NO':3s} "
                  f"{row['sim_s']:5.1f} {row['diagnose_s']:6.1f}", flush=True)
            if not row["ok"]:
                print(f"    findings {row['findings']}; {row.get('why', row.get('best_candidate'))}", flush=True)
    summary = {"logs": len(rows), "ok": sum(r["ok"] for r in rows)}
    print(f"{summary['ok']} / {summary['logs']} logs meet the requirements")
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps({"command": "python benchmarks/diagnose_mujoco_effects.py " + " ".join(argv or sys.argv[1:]),
                               "summary": summary, "rows": rows, "step_responses": steps}, indent=2) + "\n")
    return 0 if summary["ok"] == summary["logs"] else 1


if __name__ == "__main__":
    raise SystemExit(main())
