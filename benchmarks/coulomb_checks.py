"""Numbers of the rigid-track Coulomb reference quoted in the report (default Robot()).

Run: python benchmarks/coulomb_checks.py
Prints the pivot-turn ratio (closed form and discrete), the ICR shift for cg_x = +0.05 m,
a table of commanded turning radii with inertia on/off, and the comparison of the
simplified dynamics (2.4-2.6) with the Coulomb reference in a pivot turn.
"""

from __future__ import annotations

import sys

import numpy as np
from scipy import optimize

from mjtrack.io.robot import Robot
from mjtrack.models.coulomb import pivot_turn_closed_form, steady_state
from mjtrack.models.dynamics import TrackedDynamics, simulate
from mjtrack.testing.repo import benchmark_command, default_run_result, printed_result


def main() -> None:
    robot = Robot()
    T, v = robot.track_gauge, 0.5
    p = pivot_turn_closed_form(robot, v)
    print(f"pivot closed form (L={robot.track_length}, T={T}): wz/ideal = {p.wz * T / (2 * v):.6f}, "
          f"y_l = {p.y_l:.6f}, y_r = {p.y_r:.6f}")
    for n in (200, 2000):
        s = steady_state(robot, -v, v, inertial=False, n_points=n)
        print(f"  discrete n_points={n}: wz/ideal = {s.wz * T / (2 * v):.6f}, y_l = {s.y_l:.6f}")
    for k in (2, 8):
        s = steady_state(robot, -v, v, inertial=False, n_across=k)
        print(f"  n_across={k} (width {robot.track_width}): wz/ideal = {s.wz * T / (2 * v):.6f}, y_l = {s.y_l:.6f}")
    L70 = optimize.brentq(
        lambda L: pivot_turn_closed_form(robot.replace(track_length=L), v).wz * T / (2 * v) - 0.70, 0.3, 1.0)
    print(f"  ratio 0.70 needs L/T = {L70 / T:.4f} (L = {L70:.4f} m at T = {T}); "
          f"then y_l = {pivot_turn_closed_form(robot.replace(track_length=L70), v).y_l:.4f}")

    for w in (0.08, 0.15, 0.16):
        wide = robot.replace(track_width=w)
        s = steady_state(wide, -v, v, inertial=False, n_across=16)
        f = steady_state(wide.replace(cg_x=0.05), -v, v, inertial=False, n_across=16)
        print(f"  width {w} (16 across): wz/ideal = {s.wz * T / (2 * v):.4f}, y_l = {s.y_l:.4f}; "
              f"cg_x=+0.05: x_c = {f.x_c:.4f}, y_l = {f.y_l:.4f}")

    fwd = robot.replace(cg_x=0.05)
    for inertial in (False, True):
        for vv in (0.3, 0.8):
            s = steady_state(fwd, -vv, vv, inertial=inertial)
            print(f"pivot cg_x=+0.05, v={vv}, inertial={inertial}: x_c = {s.x_c:.4f}, y_l = {s.y_l:.4f}, "
                  f"y_r = {s.y_r:.4f}, wz/ideal = {s.wz * T / (2 * vv):.4f}")

    print("commanded radius R, speed v -> actual radius vx/wz, wz/nominal, y_l, y_r, x_c (cg at centre)")
    for vv in (0.3, 0.8):
        for R in (0.25, 0.5, 1.0, 2.0):
            vl, vr = vv * (1 - T / (2 * R)), vv * (1 + T / (2 * R))
            row = []
            for inertial in (False, True):
                s = steady_state(robot, vl, vr, inertial=inertial)
                row.append(f"{'inert' if inertial else 'quasi'}: R={s.vx / s.wz:.4f} wz/nom={s.wz / (vv / R):.4f} "
                           f"y_l={s.y_l:.4f} y_r={s.y_r:.4f} x_c={s.x_c:+.4f}")
            print(f"  R={R} v={vv}: " + " | ".join(row))

    dyn = TrackedDynamics(robot)
    t = np.linspace(0.0, 3.0, 31)
    out = simulate(dyn, t, v_left=-v, v_right=v)
    print(f"simplified dynamics pivot (traction eps={dyn.traction_eps}): wz/ideal = "
          f"{out.twist[-1, 2] * T / (2 * v):.4f} vs Coulomb {p.wz * T / (2 * v):.4f}")


if __name__ == "__main__":
    with printed_result(default_run_result("coulomb_checks.txt"), command=benchmark_command(__file__)):
        status = main()
    sys.exit(status)
