"""Why wheeled continuous logs get an extra friction_scale: the surrogate's transient vs rigid bodies.

On fresh logs (``benchmarks/diagnose_benchmark.py --seed 1000``) two continuous wheeled
logs with track speeds got ``friction_scale`` ~ 1.2 beside the right effect. Two measurements:

1. Yaw step responses. For each geometry of mjtrack/testing/diagnose_physics.py, the equivalent yaw dead
   time int (w_end - w)/(w_end - w_0) dt after each step of :data:`STEPS` (x 0.5 m/s) of
   - generator: the benchmark's independent physics (the wheeled robot on its four wheel
     contacts, the tracked ones on Gauss-Legendre grids);
   - coulomb: the library's time-domain Coulomb rollout of the robot *description*
     (``mjtrack.models.coulomb.rollout``; for the wheeled robot its equivalent 0.97 m track);
   - steady: the surrogate's reduced transient (mjtrack/diagnose/surrogate.py, item 4) as it is,
     with the steady turning resistance ratio from the first instant of a turn;
   - matched: the same with the one constant ratio that fits the Coulomb rollout best (least
     squares in the log of the dead times over the steps; commit 5da6223 put it in the surrogate,
     the next commit took it out, see 2).
   The steady resistance makes every turn entry and spin start too slow, most on the wheeled
   description (its steady ratio is the largest): friction_scale, which shortens every transient,
   makes up for it.
2. friction_scale on clean wheeled continuous logs (seeds 5000-5003, outside the benchmark's), with
   the steady and the matched resistance: the fitted scale, its held-out gain and its bound, and
   whether it was named (a false positive). With the transient matched, the scale falls below 1:
   the four-wheel body's steady inertial response (lateral slip in fast turns) is stronger than
   that of the track equivalent, and the transient error had been hiding it.

    python benchmarks/diagnose_transient_steps.py [--skip-logs] [--json OUT]
    python benchmarks/diagnose_transient_steps.py --icr-spread

**The steady ICR spread** (``--icr-spread``; printed and kept in ``generator_spread.txt``).
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

import argparse
import dataclasses
import json
import sys
from pathlib import Path

import numpy as np
from scipy import optimize

from mjtrack.diagnose import diagnose
from mjtrack.diagnose import select as sel
from mjtrack.diagnose import surrogate as sg
from mjtrack.io.robot import G
from mjtrack.models import coulomb
from mjtrack.testing import diagnose_physics as phys
from _results import RESULTS, benchmark_command, printed_result

# turn entries from straight, spins from rest, turn and spin reversals, both turn directions (x V)
STEPS = (((1.0, 1.0), (1.0, 0.0)), ((1.0, 1.0), (0.0, 1.0)), ((0.0, 0.0), (-1.0, 1.0)), ((0.0, 0.0), (1.0, -1.0)),
         ((1.0, 0.0), (0.0, 1.0)), ((1.0, -1.0), (-1.0, 1.0)))
V, H = 0.5, 1e-3
DISTINCT = (0, 2, 4, 5)  # STEPS without the mirror images (turn entry right, spin start the other way)


def dead_time(x: np.ndarray, x0: float, h: float) -> float:
    return float(np.sum(x[-1] - x) * h / (x[-1] - x0))


def _duration(robot) -> float:
    return max(0.4, 12.0 * V / (min(robot.friction_left, robot.friction_right) * G))


def generator_dead_times(geometry: str) -> np.ndarray:
    robot, kind = phys.GEOMETRIES[geometry]
    out = []
    for u0, u1 in STEPS:
        pre, n = int(round(2.0 / phys.H)), int(round(0.6 / phys.H))
        u = V * np.r_[np.tile(u0, (pre, 1)), np.tile(u1, (n, 1))]
        _, tw = phys.simulate(robot, kind, np.arange(u.shape[0]) * phys.H, u, mu=(robot.mu, robot.mu))
        out.append(dead_time(tw[pre:, 2], tw[pre - 1, 2], phys.H))
    return np.array(out)


def rollout_dead_times(robot) -> np.ndarray:
    out = []
    for u0, u1 in STEPS:
        u0, u1 = (V * u0[0], V * u0[1]), (V * u1[0], V * u1[1])
        tw0 = (u0[0], 0.0, 0.0) if u0[0] == u0[1] else tuple(coulomb.steady_state(robot, *u0).twist)
        wz = coulomb.rollout(robot, np.arange(0.0, _duration(robot), H), u1[0], u1[1], twist0=tw0,
                             n_points=20).twist[:, 2]
        out.append(dead_time(wz, wz[0], H))
    return np.array(out)


def reduced_dead_times(robot, ratio: float) -> np.ndarray:
    """The surrogate's reduced transient (as Surrogate.effective_speeds sets it up) with the
    turning resistance ratio x (b_L + b_R)."""
    q0 = sg.ground_response(robot).q0
    T, L = robot.track_gauge, robot.track_length
    share = float(np.clip(0.5 + robot.cg_y / T, 0.05, 0.95))
    b_l, b_r = robot.friction_left * G * share, robot.friction_right * G * (1.0 - share)
    kappa = 3.0 * T * float(q0[0] - q0[1]) / (L * L + T * T)
    n = int(round(_duration(robot) / H))
    out = []
    for u0, u1 in STEPS:
        u = V * np.array([u0] * 10 + [u1] * n, float)
        starts = np.zeros(u.shape[0], bool)
        starts[0] = True
        e = sg.friction_limited(u, np.full(u.shape[0], H), starts, b_left=b_l, b_right=b_r, kappa=kappa,
                                resist=ratio * (b_l + b_r))[10:]
        out.append(dead_time(0.5 * (e[:, 1] - e[:, 0]), 0.5 * V * (u0[1] - u0[0]), H))
    return np.array(out)


def matched_ratio(robot, ref: np.ndarray) -> float:
    rho = sg.ground_response(robot).resist_ratio
    sol = optimize.minimize_scalar(lambda k: float(np.sum(np.log(reduced_dead_times(robot, k * rho) / ref) ** 2)),
                                   bounds=(0.2, 1.5), method="bounded", options={"xatol": 1e-3})
    return float(sol.x) * rho


def clean_wheeled_logs(matched: float | None) -> list[dict]:
    """friction_scale on clean wheeled continuous logs, the surrogate's resistance ratio replaced
    by ``matched`` when given."""
    orig = sg.ground_response
    if matched is not None:
        sg.ground_response = lambda robot: dataclasses.replace(orig(robot), resist_ratio=matched)
    rows = []
    try:
        for rate, dur, speeds in ((20, 180, True), (10, 120, False)):
            for seed in (5000, 5001, 5002, 5003):
                log, robot = phys.make_log({}, geometry="wheeled", seed=seed, duration=dur, rate=rate, speeds=speeds)
                d = diagnose(log, robot, baseline="surrogate")
                r = next(r for r in d.steps[0].results if r.effect.name == "friction_scale")
                rows.append({"rate": rate, "duration": dur, "speeds": speeds, "seed": seed, "cause": d.cause,
                             "friction_scale": float(r.estimate[0]), "gain": r.gain.relative, "lower": r.gain.lower})
                print(f"  {rate} Hz {dur} s speeds={int(speeds)} seed {seed}: friction_scale {r.estimate[0]:.3f}, gain "
                      f"{100 * r.gain.relative:.1f} % (bound {100 * r.gain.lower:.1f} %) -> cause {d.cause}", flush=True)
    finally:
        sg.ground_response = orig
    return rows


# ----------------------------------------------------------------- the steady ICR spread

SPREAD_COMMANDS = ((0.3, 0.5), (0.1, 0.3), (-0.3, 0.3))
SPREAD_STEPS = (((0.5, 0.5), (0.5, 0.0)), ((0.0, 0.0), (-0.5, 0.5)))


def spread(q) -> float:
    """y_l - y_r [m]."""
    return float(q[0] - q[1])


def _spread_dead(t, w) -> float:
    d = (w[-1] - w) / (w[-1] - w[0])
    return float(np.sum(0.5 * (d[1:] + d[:-1]) * np.diff(t)))


def wheeled_generator_dead_time(u0, u1, *, h, eps, duration=1.0) -> float:
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
    return _spread_dead(np.arange(w.size) * h, w)


def wheeled_rollout_dead_time(u0, u1, duration=1.0) -> float:
    """The same for the converged Coulomb rollout of the same four-contact body."""
    robot, _ = phys.GEOMETRIES["wheeled"]
    body = robot.replace(track_length=2 * phys.WHEELBASE)
    inertia = robot.mass * (robot.track_length**2 + robot.track_gauge**2) / 12
    tw0 = (u0[0], 0.0, 0.0) if u0[0] == u0[1] else tuple(coulomb.steady_state(body, *u0, n_points=2).twist)
    t = np.arange(0.0, duration + 5e-4, 1e-3)
    w = coulomb.rollout(body, t, u1[0], u1[1], twist0=tw0, n_points=2, inertia=inertia).twist[:, 2]
    return _spread_dead(t, w)


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


def icr_spread_report() -> int:
    """``--icr-spread``: the two tables of the module docstring's last section, printed."""
    print(f"{'geometry':8s} {'command':>13s}  {'q0':>7s} {'coulomb':>8s} {'width':>7s} {'generator':>18s} "
          f"{'gen 1 ms, 0.001':>18s}  x_c coulomb / generator [m]")
    gaps = []  # generator spread / reference spread - 1, at the generator's settings
    for name, (robot, kind) in phys.GEOMETRIES.items():
        q0 = sg.ground_response(robot).q0
        for vl, vr in SPREAD_COMMANDS:
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
    for u0, u1 in SPREAD_STEPS:
        ref = wheeled_rollout_dead_time(u0, u1)
        cells = [f"{label} {d:.4f} ({100 * (d / ref - 1):+.1f} %)"
                 for label, h, eps in settings for d in [wheeled_generator_dead_time(u0, u1, h=h, eps=eps)]]
        print(f"  {u0} -> {u1}: rollout {ref:.4f}; " + "; ".join(cells))
    return 0



def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--skip-logs", action="store_true", help="step responses only")
    ap.add_argument("--icr-spread", action="store_true",
                    help="the steady ICR spread instead (printed; alone, also written to generator_spread.txt)")
    ap.add_argument("--json", type=Path, default=None,
                    help="result file (default benchmarks/results/diagnose_transient_steps.json; with --skip-logs none)")
    args = ap.parse_args()
    if args.icr_spread:
        stable = RESULTS / "generator_spread.txt" if sys.argv[1:] == ["--icr-spread"] else None
        with printed_result(stable, command=benchmark_command(__file__)):
            return icr_spread_report()
    out: dict = {"steps": [], "clean_wheeled": {}}
    ratios = {}
    gaps = {}  # geometry -> 1/r - 1 over the distinct steps, r = generator / coulomb dead time
    for geo in ("small", "large", "wheeled"):
        robot, _ = phys.GEOMETRIES[geo]
        rho = sg.ground_response(robot).resist_ratio
        gen, ref = generator_dead_times(geo), rollout_dead_times(robot)
        ratios[geo] = matched_ratio(robot, ref)
        steady, matched = reduced_dead_times(robot, rho), reduced_dead_times(robot, ratios[geo])
        print(f"{geo}: turning resistance ratio steady {rho:.3f}, matched to the Coulomb rollout {ratios[geo]:.3f}")
        for k, (u0, u1) in enumerate(STEPS):
            print(f"  {str(u0):12s} -> {str(u1):12s} generator {gen[k]:.4f}  coulomb {ref[k]:.4f}  "
                  f"steady {steady[k]:.4f} ({100 * (steady[k] / ref[k] - 1):+.0f} %)  "
                  f"matched {matched[k]:.4f} ({100 * (matched[k] / ref[k] - 1):+.0f} %)")
            out["steps"].append({"geometry": geo, "u0": u0, "u1": u1, "generator": gen[k], "coulomb": ref[k],
                                 "steady": steady[k], "matched": matched[k], "rho_steady": rho,
                                 "rho_matched": ratios[geo]})
        for name, x in (("steady", steady), ("matched", matched)):
            print(f"  {name}: RMS log error {np.sqrt(np.mean(np.log(x / ref) ** 2)):.3f} vs coulomb, "
                  f"{np.sqrt(np.mean(np.log(x / gen) ** 2)):.3f} vs generator")
        gaps[geo] = ref[list(DISTINCT)] / gen[list(DISTINCT)] - 1.0
    # friction_scale's absolute model-form term (mjtrack.diagnose.select.MODEL_ABS): every transient's
    # time goes as 1/fs, so the generator's dead-time ratio r reads as fs = 1/r; 1 sigma = the RMS gap
    rms = {k: float(np.sqrt(np.mean(np.concatenate(v) ** 2))) for k, v in
           (("all", list(gaps.values())), ("tracked", [gaps["small"], gaps["large"]]), ("wheeled", [gaps["wheeled"]]))}
    print(f"friction_scale read off the generator's faster transients, 1/r - 1: "
          f"{np.min(np.concatenate(list(gaps.values()))):.3f}-{np.max(np.concatenate(list(gaps.values()))):.3f}, RMS "
          f"{rms['all']:.3f} (tracked {rms['tracked']:.3f}, wheeled {rms['wheeled']:.3f}); "
          f"select.MODEL_ABS: {sel.MODEL_ABS['friction_scale']}")
    out["model_abs_friction_scale"] = rms
    if not args.skip_logs:
        for name, ratio in (("steady", None), ("matched", ratios["wheeled"])):
            print(f"clean wheeled continuous logs, {name} resistance:", flush=True)
            rows = clean_wheeled_logs(ratio)
            out["clean_wheeled"][name] = rows
            print(f"  named a cause on {sum(r['cause'] != 'none' for r in rows)} of {len(rows)}")
    json_out = args.json or (None if args.skip_logs else RESULTS / "diagnose_transient_steps.json")
    if json_out:
        json_out.write_text(json.dumps(out, indent=1, default=float) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
