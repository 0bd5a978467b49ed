"""The steady ICR spread of the benchmark's generator against the diagnosis surrogate's.

    python benchmarks/generator_spread.py

For each geometry of mjtrack/testing/diagnose_physics.py (the independent physics the diagnosis benchmark
draws its logs from) and three constant commands, the steady ICRs of the generator (last 1 s
of 6 s, at its own settings: 5 ms step, 0.02 m/s regularisation, and at 1 ms / 0.001 m/s)
against those of the Coulomb reference of the robot *description* (mjtrack.models.coulomb,
which the surrogate's quasi-static ICRs q0 come from; its contact is a line per track, and the
column "width" gives it 2 points across the track width, as the generator has). The spread
y_l - y_r is what the
diagnosis effect `icr_spread` scales: a generator that turns with wider ICRs looks like an
icr_spread above 1 on a clean log once the surrogate's transient is right (its slip resistance from the first instant).

Second table: what the generator's numerics do to its transients. On the four-contact body of
the wheeled geometry (the rollout with a 1.0 m line of two midpoints per side and the
generator's yaw inertia, as in tests/test_coulomb_transient.py), the yaw dead time
int (w_end - w)/(w_end - w_0) dt over 1 s after a turn entry (0.5, 0.5) -> (0.5, 0) and a spin
start (0, 0) -> (-0.5, 0.5) m/s: the generator at its settings, with its step or its
regularisation made small alone, and both small, beside the converged Coulomb rollout.
"""

from __future__ import annotations

import sys

import numpy as np

from mjtrack.diagnose import select as sel
from mjtrack.diagnose import surrogate as sg
from mjtrack.models import coulomb
from mjtrack.testing import diagnose_physics as phys
from _results import benchmark_command, default_run_result, printed_result

COMMANDS = ((0.3, 0.5), (0.1, 0.3), (-0.3, 0.3))
STEPS = (((0.5, 0.5), (0.5, 0.0)), ((0.0, 0.0), (-0.5, 0.5)))


def spread(q) -> float:
    """y_l - y_r [m]."""
    return float(q[0] - q[1])


def _dead(t, w) -> float:
    d = (w[-1] - w) / (w[-1] - w[0])
    return float(np.sum(0.5 * (d[1:] + d[:-1]) * np.diff(t)))


def generator_dead_time(u0, u1, *, h, eps, duration=1.0) -> float:
    """Yaw dead time [s] of the generator (wheeled geometry) after the step u0 -> u1 [m/s]."""
    robot, kind = phys.GEOMETRIES["wheeled"]
    saved = phys.H, phys.EPS
    phys.H, phys.EPS = h, eps
    try:
        pre, n = int(round(0.5 / h)), int(round(duration / h))
        u = np.r_[np.tile(u0, (pre, 1)), np.tile(u1, (n, 1))]
        _, tw = phys.simulate(robot, kind, np.arange(u.shape[0]) * h, u, mu=(robot.mu, robot.mu))
    finally:
        phys.H, phys.EPS = saved
    w = np.r_[tw[pre - 1, 2], tw[pre:, 2]]  # tw[k]: after step k; the new command acts in step pre
    return _dead(np.arange(w.size) * h, w)


def rollout_dead_time(u0, u1, duration=1.0) -> float:
    """The same for the converged Coulomb rollout of the same four-contact body."""
    robot, _ = phys.GEOMETRIES["wheeled"]
    body = robot.replace(track_length=2 * phys.WHEELBASE)
    inertia = robot.mass * (robot.track_length**2 + robot.track_gauge**2) / 12
    tw0 = (u0[0], 0.0, 0.0) if u0[0] == u0[1] else tuple(coulomb.steady_state(body, *u0, n_points=2).twist)
    t = np.arange(0.0, duration + 5e-4, 1e-3)
    w = coulomb.rollout(body, t, u1[0], u1[1], twist0=tw0, n_points=2, inertia=inertia).twist[:, 2]
    return _dead(t, w)


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
    gaps = []  # generator spread / reference spread - 1, at the generator's settings
    for name, (robot, kind) in phys.GEOMETRIES.items():
        q0 = sg.ground_response(robot).q0
        for vl, vr in COMMANDS:
            ref = np.array(coulomb.steady_state(robot, vl, vr).icr)
            wide = np.array(coulomb.steady_state(robot, vl, vr, n_across=2).icr)
            gen = generator_icr(robot, kind, vl, vr)
            fine = generator_icr(robot, kind, vl, vr, h=1e-3, eps=1e-3, duration=4.0)
            print(f"{name:8s} ({vl:+.1f}, {vr:+.1f})  {spread(q0):7.4f} {spread(ref):8.4f} {spread(wide):7.4f} "
                  f"{spread(gen):8.4f} ({100 * (spread(gen) / spread(ref) - 1):+5.1f} %) "
                  f"{spread(fine):8.4f} ({100 * (spread(fine) / spread(ref) - 1):+5.1f} %)  "
                  f"{ref[2]:+.4f} / {gen[2]:+.4f}")
            gaps.append(spread(gen) / spread(ref) - 1.0)
    # icr_spread's absolute model-form term (mjtrack.diagnose.select.MODEL_ABS): 1 sigma = the RMS gap
    print(f"icr_spread gaps {100 * min(gaps):+.2f}..{100 * max(gaps):+.2f} %, RMS {np.sqrt(np.mean(np.square(gaps))):.4f}; "
          f"select.MODEL_ABS: {sel.MODEL_ABS['icr_spread']}")
    print("\nyaw dead time [s], wheeled four-contact body (error against the rollout)")
    settings = (("generator 5 ms, 0.02 m/s", 5e-3, 0.02), ("generator 5 ms, 1e-4 m/s", 5e-3, 1e-4),
                ("generator 5e-5 s, 0.02 m/s", 5e-5, 0.02), ("generator 5e-5 s, 1e-4 m/s", 5e-5, 1e-4))
    for u0, u1 in STEPS:
        ref = rollout_dead_time(u0, u1)
        cells = [f"{label} {d:.4f} ({100 * (d / ref - 1):+.1f} %)"
                 for label, h, eps in settings for d in [generator_dead_time(u0, u1, h=h, eps=eps)]]
        print(f"  {u0} -> {u1}: rollout {ref:.4f}; " + "; ".join(cells))
    return 0


if __name__ == "__main__":
    with printed_result(default_run_result("generator_spread.txt"), command=benchmark_command(__file__)):
        status = main()
    sys.exit(status)
