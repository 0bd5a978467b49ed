"""Benchmark of ``mjtrack diagnose``: stage timings on 10 minutes of 20 Hz data (12000 samples).

    python benchmarks/bench_diagnose.py [--effect cg_offset_x] [--minutes 10] [--no-speeds]
                                         [--marmotte PATH.csv] [--horizon S]
    nice -n 10 python benchmarks/bench_diagnose.py --case mujoco60 [--old-tree DIR] [--repeats N] [--change TEXT]
    nice -n 10 python benchmarks/bench_diagnose.py --case mujoco60 --profile-only
    nice -n 10 python benchmarks/bench_diagnose.py --case mujoco60 --noslip N

The synthetic log comes from the tests' independent generator (mjtrack/testing/diagnose_physics.py: its
own rigid-body Coulomb simulation, pose noise); the budget is 30 s for the whole diagnosis on
the surrogate baseline (read, forward selection over every effect, write the report). With
--marmotte it also runs the real Marmotte log and prints its findings. Prints the machine load.

``--case mujoco60``: ``diagnose TEST --robot DESCRIBED --baseline mujoco`` on the 60 s held-out log
of ``benchmarks/bench_calibrate.py``'s sim60 case (the default robot with its centre of mass 6 cm
ahead, described without it), in a fresh Python process per run; with ``--old-tree DIR`` (e.g.
``git archive REV | tar -x -C DIR``) the code there and the code now alternate (old, new, ...) so
that both see the same load. Each run reports its wall and CPU time, its stage times, the windows
it simulated and the cause it named. Writes benchmarks/results/bench_diagnose_mujoco60.json; the
budget is 60 s. ``--case mujoco60 --profile-only``: one more run of the code now under cProfile, the
seconds of its parts (:data:`PROFILE_PARTS`; cProfile slows the Python around the rollouts, not
the rollouts) added to the stored file under ``profile``. ``--case mujoco60 --noslip N``: one more run
of the code now with MuJoCo's noslip friction pass capped at N iterations (the robot is built with SimConfig.noslip_iterations), added under
``noslip_cap`` with its cause and estimate: whether a cheaper step is where the time is.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

from mjtrack.diagnose import diagnose, write_outputs
from mjtrack.io.logs import read_log_with_robot, write_log
from mjtrack.io.robot import write_robot
from mjtrack.testing.diagnose_logs import HIDDEN, make_log
from _results import RESULTS, benchmark_command, default_run_result, printed_result

ROOT = Path(__file__).resolve().parent.parent


BUDGET_S = 30.0


def run(path: Path, out: Path, horizon) -> float:
    t0 = time.perf_counter()
    log, robot = read_log_with_robot(path)
    t1 = time.perf_counter()
    d = diagnose(log, robot, horizon_s=horizon, baseline="surrogate")
    t2 = time.perf_counter()
    write_outputs(d, out)
    t3 = time.perf_counter()
    total = t3 - t0
    print(f"  {path.name}: {d.samples} samples, {int(d.data.seg[-1]) + 1} segments, {d.starts.size} windows "
          f"at {d.horizon_s:g} s, baseline '{d.baseline.name}' RMSE {d.before:.4g} m")
    print(f"  read {t1 - t0:6.2f} s | prepare {d.timings['prepare']:6.2f} s | selection "
          f"{d.timings['selection']:6.2f} s ({len(d.steps)} steps) | report "
          f"{t3 - t2:6.2f} s | total {total:6.2f} s "
          f"({'within' if total < BUDGET_S else 'OVER'} the {BUDGET_S:.0f} s budget)")
    print("  " + d.summary().replace("\n", "\n  "))
    for step in d.steps:
        print(f"  step on top of {' + '.join(step.base) or 'the nominal model'} (baseline {step.before:.4g} m):")
        _table(step.results)
    print(f"  load {os.getloadavg()}")
    return total


def _table(results) -> None:
    for r in results:
        est = ", ".join(f"{n}={v:.4g}" for n, v in zip(r.effect.params, r.estimate))
        iv = ", ".join(f"[{a:.4g}, {b:.4g}]" for a, b in r.interval)
        print(f"    {'*' if r.passed else ' '} {r.effect.name:19s} {est:42s} {iv:34s} gain {100 * r.relative:6.1f} % "
              f"bound {100 * r.gain.lower:6.1f} %" + (f"  speed RMSE {r.speed_before:.3f}->{r.speed_after:.3f}" if r.speed_after else "")
              + (f"  tied with {r.tied_with}" if r.tied_with else ""))


MUJOCO60_BUDGET_S = 60.0


# where the seconds of a MuJoCo diagnosis go: (part, function whose cumulative time it is) of the
# cProfile of one run; "MuJoCo rollouts" is the C call itself, the others include their rollouts
PROFILE_PARTS = (("every MuJoCo rollout (the C call)", "<built-in method mujoco._rollout.rollout>"),
                 ("warming up each window's hidden states", "warm_states"),
                 ("the baseline's errors (the problem)", "problem"),
                 ("each effect's grid of values (the fit's curves)", "_curves"),
                 ("the slope's central differences", "_slope_jacobian"),
                 ("scoring every effect (grids, then each fold's fitted value)", "score"))


def _profile_parts(stats) -> dict:
    """Cumulative seconds of :data:`PROFILE_PARTS` in a pstats.Stats (summed over same-named functions)."""
    out = {}
    for label, name in PROFILE_PARTS:
        total = 0.0
        for (_, _, fn), row in stats.stats.items():
            if fn == name:
                total += row[3]  # cumulative time
        out[label] = total
    return out


def _mujoco60_child(data: str, profile: bool = False, noslip: int | None = None) -> None:
    """One ``diagnose --baseline mujoco`` of the held-out log with the ``mjtrack`` on the path; one JSON
    line (with ``profile``: run under cProfile, its parts in the line; with ``noslip``: the MuJoCo
    baseline's noslip pass capped at that many iterations, the finding's estimate in the line)."""
    import json

    import mjtrack.sim.windows as sim_windows
    from mjtrack.io import read_log_with_robot, read_robot

    import mjtrack.diagnose.mujoco_baseline as baseline_mod

    if noslip is not None:
        settings = baseline_mod.sim_config
        baseline_mod.sim_config = lambda *a, **k: settings(*a, **k).replace(noslip_iterations=noslip)

    count = {"windows": 0}
    original = sim_windows.simulate_windows

    def counted(sim, log, ws, variants=None, **kw):
        count["windows"] += (1 if variants is None else len(variants)) * len(ws)
        return original(sim, log, ws, variants, **kw)

    for mod in (sim_windows, baseline_mod):
        if getattr(mod, "simulate_windows", None) is original:
            mod.simulate_windows = counted
    test, _ = read_log_with_robot(Path(data) / "test.csv")
    robot = read_robot(Path(data) / "described.json")
    load0 = os.getloadavg()
    prof = None
    if profile:
        import cProfile

        prof = cProfile.Profile()
        prof.enable()
    t0, c0 = time.perf_counter(), time.process_time()
    d = diagnose(test, robot, baseline="mujoco")
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    parts = {}
    if prof is not None:
        import pstats

        prof.disable()
        parts = {"profile_s": _profile_parts(pstats.Stats(prof))}
    findings = d.to_json()["findings"]
    print(json.dumps({"wall_s": wall, "cpu_s": cpu, "load_before": load0, "load_after": os.getloadavg(),
                      "windows": count["windows"], "timings_s": {k: float(v) for k, v in d.timings.items()},
                      "cause": d.cause, "findings": [f["effect"] for f in findings],
                      "estimates": [{"estimate": f["estimate"], "interval": f["interval"]} for f in findings],
                      **parts}))


def _one_run(*flags: str) -> dict:
    """One child run of the code now on freshly simulated logs (its JSON line)."""
    import json
    import subprocess

    from bench_calibrate import _simulate_logs

    with tempfile.TemporaryDirectory() as tmp:
        _simulate_logs(Path(tmp))
        env = {**os.environ, "PYTHONPATH": str(ROOT), "MUJOCO_GL": "egl"}
        res = subprocess.run([sys.executable, str(Path(__file__).resolve()), "--mujoco60-child", tmp, *flags],
                             env=env, capture_output=True, text=True, check=False, cwd=str(ROOT))
        if res.returncode != 0:
            raise SystemExit(f"diagnose failed:\n{res.stderr[-3000:]}")
        return json.loads(res.stdout.strip().splitlines()[-1])


def mujoco60_noslip(iterations: int) -> int:
    """One run of the code now with the noslip pass capped at ``iterations`` (``--noslip N``), added to
    the stored result file beside the runs as built: what the per-step friction pass costs the diagnosis."""
    import json

    out = RESULTS / "bench_diagnose_mujoco60.json"
    stored = json.loads(out.read_text())
    r = _one_run("--noslip", str(int(iterations)))
    stored["noslip_cap"] = {"command": f"python benchmarks/bench_diagnose.py --case mujoco60 --noslip {iterations}",
                            "noslip_iterations": int(iterations), "wall_s": r["wall_s"], "cpu_s": r["cpu_s"],
                            "windows": r["windows"], "cause": r["cause"], "estimates": r["estimates"],
                            "load_before": r["load_before"], "load_after": r["load_after"]}
    print(f"noslip capped at {iterations}: wall {r['wall_s']:.1f} s, CPU {r['cpu_s']:.1f} s, cause {r['cause']}, "
          f"{r['estimates']}, load {r['load_before'][0]:.2f} -> {r['load_after'][0]:.2f}")
    out.write_text(json.dumps(stored, indent=1) + "\n")
    return 0


def mujoco60_profile() -> int:
    """One profiled run of the code now added to the stored result file (``--profile-only``)."""
    import json

    out = RESULTS / "bench_diagnose_mujoco60.json"
    stored = json.loads(out.read_text())
    r = _one_run("--profile")
    stored["profile"] = {"command": "python benchmarks/bench_diagnose.py --case mujoco60 --profile-only",
                         "wall_s": r["wall_s"], "load_before": r["load_before"], "load_after": r["load_after"],
                         "windows": r["windows"], "parts_s": r["profile_s"]}
    for k, v in r["profile_s"].items():
        print(f"  {k:62s} {v:7.1f} s")
    print(f"profiled run: {r['wall_s']:.1f} s under cProfile, load {r['load_before'][0]:.2f} -> {r['load_after'][0]:.2f}")
    out.write_text(json.dumps(stored, indent=1) + "\n")
    return 0


def mujoco60(old_tree: Path | None, repeats: int, change: str | None = None) -> int:
    """The mujoco60 case (module docstring): old and new alternating; writes its result file."""
    import json
    import statistics
    import subprocess

    from bench_calibrate import _simulate_logs

    runs: dict[str, list[dict]] = {"new": []} | ({"old": []} if old_tree else {})
    with tempfile.TemporaryDirectory() as tmp:
        _simulate_logs(Path(tmp))
        for _ in range(repeats):
            for label in reversed(list(runs)):  # old first, then new
                tree = ROOT if label == "new" else old_tree.resolve()
                env = {**os.environ, "PYTHONPATH": str(tree), "MUJOCO_GL": "egl"}
                out = subprocess.run([sys.executable, str(Path(__file__).resolve()), "--mujoco60-child", tmp],
                                     env=env, capture_output=True, text=True, check=False, cwd=str(tree))
                if out.returncode != 0:
                    raise SystemExit(f"{tree}: diagnose failed:\n{out.stderr[-3000:]}")
                r = json.loads(out.stdout.strip().splitlines()[-1])
                runs[label].append(r)
                print(f"{label}: wall {r['wall_s']:.1f} s, CPU {r['cpu_s']:.1f} s, {r['windows']} windows simulated, "
                      f"load {r['load_before'][0]:.2f} -> {r['load_after'][0]:.2f}; cause {r['cause']}", flush=True)
    med = {label: {k: statistics.median(r[k] for r in rs) for k in ("wall_s", "cpu_s", "windows")}
           for label, rs in runs.items()}
    if "old" in med:
        med["ratio_old_over_new"] = {k: med["old"][k] / max(med["new"][k], 1e-9) for k in ("wall_s", "cpu_s", "windows")}
        print("medians old / new: " + ", ".join(f"{k} {v:.2f}" for k, v in med["ratio_old_over_new"].items()))
    command = " ".join(["python benchmarks/bench_diagnose.py --case mujoco60 --repeats", str(repeats)]
                       + (["--old-tree DIR"] if old_tree else []) + ([f'--change "{change}"'] if change else []))
    out = RESULTS / "bench_diagnose_mujoco60.json"
    out.write_text(json.dumps({"command": command, "case": "mujoco60", "cpus": os.cpu_count(),
                               "target_wall_s": MUJOCO60_BUDGET_S, "change": change, "medians": med, "runs": runs},
                              indent=1) + "\n")
    print(f"wrote {out.relative_to(ROOT)}")
    return 0 if med["new"]["wall_s"] <= MUJOCO60_BUDGET_S else 1


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--effect", default="cg_offset_x", choices=sorted(HIDDEN) + ["none"])
    ap.add_argument("--minutes", type=float, default=10.0)
    ap.add_argument("--no-speeds", action="store_true")
    ap.add_argument("--horizon", default="auto", help="seconds, or auto (default)")
    ap.add_argument("--marmotte", type=Path, default=None, help="also run this real log (CSV with its JSON)")
    ap.add_argument("--case", choices=("surrogate", "mujoco60"), default="surrogate",
                    help="mujoco60: diagnose --baseline mujoco on a 60 s simulated log, old against new")
    ap.add_argument("--old-tree", type=Path, help="mujoco60: a checkout of the code to compare against")
    ap.add_argument("--repeats", type=int, default=1, help="mujoco60: runs of each (alternating; default 1)")
    ap.add_argument("--change", help="mujoco60 with --old-tree: what the new code changes, in words (stored, "
                                     "and shown on the results page)")
    ap.add_argument("--profile-only", action="store_true",
                    help="mujoco60: one run under cProfile, its parts added to the stored result file")
    ap.add_argument("--noslip", type=int, help="mujoco60: one more run of the code now with MuJoCo's noslip pass "
                                                "capped at N iterations, added to the stored result file")
    ap.add_argument("--mujoco60-child", help=argparse.SUPPRESS)
    ap.add_argument("--profile", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.mujoco60_child:
        _mujoco60_child(args.mujoco60_child, args.profile, args.noslip)
        return 0
    if args.case == "mujoco60" and args.noslip is not None:
        return mujoco60_noslip(args.noslip)
    if args.case == "mujoco60" and args.profile_only:
        return mujoco60_profile()
    if args.case == "mujoco60":
        return mujoco60(args.old_tree, args.repeats, args.change)
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        t0 = time.perf_counter()
        effect = None if args.effect == "none" else args.effect
        log, robot = make_log(effect, seed=42, duration=60.0 * args.minutes, speeds=not args.no_speeds)
        path = tmp / "synthetic.csv"
        write_log(log, path)
        write_robot(robot, path.with_suffix(".json"))
        print(f"synthetic log, hidden {args.effect} {HIDDEN.get(effect, '')}: generated in "
              f"{time.perf_counter() - t0:.1f} s (not part of the budget)")
        horizon = args.horizon if args.horizon == "auto" else float(args.horizon)
        total = run(path, tmp / "out", horizon)
        if args.marmotte is not None:
            print("real log:")
            run(args.marmotte, tmp / "marmotte", horizon)
    return 0 if total < BUDGET_S else 1


if __name__ == "__main__":
    with printed_result(default_run_result("bench_diagnose.txt"), command=benchmark_command(__file__)):
        status = main()
    sys.exit(status)
