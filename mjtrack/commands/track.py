"""Slip-compensated trajectory tracking with the MuJoCo tracked robot.

Drives the MuJoCo robot, tracked or wheeled (--robot FILE), along a tracking scenario's reference
(figure_eight: lemniscate of Gerono, A = 1.5 m, 2 laps; circle: radius 1 m, 1.5 turns;
lane_change: 1.5 m straight, a 1 m shift to the left over 3 m with continuous curvature, 1.5 m
straight; all at 0.5 m/s unless --speed) with a controller: tracker (feed-forward + pole-placement
feedback, slip-compensated) or one of the wheeled-robot thesis's five ([Jonszta]), set up to follow the path
(mjtrack.control.path_controllers): feedforward (open loop), pole_placement (the tracker's law,
uncompensated by default), reactive (chasing a goal that runs ahead on the path), posture (the
polar law chasing a goal pose ahead on the path), line_following (two sensors on the path as a
line). Their body commands (v, w) go to the tracks or wheel sides through a compensation: none
(nominal V_L,R = v -+ w T/2: [Jonszta]'s adapter), icr (inverse ICR map of the online estimate for the feed-forward, feedback
on the body point that does not drift sideways) or vir (the same map plus the virtual-robot
heading correction, eq. (2.21) of [Mendaluk]). The estimate is applied with a trust
weight in [0, 1]: 0 while it is
unconverged, physically impossible, or no better than the nominal map at explaining the
measured motion; so compensation fades out where it cannot help. Same controller and gains for
all compensations; only the controllers with a feed-forward from the reference (tracker,
feedforward, pole_placement) can be compensated, and the default is vir for tracker and
feedforward, none for the others. --reference-map coulomb starts the compensation from the Coulomb reference's
steady ICRs of the robot's description at each reference command instead of the nominal map
(large gains where slip is large; worse than none on some paths with the centre of gravity
behind the centre: docs results page "Path controllers"). Writes DIR/tracking.json (rms_cross_track_m, max_cross_track_m,
final_pos_err_m, mean_trust_weight, the settings, the robot, the final ICR estimate) and
DIR/tracking.png (path vs reference, cross-track error over time). The cross-track error is the
distance to the path near where the robot should be: the reference's s(t), or the robot's own
progress for the line follower, which has no clock. --terrain puts the robot on
sloped, stepped, rough or patchy ground (the reference is followed in the horizontal plane;
steps and height fields are simulated at 2.5 ms, so --control-rate must divide into that).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from mjtrack.commands._common import (TERRAIN_HELP, add_output_options, add_robot_options, bounded, check_out_dir,
                                      check_overwrite, command_inputs, robot_config, robot_from_args,
                                      terrain_from_args)

HELP = ("closed-loop path tracking on the MuJoCo robot, tracked or wheeled (the slip-compensated tracker or the "
        "thesis's five controllers, [Jonszta]) -> tracking.json + tracking.png")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from mjtrack.control.compensation import CONTROLLERS, MODES
    from mjtrack.control.runs import TRACK_SCENARIOS
    from mjtrack.control.path_controllers import DESCRIPTIONS

    parser.add_argument("--scenario", choices=list(TRACK_SCENARIOS), default="figure_eight",
                        help="reference path (default figure_eight)")
    parser.add_argument("--compensation", choices=list(MODES), default=None,
                        help="slip compensation: none, icr (inverse ICR map + drift-free control point), vir (inverse ICR map + "
                             "heading correction); default vir for tracker and feedforward, none for the others "
                             "(which, but for pole_placement, have no feed-forward to compensate)")
    parser.add_argument("--reference-map", choices=["nominal", "coulomb"], default="nominal",
                        help="the map the compensation starts from and blends its online estimate against: nominal "
                             "ICRs (default) or the Coulomb reference's steady ICRs of the robot description, flat ground "
                             "only (it helps where the description is right, is worse than none on some paths with the "
                             "centre of mass behind, and much worse with a description whose centre of mass is off: "
                             "calibrate the description first; docs results page \"Path controllers\")")
    parser.add_argument("--controller", choices=list(CONTROLLERS), default="tracker",
                        help="tracker: feed-forward + pole-placement state feedback with the slip compensation (default); "
                             + "; ".join(f"{k}: {v}" for k, v in DESCRIPTIONS.items())
                             + ". [Jonszta]'s controllers were designed for a wheeled robot's model; here they drive the "
                               "MuJoCo robot through the same track-speed (wheel-side speed) interface")
    parser.add_argument("--speed", metavar="M/S", type=bounded("reference_speed"), default=None, help="reference speed [m/s] (default 0.5)")
    parser.add_argument("--laps", metavar="N", type=bounded("laps"), default=None, help="laps / turns of the path")
    parser.add_argument("--control-rate", metavar="HZ", type=bounded("control_rate"), default=25.0,
                        help="controller rate [Hz]; its period must be a multiple of the simulation time step "
                             "(default 25)")
    parser.add_argument("--seed", type=bounded("seed"), default=0, help="seed of the measurement noise (default 0)")
    parser.add_argument("--no-noise", action="store_true", help="exact pose and twist measurements")
    parser.add_argument("--out", metavar="DIR", type=Path, required=True, help="output folder")
    parser.add_argument("--terrain", metavar="SPEC", default=None,
                        help=TERRAIN_HELP + " (default flat); the reference path lies in the horizontal plane")
    add_robot_options(parser)
    add_output_options(parser)


def write_figure(result, path: Path) -> None:
    """Path vs reference and the cross-track error over time, as a PNG (atomic write)."""
    import io

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from mjtrack.control.runs import cross_track_errors
    from mjtrack.io.atomic import atomic_write_bytes

    ref = result.reference
    pts = ref.path.point(ref.path.u_at(np.linspace(0, ref.path.length, 2000)))
    p = result.loop.poses
    ct = cross_track_errors(ref, p, t=result.loop.t)
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(11, 4.5), gridspec_kw={"width_ratios": [1.3, 1]})
    ax.plot(pts[:, 0], pts[:, 1], "k--", lw=1, label="reference")
    ax.plot(p[:, 0], p[:, 1], "C0", lw=1.5, label="robot centre")
    ax.plot(p[0, 0], p[0, 1], "go", ms=5, label="start")
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    s = result.settings
    ax.set_title(f"{s['scenario']}, {s['controller']}, compensation {s['compensation']}")
    ax.legend(fontsize=8)
    bx.plot(result.loop.t, 100 * ct, "C3")
    bx.set_xlabel("t [s]")
    bx.set_ylabel("cross-track error [cm]")
    m = result.metrics
    bx.set_title(f"RMS {100 * m['rms_cross_track_m']:.1f} cm, max {100 * m['max_cross_track_m']:.1f} cm")
    bx.grid(alpha=0.3)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    plt.close(fig)
    atomic_write_bytes(path, buf.getvalue())


def run(args: argparse.Namespace) -> int:
    from mjtrack.control.runs import run_tracking
    from mjtrack.io.atomic import atomic_write_text

    robot = robot_from_args(args)  # an error in the robot file before a clash of output names
    terrain = terrain_from_args(args)
    out = check_out_dir(args.out)
    check_overwrite([out / "tracking.json", out / "tracking.png"], args.force, command_inputs(args))
    compensation = args.compensation or ("vir" if args.controller in ("tracker", "feedforward") else "none")
    noise = {} if not args.no_noise else {"pose_noise": (0.0, 0.0, 0.0), "twist_noise": (0.0, 0.0, 0.0)}
    result = run_tracking(robot, scenario=args.scenario, compensation=compensation, controller=args.controller,
                          control_dt=1.0 / args.control_rate, speed=args.speed, laps=args.laps, seed=args.seed,
                          terrain=terrain, reference_map=args.reference_map, config=robot_config(robot), **noise)
    hist = result.icr_history
    doc = dict(result.metrics)
    doc["settings"] = result.settings
    doc["robot"] = robot.to_dict()
    doc["final_icr_estimate"] = None if not len(hist) else dict(zip(("y_l", "y_r", "x_c"), map(float, hist[-1, 1:])))
    atomic_write_text(out / "tracking.json", json.dumps(doc, indent=2) + "\n")
    write_figure(result, out / "tracking.png")
    if not args.quiet:
        m = result.metrics
        print(f"{args.scenario} ({args.controller}, compensation {compensation}): RMS cross-track "
              f"{m['rms_cross_track_m']:.4f} m, max {m['max_cross_track_m']:.4f} m, final {m['final_pos_err_m']:.4f} m; "
              f"wrote {out / 'tracking.json'} and {out / 'tracking.png'}")
    return 0
