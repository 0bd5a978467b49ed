"""report.html of a calibration: from the uncalibrated simulation's errors to the held-out gain.

Offline (figures embedded as PNG by :mod:`mjtrack.report.html`); ``mujoco.sysid``'s own report is
not used (it loads plotly from a CDN, and its signal plots fail on multi-dimensional sensors).
"""

from __future__ import annotations

import numpy as np

from mjtrack.calibrate.params import specs_for
from mjtrack.report.html import Report
from mjtrack.windows import bins
from mjtrack.windows.screen import AGAINST_WHY, STUCK_WHY

TURN_EDGES = (-1.0, -0.6, -0.2, 0.2, 0.6, 1.0)


def _window_inputs(lg, ws):
    cmd = np.stack([lg.v_left_cmd, lg.v_right_cmd], -1).astype(float)
    mean = bins.window_means(cmd, ws.starts, ws.ends + 1)
    turn = bins.turn_ratio(mean)
    speed = 0.5 * np.abs(mean).sum(axis=1)
    direction = np.sign(np.array([lg.yaw[e] - lg.yaw[s] for s, e in zip(ws.starts, ws.ends)]))
    return turn, speed, direction, lg.t[ws.starts] - lg.t[0]


def _bins(lg, ws, before, after):
    turn, speed, direction, t = _window_inputs(lg, ws)
    vmax = max(float(speed.max()), 1e-3)
    tmax = max(float(t.max()), 1e-3)
    groups = [("commanded turn ratio (curvature)", turn, TURN_EDGES, ""),
              ("commanded speed", speed, np.linspace(0, vmax * 1.0001, 5), " m/s"),
              ("turn direction (−1 right, +1 left)", direction, (-1.5, -0.5, 0.5, 1.5), ""),
              ("time in the log", t, np.linspace(0, tmax * 1.0001, 5), " s")]
    out = []
    for label, x, edges, unit in groups:
        b = bins.bin_errors(label, x, before, edges)
        a = bins.bin_errors(label, x, after, edges)
        rows = []
        for i in range(b.count.size):
            if b.count[i]:
                rows.append([f"{b.edges[i]:.3g} … {b.edges[i + 1]:.3g}{unit}", int(b.count[i]), float(b.pos_rms[i]),
                             float(a.pos_rms[i]), float(b.along[i]), float(b.across[i]), float(np.degrees(b.yaw[i])),
                             float(np.degrees(a.yaw[i]))])
        out.append((label, rows, x, edges))
    return out


def _figure_bins(lg, ws, before, after):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    turn, speed, _, _ = _window_inputs(lg, ws)
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.6))
    for ax, x, label in ((axes[0], turn, "commanded turn ratio (V_R − V_L)/(|V_L| + |V_R|)"),
                         (axes[1], speed, "commanded speed [m/s]")):
        ax.scatter(x, np.hypot(before[:, 0], before[:, 1]), s=8, alpha=0.6, label="uncalibrated")
        ax.scatter(x, np.hypot(after[:, 0], after[:, 1]), s=8, alpha=0.6, label="calibrated")
        ax.set_xlabel(label)
        ax.set_ylabel("position error at the horizon [m]")
        ax.grid(alpha=0.3)
    axes[0].legend()
    fig.tight_layout()
    return fig


def _figure_paths(cal, k: int = 6):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from mjtrack.windows.define import measured_window_poses

    lg, ws = (cal.test_log, cal.test_windows) if cal.test_log is not None else (cal.train_log, cal.train_windows)
    b, a = (cal.test_before, cal.test_after) if cal.test_log is not None else (cal.before, cal.after)
    meas = measured_window_poses(lg, ws)
    err = np.hypot(b.errors[:, 0], b.errors[:, 1])
    pick = np.argsort(err)[::-1][:k]
    fig, axes = plt.subplots(1, len(pick), figsize=(2.6 * len(pick), 2.8))
    for ax, j in zip(np.atleast_1d(axes), pick):
        for poses, style, label in ((meas[j], "k-", "measured"), (b.poses[j], "C0--", "uncalibrated"),
                                    (a.poses[j], "C1-", "calibrated")):
            ax.plot(poses[:, 0], poses[:, 1], style, label=label)
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_title(f"window {j}", fontsize=9)
        ax.tick_params(labelsize=7)
    np.atleast_1d(axes)[0].legend(fontsize=7)
    fig.tight_layout()
    return fig


def build_report(cal) -> Report:
    specs = specs_for(cal.robot)
    rep = Report(
        title="Calibration of the MuJoCo robot",
        intro=("The MuJoCo tracked robot simulated over windows of a measured log, each started from the measured "
               f"state at its start (pose, body twist, track speeds) and driven by the logged commands for "
               f"{cal.horizon_s:g} s; first as described, then with parameters fitted on the training log; the "
               "gain is measured on a test log the fit never saw." if cal.test_log is not None else
               "The MuJoCo tracked robot simulated over windows of a measured log, each started from the measured "
               f"state at its start and driven by the logged commands for {cal.horizon_s:g} s; first as described, "
               "then with parameters fitted on the same log (no test log was given: no held-out gain)."))
    s = rep.section("What the uncalibrated simulation got wrong")
    s.verdict(cal.sentence)
    rows = [["training windows", len(cal.train_windows), cal.before.rms, cal.after.rms,
             1 - cal.after.rms / cal.before.rms if cal.before.rms > 0 else 0.0]]
    if cal.test_before is not None:
        rows.append(["test windows (held out)", len(cal.test_windows), cal.test_before.rms, cal.test_after.rms,
                     1 - cal.test_after.rms / cal.test_before.rms if cal.test_before.rms > 0 else 0.0])
    s.table(["data", "windows", f"{cal.horizon_s:g} s position RMSE before [m]", "after [m]", "relative gain"], rows)
    s.paragraph(f"Drive input: {cal.drive_input_mode} ({cal.drive_input_why}).")
    _speed_sections(rep, cal)

    s = rep.section("Errors of the uncalibrated simulation (training log)")
    s.paragraph("Error at the window's end in the frame of its measured start pose: along (+ = the simulation went "
                "too far), across (+ = it ended left of the measurement), yaw (simulated − measured). Windows "
                "grouped by what was commanded, by turn direction and by time.")
    for label, rows_, _, _ in _bins(cal.train_log, cal.train_windows, cal.before.errors, cal.after.errors):
        s.table([label, "windows", "pos RMSE before [m]", "after [m]", "mean along before [m]",
                 "mean across before [m]", "mean yaw before [°]", "mean yaw after [°]"], rows_)
    s.figure(_figure_bins(cal.train_log, cal.train_windows, cal.before.errors, cal.after.errors),
             "Position error at the horizon of every training window against the commanded turn ratio and speed.")
    s.figure(_figure_paths(cal), "The windows the uncalibrated simulation got most wrong"
             + (" (test log)" if cal.test_log is not None else "") + ": measured, uncalibrated and calibrated paths.")

    sign = {"against": "+.2f", "stuck": ".2f"}
    rows_ = [[part, r["kind"], f"{r['t0']:.2f}", *(format(v, sign[r["kind"]]) for v in r["track_path_m"]),
              *(format(v, sign[r["kind"]]) for v in r["body_path_m"])]
             for part, rows in cal.left_out.items() for r in rows]
    if rows_:
        s = rep.section("Windows left out")
        s.paragraph(f"Not fitted and not scored. Kind against: {AGAINST_WHY}; track path: the mean track speed "
                    "integrated over each half of the window, body path: the measured displacement along the body's "
                    f"heading. Kind stuck: {STUCK_WHY}; track path: the longer of the two tracks' paths in each half, "
                    "body path: the farthest either point under the tracks' centres gets from where it was.")
        s.table(["part", "kind", "window start [s]", "track path, 1st half [m]", "2nd half [m]", "body path, 1st half [m]",
                 "2nd half [m]"], rows_)

    s = rep.section("Steady turns: yaw ratio and ICRs, measured against simulated")
    s.paragraph("Yaw ratio: median over steady windows (commands constant) of the yaw rate over the nominal "
                "(V_R − V_L)/T from the window's mean track speeds (measured for the log, simulated for the "
                "simulation). ICRs (2.13) from each window's mean twist, medians per turn direction.")
    s.table(["quantity", "part", "windows", "measured", "simulated before", "simulated after"],
            [[f["what"], f["part"], f.get("windows", ""), _num(f["measured"]), _num(f["simulated_before"]),
              _num(f["simulated_after"])] for f in cal.findings])

    s = rep.section("Why: the causes of the improvement")
    if cal.causes:
        s.paragraph("Each cause is a changed parameter, or a group the fit cannot move independently. Share: the "
                    "fraction of the training improvement lost when the cause goes back to its described value; "
                    "alone: the relative improvement from the cause's change only.")
        s.table(["cause", "parameters", "share of the improvement", "improvement alone"],
                [[c.sentence, ", ".join(c.parameters), f"{100 * c.share:.0f} %", f"{100 * c.gain_alone:.0f} %"]
                 for c in cal.causes])
    else:
        s.verdict("Nothing needs to change: no parameter differs from its description by more than its interval.")

    s = rep.section("What the log determines")
    fits = [cal.fit] + ([cal.refit] if cal.refit is not None else [])
    s.paragraph(f"Fitted by {cal.fit.method}: first every candidate ({cal.fit.iterations} iterations, cost "
                f"{cal.fit.cost_start:.4g} → {cal.fit.cost_final:.4g})"
                + (f", then the kept ones again ({cal.refit.iterations} iterations, cost {cal.refit.cost_final:.4g})"
                   if cal.refit is not None else "")
                + f"; {sum(f.evaluations for f in fits)} parameter sets × {len(cal.fitted_windows)} fit windows simulated "
                  f"in {sum(f.seconds for f in fits):.1f} s. Intervals: 95 %, a cluster-robust sandwich over clusters "
                  "of consecutive windows plus each parameter's model-form shift (a finer simulator, a longer warm-up "
                  "of the hidden states). A parameter is determined when its half-width is at most its resolution or its distance from the described value; "
                  "one that is not, or whose described value lies in its interval, keeps the described value.")
    rows = []
    for n in cal.names:
        v = cal.verdicts[n]
        iv = "" if v.interval is None else f"[{v.interval[0]:.4g}, {v.interval[1]:.4g}]"
        rows.append([n, cal.described[n], cal.values[n], iv, specs[n].resolution, specs[n].unit,
                     "yes" if v.determined else "no", "changed" if v.changed else "kept", v.reason])
    s.table(["parameter", "described", "calibrated", "95 % interval", "resolution", "unit", "determined", "",
             "why"], rows)
    if cal.fit.starts_tried:
        s.table(["start tried (multi-start)", "cost"],
                [[", ".join(f"{k} {v:.3g}" for k, v in p.items()), c] for p, c in cal.fit.starts_tried])
    s.definitions({"fixed": ", ".join(f"{k} = {v:g}" for k, v in cal.fixed.items()) or "none",
                   **{f"assumed: {k}": v for k, v in cal.assumed.items()}})

    s = rep.section("Held-out gain")
    if cal.test_before is not None:
        s.paragraph(f"On {len(cal.test_windows)} windows of {cal.test_path}, never used in the fit, the "
                    f"{cal.horizon_s:g} s position RMSE goes from {cal.test_before.rms:.4g} m (as described) to "
                    f"{cal.test_after.rms:.4g} m (calibrated): "
                    f"{100 * (1 - cal.test_after.rms / cal.test_before.rms):.0f} % lower.")
    else:
        s.verdict("No test log was given (--test): the gain above is on the training data only.", warn=True)
    return rep


def _speed_sections(rep, cal) -> None:
    """The track speeds, simulated and predicted, against the measured ones; what the log shows
    that no candidate describes."""
    speeds = cal.simulated_wheel_speeds()
    rows = []
    if speeds is not None:
        who = ("MuJoCo robot (before: the described contact through the fitted drivetrain)"
               if cal.drive_input_mode == "fitted" else "MuJoCo robot")
        rows += [[f"{who}, {part}", p["windows"], p["before"]["left"], p["before"]["right"], p["after"]["left"],
                  p["after"]["right"]] for part, p in speeds.items()]
    if cal.drivetrain is not None:
        d = cal.drivetrain
        rows.append(["drivetrain chain alone (commands -> speeds), train", d.windows, d.rms_before[0], d.rms_before[1],
                     d.rms_after[0], d.rms_after[1]])
    if rows:
        s = rep.section("Track speeds: simulated against measured")
        s.paragraph("RMS of the simulated (or predicted) minus the measured track speeds over every row of every window "
                    "after its start, as described and as calibrated. With the drives following measured or fitted "
                    "speeds the simulated speeds are divided by the speed scale (an effective rolling radius). A "
                    "calibrated robot further from the measured speeds than the described one contradicts them.")
        s.table(["robot", "windows", "left before [m/s]", "right before [m/s]", "left after [m/s]",
                 "right after [m/s]"], rows)
    missing = cal.not_explained(speeds)
    if missing:
        s = rep.section("What the log shows that no candidate describes")
        s.table(["what", "acts like", "why its values are not the robot's"],
                [[m["what"], m["acts_like"], "; ".join(m["why"])] for m in missing])


def _num(v):
    return float("nan") if v is None else v
