"""ICRs of the real Marmotte robot from its lidar poses, per turn direction (README's numbers).

    python benchmarks/marmotte_icrs.py [LOG.csv]   (default ../shared/data/marmotte/marmotte_boreal.csv)

For every steady 2 s window (column ``steady`` = 1) the mean body twist is the window's pose
increment over its duration in the body frame of its first pose, and the track speeds are the
window means of the measured ``v_left``, ``v_right``; ICRs by (2.13) where |w| >= 0.2 rad/s.
Prints the medians per turn direction, the measured/commanded track-speed ratio, the yaw-rate
ratio to the nominal model driven by the measured speeds, and the sign agreement of the
``wz_imu`` column with the lidar yaw rate.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from mjtrack.geometry import relative_pose
from mjtrack.icr import icr_from_twist
from mjtrack.io import read_log_with_robot
from mjtrack.testing.repo import benchmark_command, default_run_result, printed_result

DEFAULT = Path(__file__).resolve().parents[2] / "shared" / "data" / "marmotte" / "marmotte_boreal.csv"


def main(path: Path) -> None:
    log, robot = read_log_with_robot(path)
    steady = log.extra["steady"]
    rows = []
    for sl in log.segment_slices():
        if steady[sl.start] != 1 or sl.stop - sl.start < 10:
            continue
        t = log.t[sl]
        yaw = np.unwrap(log.yaw[sl])
        p0 = np.array([log.x[sl][0], log.y[sl][0], yaw[0]])
        p1 = np.array([log.x[sl][-1], log.y[sl][-1], yaw[-1]])
        d = relative_pose(p0, p1)
        dt = t[-1] - t[0]
        # mean twist of a constant-twist arc: exact inverse of the SE(2) step
        wz = (yaw[-1] - yaw[0]) / dt
        phi = wz * dt
        s, c = (np.sin(phi) / phi, (1 - np.cos(phi)) / phi) if abs(phi) > 1e-9 else (1.0, 0.0)
        vx, vy = np.linalg.solve(np.array([[s, -c], [c, s]]) * dt, d[:2])
        rows.append((vx, vy, wz, log.v_left[sl].mean(), log.v_right[sl].mean(),
                     log.v_left_cmd[sl].mean(), log.v_right_cmd[sl].mean(), log.extra["wz_imu"][sl].mean()))
    vx, vy, wz, vl, vr, vlc, vrc, wimu = np.array(rows).T
    print(f"{path.name}: {len(rows)} steady windows, track gauge T = {robot.track_gauge} m (T/2 = {robot.track_gauge / 2:.3f})")
    for v, vc, side in ((vl, vlc, "left"), (vr, vrc, "right")):
        ok = np.abs(vc) > 0.2
        print(f"  measured/commanded {side} track speed (|cmd| > 0.2 m/s): median {np.median(v[ok] / vc[ok]):.3f}")
    wnom = (vr - vl) / robot.track_gauge
    ok = np.abs(wnom) > 0.3
    print(f"  yaw rate / nominal (2.1) with measured speeds (|w_nom| > 0.3): median {np.median(wz[ok] / wnom[ok]):.3f}")
    turning = np.abs(wz) >= 0.2
    icr = icr_from_twist(vx[turning], vy[turning], wz[turning], vl[turning], vr[turning])
    for sign, name in ((1, "left turns"), (-1, "right turns")):
        m = np.sign(wz[turning]) == sign
        print(f"  {name} ({m.sum()} windows): median y_l {np.median(icr.y_l[m]):+.3f} m, "
              f"y_r {np.median(icr.y_r[m]):+.3f} m, x_c {np.median(icr.x_c[m]):+.3f} m")
    big = np.abs(wz) > 0.2
    agree = np.mean(np.sign(wimu[big]) == np.sign(wz[big]))
    print(f"  wz_imu has the sign of the lidar yaw rate in {100 * agree:.0f} % of turning windows")


if __name__ == "__main__":
    with printed_result(default_run_result("marmotte_icrs.txt"), command=benchmark_command(__file__)):
        status = main(Path(sys.argv[1]) if len(sys.argv) > 1 else DEFAULT)
    sys.exit(status)
