"""Wall time of ``mjtrack demo`` and of each of its stages, plus its headline numbers.

    python experiments/bench_demo.py [--out DIR] [--json FILE]

Runs :func:`mjtrack.demo.run_demo` exactly as ``mjtrack demo --out DIR --quiet`` does (into a
temporary folder unless --out is given) and prints the wall time, the time of each stage
(rollout, validate, video) and the 2-s position RMSE of every predictor on the MuJoCo and on
the MPP truth. The issue asks for < 3 minutes on the 2-core development machine; there is no
timed unit test. --json also writes these numbers to FILE.
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


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=None, help="demo output folder (default: a temporary one)")
    parser.add_argument("--json", type=Path, default=None, help="also write the numbers to this JSON file")
    args = parser.parse_args(argv)

    from mjtrack.demo import run_demo

    with tempfile.TemporaryDirectory() as tmp:
        out = args.out or Path(tmp) / "demo"
        start = time.perf_counter()
        res = run_demo(out, quiet=True)
        wall = time.perf_counter() - start
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
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps({"wall_s": wall, "stage_s": res.stage_s, "headline": head,
                                         "cpus": os.cpu_count()}, indent=2) + "\n")
    return 0 if wall < 180 else 1


if __name__ == "__main__":
    sys.exit(main())
