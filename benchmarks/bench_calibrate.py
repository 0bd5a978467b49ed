"""Wall and CPU time of a calibration, the code before a change against the code now, in one run.

    nice -n 10 python benchmarks/bench_calibrate.py [--old-tree DIR] [--case sim60|marmotte|husky|warthog] [--repeats N]

``--old-tree DIR``: a checkout of the code to compare against (e.g. ``git archive REV | tar -x -C
DIR``); without it only the code now is measured. Cases:

* ``sim60`` (default): a 60 s ``random_steps`` log of the default robot with its centre of mass
  6 cm ahead (``cg_x`` 0.06 m), calibrated from the robot as described (``cg_x`` 0) with a held-out
  60 s log of the same robot (``calibrate TRAIN --robot DESCRIBED --test TEST``), calibrate's
  defaults; the logs are simulated here (seeds 1 and 2), by the code now, for both.
* ``marmotte``: the whole shared Marmotte log (../shared/data/marmotte/marmotte_boreal.csv) from
  the Marmotte's starting robot of ``benchmarks/real_robots.py``, 6 rollers per track.
* ``husky``: the whole shared Husky log (../shared/data/husky/husky_drive.csv) from the description
  shipped with it, calibrate's defaults (as a user runs ``mjtrack calibrate husky_drive.csv``: the
  drive input calibrate chooses, and the turn stage where the fit's robot turns unlike the log).
* ``warthog``: the same for the whole shared Warthog log (../shared/data/warthog/warthog_drive.csv).

Old and new alternate (old, new, old, new, ...), each calibration in a fresh Python process with
that code on its path, so that both see the same load. Each run reports its wall time, its CPU time
(all threads), the windows it simulated (every window of every parameter set, counted where the
window simulator is called), its stage times, and its answer (the drive input used and why,
changed parameters, their values and intervals, the training error before and after, the
summary). The machine is shared: the load average before and after each run is
printed and stored, and the ratios quoted are of medians. Writes
benchmarks/results/bench_calibrate.json (or bench_calibrate_CASE.json).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
RESULTS = HERE / "results"
SIM_ROBOT = {"cg_x": 0.06}  # the hidden change of the sim60 case


def _child(case: str, data: str) -> None:
    """One calibration with the ``mjtrack`` on the path; prints one JSON line."""
    import mjtrack.calibrate.fit as fit_mod
    import mjtrack.calibrate.run as run_mod
    from mjtrack.io import read_log_with_robot, read_robot

    count = {"calls": 0, "parameter_sets": 0, "windows": 0}

    def counted(f):
        def g(sim, log, ws, variants=None, **kw):
            p = 1 if variants is None else len(variants)
            count["calls"] += 1
            count["parameter_sets"] += p
            count["windows"] += p * len(ws)
            return f(sim, log, ws, variants, **kw)
        return g

    import mjtrack.sim.windows as sim_windows

    original = sim_windows.simulate_windows
    wrapped = counted(original)
    # wherever the simulator is bound: the modules that import it by name, and its own module for
    # the functions that import it when they run
    for mod in (sim_windows, fit_mod, run_mod):
        if getattr(mod, "simulate_windows", None) is original:
            mod.simulate_windows = wrapped
    kw: dict = {}
    if case == "sim60":
        train, _ = read_log_with_robot(Path(data) / "train.csv")
        test, _ = read_log_with_robot(Path(data) / "test.csv")
        robot = read_robot(Path(data) / "described.json")
        kw = {"test": test, "train_path": "train.csv", "test_path": "test.csv"}
    else:  # the starting robot written by the parent, so that either tree reads the same one
        log_path = Path((Path(data) / "log_path.txt").read_text().strip())
        train, _ = read_log_with_robot(log_path)
        robot = read_robot(Path(data) / "start.json")
        kw = {"train_path": log_path.name, **({"n_rollers": 6} if case == "marmotte" else {})}
    load0 = os.getloadavg()
    t0, c0 = time.perf_counter(), time.process_time()
    cal = run_mod.calibrate(train, robot, quiet=True, **kw)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    j = cal.to_json()
    print(json.dumps({
        "wall_s": wall, "cpu_s": cpu, "load_before": load0, "load_after": os.getloadavg(), **count,
        "timings_s": j["timings_s"], "changed": j["changed"],
        "values": {n: j["parameters"][n] for n in j["changed"]},
        "intervals": {n: j["intervals"].get(n) for n in j["changed"]},
        "drive_input_mode": j.get("drive_input_mode", j.get("drive_input")), "drive_input_why": j.get("drive_input_why"),
        "rms": [j["train"]["before"], j["train"]["after"]] + ([j["test"]["before"], j["test"]["after"]]
                                                               if "test" in j else []),
        "fits": [{"parameters": f["parameters"], "iterations": f["iterations"]} for f in j["method"]["fits"]],
        "summary": j["summary"]}))


def _simulate_logs(out: Path) -> None:
    """The sim60 case's logs and the described robot, made as a user makes them (``mjtrack simulate``)."""
    env = {**os.environ, "PYTHONPATH": str(ROOT), "MUJOCO_GL": "egl"}

    def simulate(*args: str) -> None:
        subprocess.run([sys.executable, "-m", "mjtrack", "simulate", "-q", "--force", *args], env=env, check=True,
                       cwd=str(out))

    simulate("--scenario", "straight", "--duration", "1", "--out", "described.csv")  # the default robot
    robot = json.loads((out / "described.json").read_text())
    (out / "hidden.json").write_text(json.dumps({**robot, **SIM_ROBOT}, indent=1))
    for name, seed in (("train", 1), ("test", 2)):
        simulate("--scenario", "random_steps", "--duration", "60", "--seed", str(seed), "--robot", "hidden.json",
                 "--out", f"{name}.csv")


def _run(tree: Path, case: str, data: str) -> dict:
    env = {**os.environ, "PYTHONPATH": str(tree), "MUJOCO_GL": "egl"}
    cmd = [sys.executable, str(Path(__file__).resolve()), "--child", case, "--data", data]
    out = subprocess.run(cmd, env=env, capture_output=True, text=True, check=False, cwd=str(tree))
    if out.returncode != 0:
        raise SystemExit(f"{tree}: calibration failed:\n{out.stderr[-3000:]}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--old-tree", type=Path, help="a checkout of the code to compare against")
    ap.add_argument("--case", choices=("sim60", "marmotte", "husky", "warthog"), default="sim60")
    ap.add_argument("--repeats", type=int, default=1, help="runs of each (alternating; default 1)")
    ap.add_argument("--child", help=argparse.SUPPRESS)
    ap.add_argument("--data", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        _child(args.child, args.data)
        return 0
    with tempfile.TemporaryDirectory() as tmp:
        data = Path(tmp)
        if args.case == "sim60":
            _simulate_logs(data)
        else:
            sys.path.insert(0, str(HERE))
            from mjtrack.io import read_log_with_robot
            from mjtrack.io.robot import write_robot
            from real_robots import ROBOTS, starting_robot

            log_path = ROBOTS[args.case]["log"]
            if not log_path.exists():
                print(f"{log_path} not found (the shared data); nothing to do")
                return 0
            _, base = read_log_with_robot(log_path)
            write_robot(starting_robot(base, ROBOTS["marmotte"]["public"]) if args.case == "marmotte" else base,
                        data / "start.json")
            (data / "log_path.txt").write_text(str(log_path))
        trees = [("new", ROOT)] + ([("old", args.old_tree.resolve())] if args.old_tree else [])
        runs: dict[str, list[dict]] = {label: [] for label, _ in trees}
        for _ in range(args.repeats):
            for label, tree in reversed(trees):  # old first, then new
                r = _run(tree, args.case, str(data))
                runs[label].append(r)
                print(f"{label}: drive input {r.get('drive_input_mode')}, wall {r['wall_s']:.1f} s, CPU {r['cpu_s']:.1f} s, "
                      f"{r['windows']} windows simulated, training error {r['rms'][0]:.3f} -> {r['rms'][1]:.3f} m, "
                      f"load {r['load_before'][0]:.2f} -> {r['load_after'][0]:.2f}; changed {r['changed']} "
                      f"{ {n: round(v, 5) for n, v in r['values'].items()} }", flush=True)
    med = {label: {k: statistics.median(r[k] for r in rs) for k in ("wall_s", "cpu_s", "windows")}
           for label, rs in runs.items()}
    if "old" in med:
        for k in ("wall_s", "cpu_s", "windows"):
            med.setdefault("ratio_old_over_new", {})[k] = med["old"][k] / max(med["new"][k], 1e-9)
        print("medians old / new: " + ", ".join(f"{k} {v:.2f}" for k, v in med["ratio_old_over_new"].items()))
    out = RESULTS / ("bench_calibrate.json" if args.case == "sim60" else f"bench_calibrate_{args.case}.json")
    out.parent.mkdir(parents=True, exist_ok=True)
    command = " ".join(["python benchmarks/bench_calibrate.py", "--case", args.case, "--repeats", str(args.repeats)]
                       + (["--old-tree", "DIR"] if args.old_tree else []))  # (the checkout's place is the user's)
    out.write_text(json.dumps({"command": command, "case": args.case, "cpus": os.cpu_count(),
        "target_wall_s": {"sim60": 60, "marmotte": 120, "husky": 600, "warthog": 600}[args.case], "medians": med, "runs": runs}, indent=1) + "\n")
    print(f"wrote {out.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
