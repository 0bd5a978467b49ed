"""Render-speed check: ``python -m mjtrack.render.bench [--frames N] [--width W --height H]``.

Prints which offscreen backends work here (each probed in a subprocess) and the frames per
second of :func:`mjtrack.render.render_video` on the default tracked robot driving a circle,
with and without shadows: ``render`` counts scene update + OpenGL render + read-back,
``total`` adds interpolation and H.264 encoding.
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np

from mjtrack.render import gl


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=150)
    parser.add_argument("--width", type=int, default=640)
    parser.add_argument("--height", type=int, default=480)
    args = parser.parse_args(argv)
    for backend in gl.CANDIDATES:
        why = gl.probe(backend)
        print(f"backend {backend}: {'works' if why is None else 'fails: ' + why}")
    print(f"selected MUJOCO_GL={gl.select_backend()}")

    from mjtrack.io.robot import Robot
    from mjtrack.render.video import qpos_from_poses, render_video
    from mjtrack.sim.builder import build_model

    model = build_model(Robot())
    fps = 30.0
    t = np.linspace(0.0, (args.frames - 1) / fps, 200)
    yaw = 0.5 * t
    poses = np.column_stack([1.5 * np.sin(yaw), 1.5 * (1 - np.cos(yaw)), yaw])
    icr = np.column_stack([np.zeros_like(t), np.full_like(t, 1.5)])
    qpos = qpos_from_poses(model, poses)
    with tempfile.TemporaryDirectory() as folder:
        for shadows in (False, True):
            stats = render_video(model, qpos, t, Path(folder) / "bench.mp4", width=args.width,
                                 height=args.height, fps=fps, icr=icr, shadows=shadows, progress=False)
            print(f"{args.width}x{args.height} shadows={shadows}: {stats.frames} frames, "
                  f"render {stats.frames / stats.render_s:.1f} frames/s, total {stats.frames / stats.total_s:.1f} frames/s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
