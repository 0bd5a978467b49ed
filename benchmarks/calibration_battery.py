"""The calibration self-consistency battery: MuJoCo logs with one known change each, calibrated from
the description without it (:mod:`mjtrack.testing.battery`).

For every case: the training log (seed 11) and the test log (seed 12) of the truth, ``calibrate`` on
the training log from the description, then per parameter the truth, the estimate, the 95 %
interval and whether the log determines it; whether every determined parameter's interval covers
its truth; the causes named (the true one must lead; the clean log must give none); the held-out
error before and after. With ``--diagnose`` (or ``--diagnose-only``, on stored cases, the calibrated
robot rebuilt from their estimates) the same logs also go through
``diagnose --baseline mujoco`` against the description (its cause recorded beside) and against the
calibrated robot (which must name nothing calibration fitted).

    python benchmarks/calibration_battery.py                       # 3 geometries x 10 changes
    python benchmarks/calibration_battery.py --geometries default --changes cg_x,clean
    python benchmarks/calibration_battery.py --noise realistic     # the same on noisy logs

``--noise PRESET`` adds white measurement noise to both logs of every case (``mjtrack simulate
--noise``'s presets; ``realistic``: the levels measured on the shared real logs), each log's from its
own seed; those cases go to benchmarks/results/calibration_battery_noisy.json.

``--drive-input MODE`` calibrates every case with that drive input instead of calibrate's default
(``auto``, which on these logs, whose drives follow their commands late or in proportion, chooses
``commanded``); ``--drive-input fitted`` asks what fitting the drivetrain to the measured track
speeds first would do to logs whose truth is known. Those cases go to
benchmarks/results/calibration_battery_MODE.json, each with the drive input used and, fitted,
the drivetrain's wheel-speed error after its fit.

``--speed-following``: no calibration. For the clean case of each geometry, the MuJoCo robot as
it is, on its own log at the battery's 50 Hz and at 200 Hz, its 2 s windows simulated driven by
its logged commands and driven by its own logged track speeds (``--drive-input measured``'s
drives), those as logged and read half a row and a row ahead: how much of what speed-following
drives miss comes from holding a sampled speed as the set-point over the row that follows it.
Writes benchmarks/results/speed_following.json.

Writes benchmarks/results/calibration_battery.json (merged with earlier cases of another
selection) and prints the coverage table, the worst row and the machine's load.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

from mjtrack.calibrate.run import calibrate
from mjtrack.testing.battery import CHANGES, GEOMETRIES, case, described_robot, make_log

RESULT = Path(__file__).resolve().parent / "results" / "calibration_battery.json"
NOISY_RESULT = RESULT.with_name("calibration_battery_noisy.json")


def run_case(c, *, duration: float, diagnose: bool, noise: str | None = None, drive_input: str = "auto") -> dict:
    train = make_log(c, duration=duration, seed=11, noise=noise)
    test = make_log(c, duration=duration, seed=12, noise=noise)
    robot = described_robot(c)
    t0 = time.perf_counter()
    cal = calibrate(train, robot, test=test, nthread=2, drive_input=drive_input)
    seconds = time.perf_counter() - t0
    rows = []
    for n in cal.names:
        v = cal.verdicts[n]
        truth = c.truth.get(n)
        lo, hi = v.interval if v.interval is not None else (None, None)
        covered = None if (truth is None or lo is None) else bool(lo - 1e-12 <= truth <= hi + 1e-12)
        rows.append({"parameter": n, "truth": truth, "estimate": cal.values[n], "interval": v.interval,
                     "determined": v.determined, "changed": v.changed, "covered": covered, "reason": v.reason})
    causes = [cc.parameters for cc in cal.causes]
    if c.cause:
        cause_ok = bool(causes) and bool(set(causes[0]) & set(c.cause))
    else:
        cause_ok = not causes
    out = {"case": c.name, "geometry": c.geometry, "change": c.change, "truth_keys": c.true_keys,
           "rows": rows, "causes": [cc.to_json() for cc in cal.causes], "summary": cal.sentence,
           "expected_cause": list(c.cause), "cause_ok": cause_ok,
           "coverage_ok": all(r["covered"] is not False for r in rows if r["determined"]),
           "train": [cal.before.rms, cal.after.rms], "test": [cal.test_before.rms, cal.test_after.rms],
           "diverged": [cal.before.diverged, cal.after.diverged], "seconds": seconds, "noise": noise or "none",
           "drive_input_mode": cal.drive_input_mode, "drive_input_why": cal.drive_input_why}
    if cal.drivetrain is not None:
        out["drivetrain"] = {"wheel_speed_rms_before": list(cal.drivetrain.rms_before),
                             "wheel_speed_rms_after": list(cal.drivetrain.rms_after),
                             "values": cal.drivetrain.values, "half_width_95": cal.drivetrain.half}
    if diagnose:
        out.update(diagnose_case(train, test, robot, cal.calibrated))
    return out


def diagnose_case(train, test, robot, calibrated) -> dict:
    """``diagnose --baseline mujoco`` of the case's logs against the description (its cause) and
    against the calibrated robot (one story: it must name nothing calibration fitted; a slope is the
    log's ground, not the robot's: calibration reports it and the robot file does not carry it)."""
    from mjtrack.diagnose.run import diagnose as run_diagnose

    out = {}
    for key, r in (("diagnose", robot), ("diagnose_calibrated", calibrated)):
        t0 = time.perf_counter()
        d = run_diagnose(train, r, baseline="mujoco", test_log=test)
        out[key] = {"cause": d.cause, "findings": [f["effect"] for f in d.to_json()["findings"]],
                    "seconds": time.perf_counter() - t0}
    return out


def stored_calibrated(c, stored: dict):
    """The calibrated robot of a stored case, rebuilt from its changed estimates."""
    from mjtrack.calibrate.run import calibrated_robot
    from mjtrack.sim.config import sim_config

    robot = described_robot(c)
    values = {x["parameter"]: x["estimate"] for x in stored["rows"] if x["changed"]}
    return calibrated_robot(robot, values, sim_config(None, robot=robot))


SPEED_RATES = (50.0, 200.0)  # [Hz] log rates of --speed-following
SPEED_LEADS = (0.0, 0.5, 1.0)  # rows by which the logged speeds are read ahead


def speed_following(geometries, duration: float = 30.0, seed: int = 11) -> dict:
    """--speed-following (module docstring): per geometry, log rate and drive, the windows' RMS
    end position [m] and yaw [rad] error against the log."""
    import dataclasses

    from mjtrack.sim import drive_log
    from mjtrack.sim.config import sim_config
    from mjtrack.sim.windows import WindowSim, simulate_windows
    from mjtrack.testing.battery import commands
    from mjtrack.windows import WARMUP_S, make_windows, measured_drive_log

    rows = []
    for g in geometries:
        truth = described_robot(case(g, "clean"))
        sim = WindowSim(truth, sim_config(None, robot=truth), resisted=True)
        for rate in SPEED_RATES:
            lg = drive_log(truth, commands(duration, seed), duration=duration, log_rate=rate)
            ws = make_windows(lg, 2.0)
            measured = measured_drive_log(lg, "log")
            drives = [("commanded", None, lg)]
            for lead in SPEED_LEADS:
                ahead = dataclasses.replace(measured, **{k: np.interp(lg.t + lead / rate, lg.t, getattr(measured, k))
                                                         for k in ("v_left_cmd", "v_right_cmd")})
                drives.append(("measured", lead, ahead))
            for drive, lead, log_ in drives:
                e = simulate_windows(sim, log_, ws, warmup_s=WARMUP_S).errors[0]
                rows.append({"geometry": g, "rate_hz": rate, "drive": drive, "lead_rows": lead, "windows": len(ws),
                             "position_rms_m": float(np.sqrt(np.mean(e[:, 0] ** 2 + e[:, 1] ** 2))),
                             "yaw_rms_rad": float(np.sqrt(np.mean(e[:, 2] ** 2)))})
                r = rows[-1]
                print(f"{g:8s} {rate:5.0f} Hz {drive:9s} lead {lead if lead is not None else '-'}: position "
                      f"{r['position_rms_m']:.4f} m, yaw {r['yaw_rms_rad']:.4f} rad", flush=True)
    return {"rows": rows, "duration_s": duration, "seed": seed, "horizon_s": 2.0}


def _plain(o):
    """numpy scalars and arrays as JSON values."""
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    raise TypeError(type(o).__name__)


def _write(out: Path, results: dict, old: dict, duration: float, load0, noise: str | None = None) -> None:
    out.parent.mkdir(parents=True, exist_ok=True)
    extra = {}
    if noise:
        from mjtrack.sim.noise import CHANNELS, log_noise

        levels = log_noise(noise)
        extra["noise_levels"] = {"preset": noise, "std": {c: getattr(levels, c) for c in CHANNELS},
                                 "units": {c: unit for c, (_, unit, _) in CHANNELS.items()}}
    commands = sorted({x.get("command", old.get("command", "")) for x in results.values()}
                      | {x["diagnose_command"] for x in results.values() if "diagnose_command" in x})
    out.write_text(json.dumps({"command": "; ".join(commands), "cases": results, "summary": summary(results),
                               "duration_s": duration, "load_before": load0, "load_after": os.getloadavg(), **extra},
                              indent=1, default=_plain) + "\n")


def summary(results: dict) -> dict:
    """Over every case: how many name the right first cause, and the share of determined parameters
    whose interval covers the truth (the battery's two criteria)."""
    covered = [x["covered"] for r in results.values() for x in r["rows"] if x["determined"] and x["covered"] is not None]
    return {"cases": len(results), "causes_right": sum(bool(r["cause_ok"]) for r in results.values()),
            "determined": len(covered), "covered": sum(covered),
            "coverage": sum(covered) / len(covered) if covered else None}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--geometries", default=",".join(GEOMETRIES))
    ap.add_argument("--changes", default=",".join(CHANGES))
    ap.add_argument("--duration", type=float, default=60.0, help="seconds of each log (default 60)")
    ap.add_argument("--diagnose", action="store_true", help="also diagnose --baseline mujoco each case")
    ap.add_argument("--diagnose-only", action="store_true",
                    help="only diagnose stored cases: against the description and against the calibrated robot "
                         "rebuilt from the stored estimates")
    ap.add_argument("--noise", default=None, metavar="PRESET",
                    help="measurement noise on both logs of every case (a preset of `mjtrack simulate --noise`, e.g. "
                         "realistic); default: none. Writes to calibration_battery_noisy.json unless --out says otherwise")
    ap.add_argument("--drive-input", default="auto", choices=("auto", "commanded", "measured", "fitted"),
                    help="calibrate's drive input for every case (default: calibrate's own, auto). Other than auto, "
                         "writes to calibration_battery_MODE.json unless --out says otherwise")
    ap.add_argument("--speed-following", action="store_true",
                    help="no calibration: the robot driven by its own logged track speeds against its own log "
                         "(module docstring); writes speed_following.json")
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)
    if args.speed_following:
        load0 = os.getloadavg()
        out = speed_following(args.geometries.split(","))
        path = args.out or RESULT.with_name("speed_following.json")
        path.write_text(json.dumps({"command": "python benchmarks/calibration_battery.py " + " ".join(
            sys.argv[1:] if argv is None else argv), **out, "load_before": load0, "load_after": os.getloadavg(),
            "cpus": os.cpu_count()}, indent=1) + "\n")
        print(f"load average before {load0}, after {os.getloadavg()} ({os.cpu_count()} cores); wrote {path}")
        return 0
    if args.out is None:
        args.out = (NOISY_RESULT if args.noise and args.noise != "none" else
                    RESULT.with_name(f"calibration_battery_{args.drive_input}.json") if args.drive_input != "auto"
                    else RESULT)
    if args.drive_input != "auto" and (args.diagnose or args.diagnose_only):
        ap.error("--drive-input is for calibration alone; run --diagnose without it")
    noise = None if args.noise in (None, "none") else args.noise
    if noise and args.diagnose_only:
        ap.error("--diagnose-only rebuilds stored noise-free cases; run --diagnose with --noise instead")
    load0 = os.getloadavg()
    old = json.loads(args.out.read_text()) if args.out.exists() else {"cases": {}}
    results = old.get("cases", {})
    command = "python benchmarks/calibration_battery.py " + " ".join(sys.argv[1:] if argv is None else argv)
    for g in args.geometries.split(","):
        for ch in args.changes.split(","):
            c = case(g, ch)
            if args.diagnose_only:
                if c.name not in results:
                    print(f"{c.name}: not calibrated yet; skipped", flush=True)
                    continue
                r = dict(results[c.name])
                r.update(diagnose_case(make_log(c, duration=args.duration, seed=11),
                                       make_log(c, duration=args.duration, seed=12), described_robot(c),
                                       stored_calibrated(c, r)))
                r["diagnose_command"] = command
                results[c.name] = r
                print(f"{c.name:28s} diagnose: {r['diagnose']['cause']} {r['diagnose']['findings']}, calibrated: "
                      f"{r['diagnose_calibrated']['cause']} {r['diagnose_calibrated']['findings']}", flush=True)
                _write(args.out, results, old, args.duration, load0)
                continue
            r = run_case(c, duration=args.duration, diagnose=args.diagnose, noise=noise, drive_input=args.drive_input)
            before = results.get(c.name, {})
            if not args.diagnose and "diagnose" in before:
                # diagnose against the description does not depend on calibration: an earlier run's
                # is kept, marked; against the calibrated robot it does, and is dropped
                r["diagnose"] = {**before["diagnose"], "from": before.get("command", old.get("command", "an earlier run"))}
            r["command"] = command  # cases of several runs merge into one file: each says which made it
            results[c.name] = r
            det = [x for x in r["rows"] if x["determined"]]
            miss = [x["parameter"] for x in det if x["covered"] is False]
            print(f"{c.name:28s} [{r['drive_input_mode']}] cause {'ok ' if r['cause_ok'] else 'BAD'} "
                  f"{[cc['parameters'] for cc in r['causes']][:2]}  covered {len(det) - len(miss)}/{len(det)}"
                  + (f" MISSED {miss}" if miss else "")
                  + f"  test {r['test'][0]:.4g} -> {r['test'][1]:.4g} m  {r['seconds']:.0f} s"
                  + (f"  diagnose: {r['diagnose']['cause']}" if "diagnose" in r else "")
                  + (f", calibrated: {r['diagnose_calibrated']['cause']}" if "diagnose_calibrated" in r else ""),
                  flush=True)
            _write(args.out, results, old, args.duration, load0, noise)
    rows = [(name, x) for name, r in results.items() for x in r["rows"] if x["determined"]]
    cov = [x["covered"] for _, x in rows if x["covered"] is not None]
    print(f"\ncoverage of determined parameters: {sum(cov)}/{len(cov)} = {np.mean(cov):.3f}")
    print(f"causes right: {sum(r['cause_ok'] for r in results.values())}/{len(results)}")
    # a determined value the fit did not reach within its rounds has no interval: nothing to hold
    worst = max([(n, x) for n, x in rows if x["interval"]], key=lambda nx: (0 if nx[1]["covered"] is not False else 1,
                                      abs(nx[1]["estimate"] - nx[1]["truth"]) /
                                      max(1e-12, (nx[1]["interval"][1] - nx[1]["interval"][0]) / 2)))
    n, x = worst
    print(f"worst row: {n} {x['parameter']}: truth {x['truth']:.5g}, estimate {x['estimate']:.5g}, "
          f"interval [{x['interval'][0]:.5g}, {x['interval'][1]:.5g}]")
    print(f"load average before {load0}, after {os.getloadavg()} ({os.cpu_count()} cores)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
