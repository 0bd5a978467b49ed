"""Issue 12: the steady ICR spread of the benchmark's generator against the diagnosis surrogate's.

    python experiments/generator_spread.py

For each geometry of tests/diagnose_physics.py (the independent physics the diagnosis benchmark
draws its logs from) and three constant commands, the steady ICRs of the generator (last 1 s
of 6 s, at its own settings: 5 ms step, 0.02 m/s regularisation, and at 1 ms / 0.001 m/s)
against those of the Coulomb reference of the robot *description* (mjtrack.models.coulomb,
which the surrogate's quasi-static ICRs q0 come from; its contact is a line per track, and the
column "width" gives it 2 points across the track width, as the generator has). The spread
y_l - y_r is what the
diagnosis effect `icr_spread` scales: a generator that turns with wider ICRs looks like an
icr_spread above 1 on a clean log once the surrogate's transient is right (branch
slip-resistance, session 7).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
import diagnose_physics as phys  # noqa: E402

from mjtrack.diagnose import surrogate as sg  # noqa: E402
from mjtrack.models import coulomb  # noqa: E402

COMMANDS = ((0.3, 0.5), (0.1, 0.3), (-0.3, 0.3))


def generator_icr(robot, kind, vl, vr, *, h=None, eps=None, duration=6.0):
    """(y_l, y_r, x_c) [m] of the generator's steady twist (mean of the last second)."""
    saved = phys.H, phys.EPS
    phys.H, phys.EPS = h or phys.H, eps or phys.EPS
    try:
        n = int(round(duration / phys.H))
        _, tw = phys.simulate(robot, kind, np.arange(n) * phys.H, np.tile([vl, vr], (n, 1)), mu=(robot.mu, robot.mu))
        vx, vy, wz = tw[-int(round(1.0 / phys.H)):].mean(0)
    finally:
        phys.H, phys.EPS = saved
    return np.array([(vx - vl) / wz, (vx - vr) / wz, -vy / wz])


def main() -> int:
    print(f"{'geometry':8s} {'command':>13s}  {'q0':>7s} {'coulomb':>8s} {'width':>7s} {'generator':>18s} "
          f"{'gen 1 ms, 0.001':>18s}  x_c coulomb / generator [m]")
    for name, (robot, kind) in phys.GEOMETRIES.items():
        q0 = sg.ground_response(robot).q0
        for vl, vr in COMMANDS:
            ref = np.array(coulomb.steady_state(robot, vl, vr).icr)
            wide = np.array(coulomb.steady_state(robot, vl, vr, n_across=2).icr)
            gen = generator_icr(robot, kind, vl, vr)
            fine = generator_icr(robot, kind, vl, vr, h=1e-3, eps=1e-3, duration=4.0)
            spread = lambda q: q[0] - q[1]  # noqa: E731
            print(f"{name:8s} ({vl:+.1f}, {vr:+.1f})  {spread(q0):7.4f} {spread(ref):8.4f} {spread(wide):7.4f} "
                  f"{spread(gen):8.4f} ({100 * (spread(gen) / spread(ref) - 1):+5.1f} %) "
                  f"{spread(fine):8.4f} ({100 * (spread(fine) / spread(ref) - 1):+5.1f} %)  "
                  f"{ref[2]:+.4f} / {gen[2]:+.4f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
