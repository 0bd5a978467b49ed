"""Yaw step responses of the diagnosis surrogate's reduced transient against rigid bodies.

Why the wheeled continuous logs of experiments/diagnose_benchmark.py got an extra
``friction_scale`` ~ 1.2 beside the right effect (issue 12): the reduced transient
(mjtrack/diagnose/surrogate.py, items 4-5) applied the steady turning resistance from the first
instant of a turn, so every turn entry came out too slow, most on the long-contact description
the wheeled robot is given (its steady resistance ratio is the largest); friction_scale, which
shortens every transient, made up for it. For each geometry of tests/diagnose_physics.py this
prints the equivalent yaw dead time int (w_end - w)/(w_end - w_0) dt after each step of
``surrogate._STEPS`` (x 0.5 m/s), from three bodies and two versions of the reduced model:

- generator: the benchmark's independent physics (tests/diagnose_physics.py; the wheeled robot
  on its four wheel contacts, the others on Gauss-Legendre track grids);
- coulomb: the library's time-domain Coulomb rollout of the robot description
  (``mjtrack.models.coulomb.rollout``; for the wheeled robot its equivalent 0.97 m track);
- steady: the reduced transient with the steady resistance ratio (before);
- matched: with the resistance ratio matched to the Coulomb rollout (now).

    python experiments/diagnose_transient_steps.py [--json OUT]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
import diagnose_physics as phys  # noqa: E402

from mjtrack.diagnose import surrogate as sg  # noqa: E402


def generator_dead_times(geometry: str, v: float = sg._STEP_V) -> np.ndarray:
    robot, kind = phys.GEOMETRIES[geometry]
    out = []
    for u0, u1 in sg._STEPS:
        pre, n = int(round(2.0 / phys.H)), int(round(0.6 / phys.H))
        u = v * np.r_[np.tile(u0, (pre, 1)), np.tile(u1, (n, 1))]
        _, tw = phys.simulate(robot, kind, np.arange(u.shape[0]) * phys.H, u, mu=(robot.mu, robot.mu))
        out.append(sg.yaw_dead_time(tw[pre:, 2], tw[pre - 1, 2], phys.H))
    return np.array(out)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--json", type=Path, default=None)
    args = ap.parse_args()
    rows = []
    for geo in ("small", "large", "wheeled"):
        robot, _ = phys.GEOMETRIES[geo]
        resp = sg.ground_response(robot)
        gen = generator_dead_times(geo)
        ref = sg.rollout_dead_times(robot)
        steady = sg.reduced_dead_times(robot, resp.q0, resp.resist_ratio)
        matched = sg.reduced_dead_times(robot, resp.q0, resp.transient_resist_ratio)
        print(f"{geo}: resistance ratio steady {resp.resist_ratio:.3f}, matched {resp.transient_resist_ratio:.3f}")
        for k, (u0, u1) in enumerate(sg._STEPS):
            print(f"  {str(u0):12s} -> {str(u1):12s} generator {gen[k]:.4f}  coulomb {ref[k]:.4f}  "
                  f"steady {steady[k]:.4f} ({100 * (steady[k] / ref[k] - 1):+.0f} %)  "
                  f"matched {matched[k]:.4f} ({100 * (matched[k] / ref[k] - 1):+.0f} %)")
            rows.append({"geometry": geo, "u0": u0, "u1": u1, "generator": gen[k], "coulomb": ref[k],
                         "steady": steady[k], "matched": matched[k], "rho_steady": resp.resist_ratio,
                         "rho_matched": resp.transient_resist_ratio})
        for name, x in (("steady", steady), ("matched", matched)):
            print(f"  RMS log error vs coulomb: {name} {np.sqrt(np.mean(np.log(x / ref) ** 2)):.3f}, "
                  f"vs generator {np.sqrt(np.mean(np.log(x / gen) ** 2)):.3f}")
    if args.json:
        args.json.write_text(json.dumps({"rows": rows}, indent=1, default=float) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
