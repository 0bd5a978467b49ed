"""Wall time of ``mjtrack demo`` and of each of its stages, the code before a change against the code
now in one run, with a profile of where the seconds go; plus the demo's headline numbers.

    nice -n 10 python benchmarks/bench_demo.py [--old-tree DIR] [--repeats N] [--no-profile]
                                               [--out DIR] [--json FILE] [--readme-frame]

Each demo runs as ``mjtrack demo --out DIR --quiet`` does (:func:`mjtrack.demo.run_demo` on its
defaults) in a fresh Python process with that code on its path; ``--old-tree DIR``: a checkout of
the code to compare against (e.g. ``git archive REV | tar -x -C DIR``), run alternately with the
code now (old, new, old, new, ...) so that both see the same load. Each run reports its wall time,
its CPU time (the process and every process it waited for: the video worker, the encoder; also
each apart), its stage times (rollout, validate, video; the video may run beside the validation)
and the load average before and after.

The profile (unless ``--no-profile``): one more run of each code under cProfile, everything in one
process (the video after the validation), its wall time summed into named parts: compiling MuJoCo
models, the rollout, each filter, the scoring of the predictors, the HTML report, rendering and
reading back the frames, drawing the decorations, encoding the video; with the frame count, so that
a frame's cost can be read off. cProfile slows Python-heavy parts more than the rest: its numbers
say where the time goes, the unprofiled runs how long the demo takes.

Prints all of it and writes benchmarks/results/bench_demo.json (or --json FILE): ``wall_s``,
``stage_s``, ``headline`` are the median run of the code now (README's and ``demo --help``'s
stated time is checked against ``wall_s``). Exit status 1 when the code now takes 3 minutes or more;
no unit test times it (the machine's load decides too much).

``--readme-frame`` also writes the picture README shows, the middle frame of the demo's video, to
benchmarks/results/readme/video_frame.png.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from _results import RESULTS, benchmark_command

ROOT = Path(__file__).resolve().parent.parent

#: profile parts: name -> functions (file suffix, function name) whose cumulative times add up
PARTS = {
    "compile MuJoCo models": [("mjtrack/sim/builder.py", "build_model")],
    "rollout": [("mjtrack/sim/rollout.py", "drive_log")],
    "slip EKF (MPP)": [("mjtrack/estimation/slip_ekf.py", "run_slip_ekf")],
    "ICR EKF (MICR)": [("mjtrack/estimation/icr_ekf.py", "run_icr_ekf")],
    "VIR filter (MVIR)": [("mjtrack/estimation/vir_filter.py", "run_vir_filter")],
    "scoring the predictors": [("mjtrack/validate/evaluate.py", "evaluate_case")],  # less the filters, below
    "report (figures, HTML)": [("mjtrack/validate/report.py", "build_report")],
    "render frames (OpenGL)": [("~", "<built-in method mujoco._render.mjr_render>"),
                               ("~", "<built-in method mujoco._render.mjr_readPixels>"),
                               ("~", "<built-in method mujoco._render.mjr_overlay>")],
    "decorations (grid, trail, belts, ICRs)": [("mjtrack/render/decor.py", f) for f in
                                               ("draw_grid", "draw_polyline", "draw_markers", "draw_belt",
                                                "blend_top_right")],
    "encode video": [("imageio/plugins/ffmpeg.py", "_append_data"), ("imageio/plugins/ffmpeg.py", "_close")],
}
FILTERS = ("slip EKF (MPP)", "ICR EKF (MICR)", "VIR filter (MVIR)")

# One demo in this process (the code on sys.path); prints one JSON line. argv: out_dir, profile (0/1).
CHILD = r"""
import inspect, json, os, resource, sys, time
from mjtrack.demo import run_demo
out, profile = sys.argv[1], sys.argv[2] == "1"
kw = {"quiet": True}
if profile and "workers" in inspect.signature(run_demo).parameters:
    kw["workers"] = 1  # everything in this process, where cProfile sees it
load0 = os.getloadavg()
prof = None
if profile:
    import cProfile
    prof = cProfile.Profile()
    prof.enable()
tic = time.perf_counter()
res = run_demo(out, **kw)
wall = time.perf_counter() - tic
if prof is not None:
    prof.disable()
own, waited = (sum(getattr(resource.getrusage(w), f) for f in ("ru_utime", "ru_stime"))
               for w in (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN))
doc = {"wall_s": wall, "cpu_s": own + waited, "cpu_main_s": own, "cpu_workers_s": waited,
       "stage_s": res.stage_s, "headline": res.headline,
       "video_concurrent": getattr(res, "video_concurrent", False), "ran": list(getattr(res, "ran", ())),
       "load_before": load0, "load_after": os.getloadavg()}
if prof is not None:
    import pstats
    st = pstats.Stats(prof).stats
    doc["functions"] = [[f, line, name, ct, nc] for (f, line, name), (cc, nc, tt, ct, callers) in st.items()]
print("RESULT " + json.dumps(doc))
"""


def run_child(tree: Path, out: Path, *, profile: bool) -> dict:
    """One demo in a fresh process with ``tree``'s mjtrack on the path; its result dict."""
    env = {**os.environ, "PYTHONPATH": str(tree)}
    proc = subprocess.run([sys.executable, "-c", CHILD, str(out), "1" if profile else "0"], env=env,
                          capture_output=True, text=True, cwd=tree)
    lines = [ln for ln in proc.stdout.splitlines() if ln.startswith("RESULT ")]
    if proc.returncode != 0 or not lines:
        raise SystemExit(f"the demo of {tree} failed:\n{proc.stderr[-3000:]}")
    return json.loads(lines[-1].removeprefix("RESULT "))


def profile_parts(functions: list) -> dict:
    """The profile's cumulative seconds summed into :data:`PARTS` (the filters taken out of the scoring)."""
    parts = {}
    for part, names in PARTS.items():
        parts[part] = sum(ct for f, _, name, ct, _ in functions
                          if any(name == want and f.replace(os.sep, "/").endswith(suffix) for suffix, want in names))
    parts["scoring the predictors"] -= sum(parts[f] for f in FILTERS)
    out = {"parts_s": parts}
    frames = [nc for f, _, name, _, nc in functions if name == "<built-in method mujoco._render.mjr_render>"]
    if frames:
        out["frames"] = frames[0]
        out["render_ms_per_frame"] = 1000 * parts["render frames (OpenGL)"] / frames[0]
        out["decorations_ms_per_frame"] = 1000 * parts["decorations (grid, trail, belts, ICRs)"] / frames[0]
        out["encode_ms_per_frame"] = 1000 * parts["encode video"] / frames[0]
    return out


def readme_frame(demo_dir: Path) -> Path:
    """Write the middle frame of ``demo_dir``'s video as README's picture; its path."""
    import imageio.v3 as iio

    frames = iio.imread(demo_dir / "video.mp4")
    (RESULTS / "readme").mkdir(parents=True, exist_ok=True)
    iio.imwrite(RESULTS / "readme" / "video_frame.png", frames[len(frames) // 2])
    return RESULTS / "readme" / "video_frame.png"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--old-tree", type=Path, default=None,
                        help="a checkout of the code to compare against (default: only the code now)")
    parser.add_argument("--repeats", type=int, default=1, help="timed runs of each code (default 1)")
    parser.add_argument("--no-profile", action="store_true", help="skip the profiled runs")
    parser.add_argument("--out", type=Path, default=None, help="the last demo's output folder (default: temporary)")
    parser.add_argument("--json", type=Path, default=RESULTS / "bench_demo.json",
                        help="result file (default benchmarks/results/bench_demo.json)")
    parser.add_argument("--readme-frame", action="store_true",
                        help="also write README's picture: the middle frame of the demo's video "
                             "(benchmarks/results/readme/video_frame.png)")
    args = parser.parse_args(argv)

    trees = {"old": args.old_tree.resolve()} if args.old_tree else {}
    trees["new"] = ROOT
    runs = {k: [] for k in trees}
    profile = {}
    load0 = os.getloadavg()
    with tempfile.TemporaryDirectory() as tmp:
        last = None
        for i in range(args.repeats):
            for key, tree in trees.items():
                last = args.out if args.out and key == "new" else Path(tmp) / f"{key}{i}"
                res = run_child(tree, last, profile=False)
                runs[key].append(res)
                print(f"{key} run {i + 1}: {res['wall_s']:.1f} s wall, {res['cpu_s']:.1f} s CPU "
                      f"({res['cpu_main_s']:.1f} s this process, {res['cpu_workers_s']:.1f} s the processes it "
                      f"waited for), load {res['load_before'][0]:.2f} -> {res['load_after'][0]:.2f}", flush=True)
        if args.readme_frame:
            print(f"wrote {readme_frame(last)}")
        if not args.no_profile:
            for key, tree in trees.items():
                res = run_child(tree, Path(tmp) / f"{key}-profile", profile=True)
                profile[key] = {"wall_s": res["wall_s"], "stage_s": res["stage_s"],
                                "load_before": res["load_before"], "load_after": res["load_after"],
                                **profile_parts(res["functions"])}
    medians = {k: {q: statistics.median(r[q] for r in v) for q in ("wall_s", "cpu_s", "cpu_main_s", "cpu_workers_s")}
               for k, v in runs.items()}
    new = sorted(runs["new"], key=lambda r: r["wall_s"])[(len(runs["new"]) - 1) // 2]  # the median run

    print(f"machine: {platform.machine()}, {os.cpu_count()} cpus, python {platform.python_version()}")
    for key in trees:
        print(f"{key}: median wall {medians[key]['wall_s']:.1f} s, CPU {medians[key]['cpu_s']:.1f} s")
    print(f"demo wall time (code now, median): {new['wall_s']:.1f} s (limit 180 s)")
    for stage, seconds in new["stage_s"].items():
        print(f"  {stage:<9} {seconds:6.1f} s")
    for line in new["ran"]:
        print(f"  ran {line}")
    for key, prof in profile.items():
        print(f"\nprofile of the {key} code (one process, cProfile; {prof['wall_s']:.1f} s, "
              f"load {prof['load_before'][0]:.2f} -> {prof['load_after'][0]:.2f}):")
        for part, seconds in prof["parts_s"].items():
            print(f"  {part:<40} {seconds:6.1f} s")
        if "frames" in prof:
            print(f"  {prof['frames']} frames: {prof['render_ms_per_frame']:.1f} ms rendering, "
                  f"{prof['decorations_ms_per_frame']:.1f} ms decorations, {prof['encode_ms_per_frame']:.1f} ms "
                  "encoding per frame")
    head = new["headline"]
    keys = list(next(iter(head["pos_rmse_m"].values())))
    print(f"\n{head['horizon_s']:g}-s position RMSE [m]      " + "  ".join(f"{t:>8}" for t in head["pos_rmse_m"]))
    for key in keys:
        vals = [head["pos_rmse_m"][t][key] for t in head["pos_rmse_m"]]
        print(f"  {key:<26}" + "  ".join("  failed" if v is None else f"{v:8.3g}" for v in vals))
    argv = sys.argv[1:] if argv is None else list(argv)
    if args.old_tree:  # the old checkout is a scratch folder: the command names it by its role
        argv = [a for a in argv if a.split("=")[0] != "--old-tree" and Path(a).resolve() != trees["old"]]
        argv = ["--old-tree", "DIR", *argv]
    doc = {"command": benchmark_command(__file__, argv), "wall_s": new["wall_s"], "cpu_s": new["cpu_s"],
           "stage_s": new["stage_s"], "video_concurrent": new["video_concurrent"], "ran": new["ran"],
           "headline": head, "cpus": os.cpu_count(), "load_average_before": load0,
           "load_average_after": os.getloadavg(), "medians": medians,
           "runs": {k: [{q: r[q] for q in ("wall_s", "cpu_s", "cpu_main_s", "cpu_workers_s", "stage_s", "load_before",
                                          "load_after")} for r in v]
                    for k, v in runs.items()},
           "profile": profile}
    args.json.parent.mkdir(parents=True, exist_ok=True)
    args.json.write_text(json.dumps(doc, indent=2) + "\n")
    return 0 if new["wall_s"] < 180 else 1


if __name__ == "__main__":
    sys.exit(main())
