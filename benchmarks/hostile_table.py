"""Hostile command lines and interrupts, each run as a user would run it: exit status, the first
line of stderr, the number of stderr lines, wall time and what the command left in its output.

Every run is a real ``python -m mjtrack.cli`` process under a 4 GB address-space cap and a 120 s
limit. Interrupts are sent to the whole process group (what Ctrl-C in a terminal does) after a
fixed delay. Writes benchmarks/results/hostile_table.json (and prints a table).

    PYTHONPATH=$PWD python3 benchmarks/hostile_table.py [--only SUBSTRING]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
RESULT = ROOT / "benchmarks" / "results" / "hostile_table.json"
MEMORY_CAP = 4_000_000_000  # [bytes] address space of each run
TIMEOUT_S = 120.0


def _cap() -> None:
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY_CAP, MEMORY_CAP))


def run(argv: list[str], cwd: Path, *, interrupt: tuple[int, float] | None = None) -> dict:
    """One run: {rc, first_stderr_line, stderr_lines, seconds, traceback}; ``interrupt`` =
    (signal, delay [s]) sends the signal to the process group after the delay."""
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    t0 = time.monotonic()
    proc = subprocess.Popen([sys.executable, "-m", "mjtrack.cli", *argv], cwd=cwd, env=env, text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True,
                            preexec_fn=_cap)
    t_sig = None
    if interrupt is not None:
        sig, delay = interrupt
        try:
            proc.wait(timeout=delay)
        except subprocess.TimeoutExpired:
            t_sig = time.monotonic()
            os.killpg(proc.pid, sig)
    try:
        out, err = proc.communicate(timeout=TIMEOUT_S - (time.monotonic() - t0))
        rc = proc.returncode
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        out, err = proc.communicate()
        rc = "timeout"
    t1 = time.monotonic()
    lines = [ln for ln in err.splitlines() if ln.strip()]
    res = {"rc": rc, "first_stderr_line": lines[0][:160] if lines else "", "stderr_lines": len(lines),
           "seconds": round(t1 - t0, 2), "traceback": "Traceback" in err}
    if t_sig is not None:
        res["seconds_after_signal"] = round(t1 - t_sig, 2)
    return res


def listing(folder: Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*")) if folder.exists() else []


def prepare(d: Path) -> None:
    mj = [sys.executable, "-m", "mjtrack.cli"]
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    subprocess.run([*mj, "simulate", "--scenario", "random_steps", "--duration", "40", "--out", str(d / "log.csv"),
                    "-q"], check=True, env=env)
    (d / "deep.json").write_text("[" * 100_000)
    (d / "wheel_count.json").write_text(json.dumps({"track_gauge": 0.4, "wheel_count": 4}))
    (d / "typo.json").write_text(json.dumps({"track_gauge": 0.4, "drive_lags": 0.3}))
    (d / "scalar_grid.json").write_text(json.dumps({"speed": 0.5, "turn_radius": [1.0]}))
    (d / "grid24.json").write_text(json.dumps({"v_left_cmd": [0.2, 0.4, 0.6, 0.8, 1.0, 1.2],
                                               "v_right_cmd": [0.3, 0.5, 0.7, 0.9]}))
    import imageio.v3 as iio

    iio.imwrite(d / "huge.png", np.zeros((10_000, 10_000), dtype=np.uint8))
    (d / "huge_terrain.json").write_text(json.dumps({"hfield": {"file": "huge.png", "size_x": 20, "size_y": 20,
                                                                "height": 0.1}}))
    (d / "existing.csv").write_text("keep me\n")
    (d / "existing.tum").write_text("keep me\n")


def cases(d: Path) -> list[tuple[str, list[str], dict]]:
    log = str(d / "log.csv")
    return [
        ("diagnose --folds 1e9", ["diagnose", log, "--folds", "1000000000", "--out", "D1"], {}),
        ("steady --v-left 1e300", ["steady", "--v-left", "1e300", "--v-right", "0.5"], {}),
        ("steady --v-left -1e300", ["steady", "--v-left", "-1e300", "--v-right", "0.5"], {}),
        ("steady --v-left=-1e300", ["steady", "--v-left=-1e300", "--v-right", "0.5"], {}),
        ("steady --v-left 1000", ["steady", "--v-left", "1000", "--v-right", "0.5"], {}),
        ("steady --settle 1e12", ["steady", "--v-left", "0.5", "--v-right", "0.6", "--settle", "1e12"], {}),
        ("track --laps 1e12", ["track", "--laps", "1000000000000", "--out", "T1"], {}),
        ("track --speed 1e300", ["track", "--scenario", "circle", "--speed", "1e300", "--out", "T2"], {}),
        ("steady --robot deep.json", ["steady", "--v-left", "0.5", "--v-right", "0.6", "--robot", "deep.json"], {}),
        ("render --width 1000000", ["render", log, "--width", "1000000", "--out", "R1.mp4"], {}),
        ("simulate on a 10000x10000 PNG height field",
         ["simulate", "--scenario", "straight", "--duration", "1", "--terrain", "huge_terrain.json",
          "--out", "S1.csv"], {}),
        ("robot key wheel_count", ["simulate", "--scenario", "straight", "--duration", "0.2", "--robot",
                                   "wheel_count.json", "--out", "S2.csv"], {}),
        ("robot key drive_lags", ["simulate", "--scenario", "straight", "--duration", "0.2", "--robot", "typo.json",
                                  "--out", "S3.csv"], {}),
        ("grid scalar speed", ["sweep", "--grid", "scalar_grid.json", "--out", "W1", "--workers", "1"], {}),
        ("Ctrl-C during sweep", ["sweep", "--grid", "grid24.json", "--out", "W2", "--workers", "2"],
         {"interrupt": (signal.SIGINT, 25.0), "keep": True}),
        ("the same sweep again (resume)", ["sweep", "--grid", "grid24.json", "--out", "W2", "--workers", "2"], {}),
        ("Ctrl-C during calibrate", ["calibrate", log, "--track-length", "0.5", "--out", "C1"],
         {"interrupt": (signal.SIGINT, 12.0)}),
        ("Ctrl-C during demo", ["demo", "--out", "M1"], {"interrupt": (signal.SIGINT, 25.0)}),
        ("Ctrl-C during simulate --duration 3000", ["simulate", "--scenario", "random_steps", "--duration", "3000",
                                                    "--out", "S4.csv"], {"interrupt": (signal.SIGINT, 5.0)}),
        ("SIGTERM during simulate --duration 3000", ["simulate", "--scenario", "random_steps", "--duration", "3000",
                                                     "--out", "S5.csv"], {"interrupt": (signal.SIGTERM, 5.0)}),
        ("simulate onto an existing file", ["simulate", "--scenario", "straight", "--duration", "0.2",
                                            "--out", "existing.csv"], {}),
        ("export onto an existing file", ["export", log, "--format", "tum", "--out", "existing.tum"], {}),
    ]


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--only", default=None, help="run the cases whose name contains this")
    args = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory(prefix="mjtrack-hostile-") as tmp:
        d = Path(tmp)
        prepare(d)
        before = set(listing(d))
        for name, argv, kw in cases(d):
            if args.only and args.only not in name:
                continue
            keep = kw.pop("keep", False)
            res = run(argv, d, **kw)
            res["left"] = sorted(set(listing(d)) - before)
            res["name"] = name
            res["argv"] = argv
            rows.append(res)
            print(f"{name:45s} rc={res['rc']!s:8s} {res['seconds']:7.2f}s lines={res['stderr_lines']:<3d} "
                  f"{res['first_stderr_line'][:100]}  left={res['left'][:6]}", flush=True)
            if keep:  # the next case resumes from what this one left
                continue
            # each case starts from the prepared inputs
            for rel in sorted(res["left"], key=len, reverse=True):
                p = d / rel
                if p.is_dir():
                    import shutil

                    shutil.rmtree(p, ignore_errors=True)
                elif p.exists():
                    p.unlink()
            (d / "existing.csv").write_text("keep me\n")
            (d / "existing.tum").write_text("keep me\n")
    if not args.only:
        RESULT.write_text(json.dumps({"memory_cap_bytes": MEMORY_CAP, "timeout_s": TIMEOUT_S, "cases": rows},
                                     indent=1) + "\n")


if __name__ == "__main__":
    main()
