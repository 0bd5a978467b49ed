"""Regenerate the two pictures README shows: a figure of the demo's report and a video frame.

    python benchmarks/readme_figures.py [--demo-dir DIR]

Runs ``mjtrack demo`` into DIR (default: a temporary folder) unless DIR already holds its
outputs, then writes benchmarks/results/readme/report_figure.png (the first figure embedded
in report.html: prediction error against horizon) and video_frame.png (the middle frame of
video.mp4).
"""

from __future__ import annotations

import argparse
import base64
import re
import tempfile
from pathlib import Path

import imageio.v3 as iio

from mjtrack.demo import run_demo
from mjtrack.testing.repo import RESULTS

OUT = RESULTS / "readme"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--demo-dir", type=Path, default=None)
    args = parser.parse_args()
    demo_dir = args.demo_dir or Path(tempfile.mkdtemp(prefix="mjtrack-demo-"))
    if not (demo_dir / "report.html").exists() or not (demo_dir / "video.mp4").exists():
        run_demo(demo_dir, quiet=True)
    OUT.mkdir(parents=True, exist_ok=True)
    html = (demo_dir / "report.html").read_text()
    first = re.search(r'src="data:image/png;base64,([A-Za-z0-9+/=]+)"', html)
    if first is None:
        raise SystemExit("report.html has no embedded figure")
    (OUT / "report_figure.png").write_bytes(base64.b64decode(first.group(1)))
    frames = iio.imread(demo_dir / "video.mp4")
    iio.imwrite(OUT / "video_frame.png", frames[len(frames) // 2])
    print(f"wrote {OUT / 'report_figure.png'} and {OUT / 'video_frame.png'} from {demo_dir}")


if __name__ == "__main__":
    main()
