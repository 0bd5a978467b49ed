"""Wall time of ``mjtrack demo`` and of each of its stages, plus its headline numbers.

    python benchmarks/bench_demo.py [--out DIR] [--json FILE] [--readme-frame]

Runs :func:`mjtrack.demo.run_demo` exactly as ``mjtrack demo --out DIR --quiet`` does (into a
temporary folder unless --out is given) and prints the wall time, the time of each stage
(rollout, validate, video) and the 2-s position RMSE of every predictor on the MuJoCo and on
the MPP truth, and writes them to benchmarks/results/bench_demo.json (or --json FILE) with the
machine's load average. Exit status 1 when the demo takes 3 minutes or more; no unit test times it
(the machine's load decides too much).

``--readme-frame`` also writes the picture README shows, the middle frame of the demo's video, to
benchmarks/results/readme/video_frame.png.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import tempfile
import time
from pathlib import Path

from _results import RESULTS, benchmark_command


def readme_frame(demo_dir: Path) -> Path:
    """Write the middle frame of ``demo_dir``'s video as README's picture; its path."""
    import imageio.v3 as iio

    frames = iio.imread(demo_dir / "video.mp4")
    (RESULTS / "readme").mkdir(parents=True, exist_ok=True)
    iio.imwrite(RESULTS / "readme" / "video_frame.png", frames[len(frames) // 2])
    return RESULTS / "readme" / "video_frame.png"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=None, help="demo output folder (default: a temporary one)")
    parser.add_argument("--json", type=Path, default=RESULTS / "bench_demo.json",
                        help="result file (default benchmarks/results/bench_demo.json)")
    parser.add_argument("--readme-frame", action="store_true",
                        help="also write README's picture: the middle frame of the demo's video "
                             "(benchmarks/results/readme/video_frame.png)")
    args = parser.parse_args(argv)

    from mjtrack.demo import run_demo

    with tempfile.TemporaryDirectory() as tmp:
        out = args.out or Path(tmp) / "demo"
        load0 = os.getloadavg()
        start = time.perf_counter()
        res = run_demo(out, quiet=True)
        wall = time.perf_counter() - start
        if args.readme_frame:
            print(f"wrote {readme_frame(out)}")
    print(f"machine: {platform.machine()}, {os.cpu_count()} cpus, python {platform.python_version()}")
    print(f"demo wall time: {wall:.1f} s (limit 180 s)")
    for stage, seconds in res.stage_s.items():
        print(f"  {stage:<9} {seconds:6.1f} s")
    if res.video_skipped:
        print(f"  video skipped: {res.video_skipped}")
    head = res.headline
    keys = list(next(iter(head["pos_rmse_m"].values())))
    print(f"\n{head['horizon_s']:g}-s position RMSE [m]      " + "  ".join(f"{t:>8}" for t in head["pos_rmse_m"]))
    for key in keys:
        vals = [head["pos_rmse_m"][t][key] for t in head["pos_rmse_m"]]
        print(f"  {key:<26}" + "  ".join("  failed" if v is None else f"{v:8.3g}" for v in vals))
    args.json.parent.mkdir(parents=True, exist_ok=True)
    args.json.write_text(json.dumps({"command": benchmark_command(__file__, argv), "wall_s": wall,
                                     "stage_s": res.stage_s, "headline": head, "cpus": os.cpu_count(),
                                     "load_average_before": load0, "load_average_after": os.getloadavg()},
                                    indent=2) + "\n")
    return 0 if wall < 180 else 1


if __name__ == "__main__":
    sys.exit(main())
