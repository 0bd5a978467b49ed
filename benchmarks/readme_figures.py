"""Regenerate the picture README shows: the middle frame of the demo's video.

    python benchmarks/readme_figures.py [--demo-dir DIR]

Runs ``mjtrack demo`` into DIR (default: a temporary folder, removed afterwards) unless DIR
already holds its video, then writes benchmarks/results/readme/video_frame.png (the middle frame
of video.mp4).
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import imageio.v3 as iio
from _results import RESULTS

from mjtrack.demo import run_demo

OUT = RESULTS / "readme"


def video_frame(demo_dir: Path) -> Path:
    """Write the middle frame of ``demo_dir``'s video (the demo is run there first if it has none)."""
    if not (demo_dir / "video.mp4").exists():
        run_demo(demo_dir, quiet=True)
    frames = iio.imread(demo_dir / "video.mp4")
    OUT.mkdir(parents=True, exist_ok=True)
    iio.imwrite(OUT / "video_frame.png", frames[len(frames) // 2])
    return OUT / "video_frame.png"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--demo-dir", type=Path, default=None)
    args = parser.parse_args()
    if args.demo_dir is not None:
        print(f"wrote {video_frame(args.demo_dir)} from {args.demo_dir}")
        return
    with tempfile.TemporaryDirectory(prefix="mjtrack-demo-") as tmp:
        print(f"wrote {video_frame(Path(tmp))}")


if __name__ == "__main__":
    main()
