"""Speed-up of `mjtrack sweep` from 1 to 2 dask workers, and identical numbers.

    python benchmarks/bench_sweep.py [--repeats 3] [--compare-chunk 4] [--out benchmarks/results/bench_sweep.json]

A 24-case grid of the default robot (4 speeds x 3 turn radii x 2 friction coefficients, the
default 3 s settle + 2 s window of `mjtrack steady`) runs on a local cluster of 1 worker
process and of 2 (one thread each). Each cluster is started and its workers have imported
mjtrack before the clock starts; the time is that of the sweep itself (first case submitted
to last result, ``SweepSummary.run_seconds``), and the whole call (with writing sweep.json
and drawing icr_map.png) is printed beside it. Median of --repeats runs. The two sweep.csv
files must be byte-identical. The machine's load average is printed, and the CPU time each
worker got during the sweep: on a 2-core machine shared with other jobs the workers get a
fraction of a core each, which caps the speed-up whatever the code does. The sweeps use the
default chunking (``mjtrack.sweep.run.auto_chunk_size``); ``--compare-chunk N`` also times both
clusters with N cases per chunk (4 was the fixed size before), in the same run.
"""

from __future__ import annotations

import argparse
import importlib
import json
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

GRID = {"speed": [0.3, 0.6, 0.9, 1.2], "turn_radius": [0.5, 1.0, 2.0], "mu": [0.5, 0.8]}


def sweep_times(n_workers: int, out: Path, repeats: int, grid_dict: dict, chunk_size: int | None = None) -> dict:
    from dask.distributed import Client, LocalCluster

    from mjtrack.sweep import grid_from_dict, run_sweep

    grid = grid_from_dict(grid_dict)
    runs = []
    with LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=True, dashboard_address=":0") as cluster, \
            Client(cluster) as client:
        client.run(importlib.import_module, "mjtrack.sweep.run")  # workers warm: imports done
        for k in range(repeats):
            d = out / f"w{n_workers}_{chunk_size}_{k}"
            cpu0 = client.run(time.process_time)
            s = run_sweep(grid, d, scheduler=cluster.scheduler_address, quiet=True, chunk_size=chunk_size)
            cpu = [client.run(time.process_time)[w] - c for w, c in cpu0.items()]
            assert s.ran == len(grid.cases)
            runs.append((s.run_seconds, s.seconds, cpu))
    run_s = statistics.median(r for r, _, _ in runs)
    cpu_s = [statistics.median(c[i] for _, _, c in runs) for i in range(n_workers)]
    return {"workers": n_workers, "run_seconds": run_s,
            "total_seconds": statistics.median(t for _, t, _ in runs), "all_runs": runs,
            "worker_cpu_seconds": cpu_s, "cpu_share": [c / run_s for c in cpu_s],
            "csv": (out / f"w{n_workers}_{chunk_size}_0" / "sweep.csv").read_bytes()}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--out", type=Path, default=None, help="JSON results file")
    ap.add_argument("--compare-chunk", type=int, default=None, metavar="N",
                    help="also time 1 and 2 workers with N cases per chunk (4: the fixed size before)")
    args = ap.parse_args()
    load_before = os.getloadavg()
    with tempfile.TemporaryDirectory() as tmp:
        one = sweep_times(1, Path(tmp), args.repeats, GRID)
        two = sweep_times(2, Path(tmp), args.repeats, GRID)
        old = None
        if args.compare_chunk:
            old = [sweep_times(n, Path(tmp), args.repeats, GRID, args.compare_chunk) for n in (1, 2)]
            same = all(o.pop("csv") == one["csv"] for o in old)
    load_after = os.getloadavg()
    identical = one.pop("csv") == two.pop("csv")
    speedup = one["run_seconds"] / two["run_seconds"]
    result = {"cases": 24, "grid": GRID, "cpu_count": os.cpu_count(), "loadavg_before": load_before,
              "loadavg_after": load_after, "one_worker": one, "two_workers": two,
              "speedup_run": speedup, "speedup_total": one["total_seconds"] / two["total_seconds"],
              "identical_csv": identical}
    print(f"load average (1, 5, 15 min): before {load_before[0]:.2f} {load_before[1]:.2f} {load_before[2]:.2f}, "
          f"after {load_after[0]:.2f} {load_after[1]:.2f} {load_after[2]:.2f} on {os.cpu_count()} cores")
    for r in (one, two):
        print(f"{r['workers']} worker(s): sweep {r['run_seconds']:.2f} s, whole call {r['total_seconds']:.2f} s "
              f"(median of {args.repeats}; {24 / r['run_seconds']:.1f} cases/s); CPU seconds per worker "
              f"{', '.join(f'{c:.2f}' for c in r['worker_cpu_seconds'])}, i.e. each worker got "
              f"{', '.join(f'{100 * c:.0f}%' for c in r['cpu_share'])} of a core")
    print(f"speed-up 1 -> 2 workers: {speedup:.2f}x (sweep), {result['speedup_total']:.2f}x (whole call)")
    print(f"sweep.csv byte-identical on 1 and 2 workers: {identical}")
    if old:
        o1, o2 = old
        result["compare_chunk"] = {"chunk_size": args.compare_chunk, "one_worker_s": o1["run_seconds"],
                                   "two_workers_s": o2["run_seconds"], "speedup_run": o1["run_seconds"] / o2["run_seconds"],
                                   "identical_csv": same}
        print(f"{args.compare_chunk} cases per chunk, same run: 1 worker {o1['run_seconds']:.2f} s, 2 workers "
              f"{o2['run_seconds']:.2f} s, speed-up {o1['run_seconds'] / o2['run_seconds']:.2f}x; "
              f"sweep.csv identical to the default chunking: {same}")
        identical = identical and same
    if args.out:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps(result, indent=1) + "\n")
    return 0 if identical else 1


if __name__ == "__main__":
    sys.exit(main())
