"""``diagnose --baseline mujoco`` on MuJoCo logs with one hidden effect each: named and estimated?

    python experiments/diagnose_mujoco_baseline.py [--duration 60] [--effects a,b] [--out FILE.json]

Logs: tests/mujoco_effects.py (the MuJoCo robot with one hidden effect, seeded random step
commands, 20 Hz, noisy poses; written without mjtrack.diagnose; the anisotropic ground there is
its own implementation, not mjtrack.sim.ground). The diagnosis is given the nominal robot (with
the generator's drive force limit, 600 N m at the 6 cm sprocket = 10 kN per track) and tests all
its candidate effects. Printed per log: the cause, the estimate with its 95 % interval, whether
the interval holds the truth, the held-out gain, the effects reported as tied with the cause,
and the wall time. The machine's load average is printed (shared 2-core machine).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))  # the MuJoCo log generator lives with the tests

from mujoco_effects import HIDDEN, ROBOT, make_log  # noqa: E402
from mjtrack.diagnose.mujoco_baseline import diagnose_mujoco  # noqa: E402
from mjtrack.io.robot import Robot  # noqa: E402

DRIVE_FORCE_LIMIT = 600.0 / ROBOT.sprocket_radius  # [N] the generator's drives (mujoco_effects.DRIVES)


def nominal_robot() -> Robot:
    """The robot the diagnosis is told about: the generator's nominal robot and drives."""
    return Robot.from_dict({**ROBOT.to_dict(), "drive_force_limit": DRIVE_FORCE_LIMIT})


def run_one(effect: str | None, *, duration: float, seed: int, effects=None, n_folds: int = 4) -> dict:
    lg, _ = make_log(effect, seed=seed, duration=duration)
    t0 = time.perf_counter()
    d = diagnose_mujoco(lg, nominal_robot(), effects=effects, n_folds=n_folds)
    wall = time.perf_counter() - t0
    row = {"hidden": effect or "none", "cause": d.cause, "wall_s": wall, "windows": d.n_windows,
           "before": d.before}
    if effect is not None:
        truth = HIDDEN[effect].params
        match = next((c for c in d.findings if c.effect.name == effect), None)
        cand = next((c for c in d.candidates if c.effect.name == effect), None)
        if match is None and cand is not None:  # why the hidden effect was not a finding
            row["missed"] = {"estimate": list(cand.estimate), "before": cand.before, "after": cand.after,
                             "t": cand.t_stat, "decision": cand.why}
            print(f"  ({effect} not a finding: estimate {list(cand.estimate)}, held-out {cand.before:.3g} -> "
                  f"{cand.after:.3g} m, paired t {cand.t_stat:.2f}: {cand.why})", flush=True)
        row["truth"] = truth
        row["named"] = d.cause == effect or (match is not None and d.cause in match.tied_with)
        if match is not None:
            est = dict(zip(match.effect.params, match.estimate))
            iv = dict(zip(match.effect.params, match.interval))
            key = match.effect.params[0]
            tkey = "lateral_ratio" if effect == "ground_anisotropy" else key
            row.update(estimate=est, interval=iv, after=match.after, relative=match.relative,
                       tied_with=match.tied_with,
                       covered=bool(iv[key][0] <= truth[tkey] <= iv[key][1]),
                       rel_error=abs(est[key] - truth[tkey]) / abs(truth[tkey]))
    return row


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--duration", type=float, default=60.0, help="seconds of driving per log (default 60)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--hidden", default=None, help="comma-separated hidden effects (default: all, and a clean log)")
    ap.add_argument("--effects", default=None, help="comma-separated candidate effects (default: all)")
    ap.add_argument("--out", default=str(ROOT / "experiments" / "results" / "diagnose_mujoco_baseline.json"))
    args = ap.parse_args(argv)
    hidden = args.hidden.split(",") if args.hidden else [None, *HIDDEN]
    effects = args.effects.split(",") if args.effects else None
    rows = []
    print(f"{'hidden':<20} {'cause':<20} {'estimate [95 % interval]':<44} {'truth in':<8} {'gain':>6} {'s':>6}  tied")
    for h in hidden:
        h = None if h in (None, "none") else h
        r = run_one(h, duration=args.duration, seed=args.seed, effects=effects)
        rows.append(r)
        est = ", ".join(f"{k}={v:.4g} [{r['interval'][k][0]:.4g}, {r['interval'][k][1]:.4g}]"
                        for k, v in r["estimate"].items()) if "estimate" in r else "-"
        cov = "-" if "covered" not in r else ("yes" if r["covered"] else "NO")
        gain = f"{100 * r['relative']:.0f} %" if "relative" in r else "-"
        print(f"{r['hidden']:<20} {r['cause']:<20} {est:<44} {cov:<8} {gain:>6} {r['wall_s']:6.0f}  "
              f"{','.join(r.get('tied_with', []))}", flush=True)
    named = [r for r in rows if r["hidden"] != "none"]
    ok = sum(bool(r.get("named")) for r in named)
    cov = sum(bool(r.get("covered")) for r in named)
    errs = sorted(r["rel_error"] for r in named if "rel_error" in r)
    print(f"named {ok}/{len(named)}; truth inside the interval {cov}/{len(named)}; "
          f"relative estimate error median {errs[len(errs) // 2] if errs else float('nan'):.3f}, "
          f"worst {errs[-1] if errs else float('nan'):.3f}; clean log cause: "
          f"{next((r['cause'] for r in rows if r['hidden'] == 'none'), '-')}; load average {os.getloadavg()}")
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps({"duration_s": args.duration, "seed": args.seed, "rows": rows,
                                          "load_average": os.getloadavg()}, indent=2, default=float) + "\n")


if __name__ == "__main__":
    main()
