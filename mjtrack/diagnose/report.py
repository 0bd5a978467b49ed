"""report.html of a diagnosis: verdict, symptom, candidates, cause and gain, what is not identifiable.

Read top to bottom it follows the argument: the verdict; the data and the baseline; where the
baseline's predictions depart from the measurement (tables and figures against turn ratio,
speed, time; measured ICRs); every candidate's held-out score; the finding(s) with the
prediction errors before and after; what could not be tested and why; the next step.
"""

from __future__ import annotations

import math

import numpy as np

from mjtrack.diagnose import residuals as rs
from mjtrack.diagnose.result import Diagnosis, describe, extended_robot, num
from mjtrack.report.html import Report

TURN_EDGES = np.linspace(-1.0, 1.0, 11)


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _window_commands(d: Diagnosis) -> tuple[np.ndarray, np.ndarray]:
    v = rs.window_means(d.data.cmd, d.starts, d.ends)
    return rs.turn_ratio(v), np.mean(np.abs(v), axis=1)


def _direction_rows(d: Diagnosis, err: np.ndarray, turn: np.ndarray) -> list[list]:
    rows = []
    for name, m in (("right turns (turn ratio < -0.05)", turn < -0.05), ("straight (|turn ratio| <= 0.05)", np.abs(turn) <= 0.05),
                    ("left turns (turn ratio > 0.05)", turn > 0.05)):
        if m.any():
            e = err[m]
            rows.append([name, int(m.sum()), float(np.sqrt(np.mean(e[:, 0] ** 2 + e[:, 1] ** 2))), float(e[:, 0].mean()),
                         float(e[:, 1].mean()), float(np.degrees(e[:, 2].mean()))])
    return rows


def _symptom_figure(d: Diagnosis, turn, speed, best):
    plt = _plt()
    fig, ax = plt.subplots(2, 2, figsize=(10, 7))
    series = [(d.baseline_title, d.base_errors, "C3")]
    if best is not None:
        series.append((f"+ {best.effect.name} (held out)", best.held_out_errors, "C2"))
    for label, err, color in series:
        tb = rs.bin_errors("turn", turn, err, TURN_EDGES)
        mid = 0.5 * (tb.edges[1:] + tb.edges[:-1])
        ok = tb.count > 0
        ax[0, 0].plot(mid[ok], tb.along[ok], "o-", color=color, label=f"{label}: along")
        ax[0, 0].plot(mid[ok], tb.across[ok], "s--", color=color, label=f"{label}: across")
        ax[0, 1].plot(mid[ok], np.degrees(tb.yaw[ok]), "o-", color=color, label=label)
        edges = np.linspace(0, max(float(speed.max()), 1e-3) * 1.0001, 9)
        sb = rs.bin_errors("speed", speed, err, edges)
        m2 = 0.5 * (edges[1:] + edges[:-1])
        ok2 = sb.count > 0
        ax[1, 0].plot(m2[ok2], sb.pos_rms[ok2], "o-", color=color, label=label)
        tt = d.data.t[d.starts]
        order = np.argsort(d.starts)
        k = max(1, order.size // 60)
        pe = np.hypot(err[order, 0], err[order, 1])
        n = (pe.size // k) * k
        if n:
            ax[1, 1].plot(tt[order][:n].reshape(-1, k).mean(1), pe[:n].reshape(-1, k).mean(1), ".-", color=color, label=label)
    ax[0, 0].set(xlabel="commanded turn ratio (V_R-V_L)/(|V_L|+|V_R|)", ylabel="mean error in start frame [m]",
                 title="position error vs turn (+along = too far, +across = too far left)")
    ax[0, 1].set(xlabel="commanded turn ratio", ylabel="mean yaw error [deg]", title="yaw error vs turn (+ = turned too far left)")
    ax[1, 0].set(xlabel="mean commanded track speed |V| [m/s]", ylabel="RMS position error [m]", title="error vs speed")
    ax[1, 1].set(xlabel="time [s] (window start)", ylabel="mean position error [m]", title="error along the log")
    for a in ax.ravel():
        a.grid(alpha=0.3)
        a.legend(fontsize=7)
    fig.tight_layout()
    return fig


def _icr_figure(d: Diagnosis, icr: dict):
    plt = _plt()
    fig, ax = plt.subplots(1, 3, figsize=(11, 3.4))
    qn = d.baseline.nominal_icrs()
    for i, name in enumerate(("y_l", "y_r", "x_c")):
        ax[i].plot(icr["turn"], icr[name], ".", ms=3, alpha=0.5, label="measured (windows)")
        lo, hi = np.nanpercentile(icr[name], [2, 98]) if icr[name].size else (0, 1)
        pad = 0.2 * (hi - lo) + 0.02
        if qn is not None:
            ax[i].axhline(qn[i], color="C3", label=d.baseline_title)
            lo, hi = min(lo, qn[i]), max(hi, qn[i])
        ax[i].set(xlabel="turn ratio", ylabel=f"{name} [m]", title=f"{name}")
        ax[i].set_ylim(lo - pad, hi + pad)
        ax[i].grid(alpha=0.3)
    ax[0].legend(fontsize=7)
    fig.tight_layout()
    return fig


def _gain_figure(d: Diagnosis):
    plt = _plt()
    fig, ax = plt.subplots(figsize=(8, 0.35 * len(d.results) + 1.2))
    names = [r.effect.name for r in d.results][::-1]
    rel = [100 * r.relative for r in d.results][::-1]
    fold = [100 * (1 - r.fold_after / r.fold_before) for r in d.results][::-1]
    lower = [100 * r.gain.lower if r.gain is not None else np.nan for r in d.results][::-1]
    colors = ["C2" if r.passed else "0.6" for r in d.results][::-1]
    ax.barh(names, rel, color=colors)
    for i, f in enumerate(fold):
        ax.plot(f, np.full(f.size, i), "k.", ms=4)
        ax.plot([lower[i]], [i], "|", color="C3", ms=10)
    ax.axvline(0, color="k", lw=0.8)
    ax.set(xlabel="held-out reduction of the position RMSE [%] (bars: pooled, dots: per fold, red tick: 95 % lower bound)",
           title=f"candidates (green: beats the baseline, {d.baseline_title}, beyond noise)")
    ax.grid(alpha=0.3, axis="x")
    fig.tight_layout()
    return fig


def _fmt_est(r) -> str:
    return ", ".join(f"{n} = {num(v)}" for n, v in zip(r.effect.params, r.estimate))


def _fmt_int(r) -> str:
    return ", ".join(f"[{num(a)}, {num(b)}]" if math.isfinite(a) and math.isfinite(b) else "–" for a, b in r.interval)


def _lower(r) -> str:
    return f"{100 * r.gain.lower:.1f}" if r.gain is not None else "–"


def _candidate_rows(results) -> list[list]:
    return [[r.effect.name, _fmt_est(r), _fmt_int(r), float(r.before), float(r.after), float(100 * r.relative), _lower(r),
             "yes" if r.passed else "no"] for r in results]


CANDIDATE_HEADER = ["effect", "estimate", "95 % interval", "before [m]", "after [m]", "gain [%]", "95 % lower bound [%]",
                    "finding"]


def build_report(d: Diagnosis) -> Report:
    """The report of a diagnosis (not written)."""
    rep = Report(f"Diagnosis of {d.log_path or 'a drive log'}",
                 intro=f"What the baseline ({d.baseline_title}) gets wrong on this measured log, which effect explains "
                       "it, and how much of the prediction error the extended model removes on data it was not fitted "
                       "to.")
    best = d.findings[0] if d.findings else None
    v = rep.section("Verdict")
    where = "on the test log" if d.test_log else "on held-out data"
    if best is None:
        v.verdict(f"cause: none. No candidate beats the baseline ({d.baseline_title}) beyond noise "
                  f"{where} ({d.horizon_s:g} s position RMSE {d.before:.3g} m).")
    else:
        tied = [r for r in d.findings if r is not best and best.effect.name in r.tied_with]
        head = f"cause: {best.effect.name} ({best.effect.meaning})"
        if tied:
            head += " -- or, indistinguishable on this log, " + " or ".join(r.effect.name for r in tied)
        v.verdict(f"{head}. {d.evidence(best)}")
        for r in d.findings[1:]:
            if r in tied:
                v.paragraph(f"tied with the cause: {r.effect.name}: {d.evidence(r)}")
            else:
                v.verdict(f"also: {r.effect.name} ({r.effect.meaning}). {d.evidence(r)}")
        if len(d.chosen) > 1:
            v.paragraph("estimates of the effects found together are refitted each with the others in the model: "
                        + "; ".join(f"{r.effect.name}: {_fmt_est(r)} {_fmt_int(r)}" for r in d.chosen)
                        + f". Held-out {d.horizon_s:g} s position RMSE with all of them: {d.final_after:.3g} m "
                        f"({d.baseline_title}: {d.before:.3g} m).")
    for w in d.warnings():
        v.verdict(w, warn=True)
    for note in d.notes:
        v.verdict(note, warn=True)

    s = rep.section("Data and baseline")
    s.definitions({
        "log": d.log_path or "(in memory)", "samples": str(d.samples), "duration": f"{d.duration_s:.1f} s",
        "segments": str(int(d.data.seg[-1]) + 1),
        "measured track speeds": "yes" if d.data.meas is not None else "no",
        "robot keys given": ", ".join(sorted(d.robot.provided)) if d.robot.provided is not None else "all (built in code)",
        "baseline": d.baseline.describe() + (f" (chosen: {d.choice['why']})" if d.choice.get("why") else ""),
        "test log": d.test_log or "none (held-out cross-validation on the log itself)",
        "metric": f"RMS position error after {d.horizon_s:g} s of open-loop prediction from every measured pose",
        "windows": f"{d.starts.size} (cross-validation: {d.n_folds} contiguous folds)"
                   + (f"; {d.diverged} more whose baseline simulation diverged (not scored)" if d.diverged else ""),
    })

    turn, speed = _window_commands(d)
    sy = rep.section(f"Symptom: where the baseline's prediction departs ({d.baseline_title})")
    sy.paragraph("Each window starts the model at a measured pose and drives it with the logged commands for the "
                 "horizon; its error is given in the frame of the start pose (along: + the model went too far; across: "
                 "+ it ended too far left; yaw: + it turned too far left).")
    header = ["windows", "count", "RMS pos err [m]", "mean along [m]", "mean across [m]", "mean yaw err [deg]"]
    sy.table(header, _direction_rows(d, d.base_errors, turn), caption=f"{d.baseline_title}, by turn direction")
    tb = rs.bin_errors("turn ratio", turn, d.base_errors, TURN_EDGES)
    sy.table(["turn ratio"] + header[1:], tb.rows(), caption=f"{d.baseline_title}, by commanded turn ratio")
    sy.figure(_symptom_figure(d, turn, speed, best), f"window errors of the baseline, {d.baseline_title} (red), and, when there is a "
              "finding, of the extended model on held-out folds (green)")
    speeds = d.data.meas if d.data.meas is not None else d.data.cmd
    h_icr = min(d.horizon_s, 1.0)  # shorter windows: more of them hold one command
    ws, we = rs.windows(d.data.t, d.data.seg, h_icr)
    icr = rs.measured_icr(d.data, ws, we, np.where(np.isfinite(speeds), speeds, d.data.cmd))
    if icr["turn"].size >= 5:
        rows = []
        for name, m in (("left turns", icr["wz"] > 0), ("right turns", icr["wz"] < 0)):
            if m.sum() >= 3:
                rows.append([name, int(m.sum())] + [float(np.median(icr[k][m])) for k in ("y_l", "y_r", "x_c")])
        qn = d.baseline.nominal_icrs()
        if qn is not None:
            rows.append([d.baseline_title, "–", float(qn[0]), float(qn[1]), float(qn[2])])
        sy.table(["ICRs (2.13), median", "windows", "y_l [m]", "y_r [m]", "x_c [m]"], rows,
                 caption=f"measured ICRs from {h_icr:g} s windows holding one command, |turn ratio| >= 0.3 "
                         f"({'measured' if d.data.meas is not None else 'commanded'} track speeds)")
        sy.figure(_icr_figure(d, icr), "measured ICRs of the turning windows"
                  + (f" against those of the baseline, {d.baseline_title}" if qn is not None else ""))

    c = rep.section("Candidates" + (" (fitted on the log, scored on the test log)" if d.test_log else
                                      " (held-out cross-validation)"))
    c.paragraph("Each effect of the vocabulary extends the model; its parameters are fitted on all folds but one and "
                "scored on the fold left out, for every fold (with a test log: fitted on the log, scored on the test "
                "log). A finding must remove at least the gain floor, and the one-sided 95 % lower bound of its gain "
                "(blocked bootstrap over blocks of windows) must be above zero. Intervals: 95 %, the larger of "
                f"{d.baseline.interval_method()} and the delete-one-fold jackknife, with the {d.baseline.noun}'s own "
                f"model-form error ({100 * d.baseline.model_form.rel:.1f} % of the effect's size) in quadrature. "
                f"Every number is simulated by the {d.baseline.noun}.")
    c.table(CANDIDATE_HEADER, _candidate_rows(d.results))
    c.figure(_gain_figure(d), "held-out gain of every candidate")
    c.table(["effect", "decision"], [[r.effect.name, r.why] for r in d.results])

    for step in d.steps[1:]:
        sec = rep.section(f"Forward selection: on top of {' + '.join(step.base)}")
        sec.paragraph(f"A robot may have more than one defect. Here {' + '.join(step.base)} is fixed at its estimate and "
                      f"made part of the baseline, and every remaining effect is fitted and scored again (baseline now "
                      f"{step.before:.3g} m).")
        sec.table(CANDIDATE_HEADER, _candidate_rows(step.results))
        sec.table(["effect", "decision"], [[r.effect.name, r.why] for r in step.results])

    sw = d.simulator_warnings
    if sw and (sw["windows"] or sw["outside_windows"]):
        n = rep.section("Simulator warnings")
        n.paragraph(d.simulator_warning_sentence() + ".")
        if sw["windows"]:
            n.table(["window", "start [s]", "simulations that warned", "warning", "left out"],
                    [[w["window"], w["t0"], "; ".join(w["simulations"]), "; ".join(w["warnings"]),
                      "yes" if w["left_out"] else "no"] for w in sw["windows"]],
                    caption="The \"Time\" in MuJoCo's warning is the time within that window's simulation "
                            "(its warm-up included), not the log's time: the window starts at \"start\".")
        if sw["outside_windows"]:
            n.table(["outside any window"], [[x] for x in sw["outside_windows"]])

    if d.skipped:
        n = rep.section("Not identifiable on this log")
        n.table(["effect", "why it was not tested"], [[k, v] for k, v in d.skipped.items()])

    nx = rep.section("MuJoCo confirmation")
    conf = d.confirmation
    if d.baseline.name == "mujoco":
        nx.paragraph("The baseline is the MuJoCo robot itself: every number above is MuJoCo's.")
    elif best is None:
        nx.paragraph(f"Nothing to confirm: the baseline ({d.baseline_title}) is as good as any extension on this log.")
    elif conf is not None and conf.get("run"):
        nx.paragraph("The log's commands re-simulated with the MuJoCo robot, as described and extended by the cause "
                     "(each segment from rest, same windows). Not held out: the estimate was fitted on this log.")
        nx.table(["MuJoCo robot", f"{d.horizon_s:g} s position RMSE [m]"],
                 [["nominal", conf["before"]], [f"+ {conf['effect']}", conf["after"]]])
        nx.verdict(f"MuJoCo confirms {100 * conf['relative']:.0f} % less position error with {conf['effect']}"
                   if conf["relative"] > 0 else f"MuJoCo does not confirm {conf['effect']}: the error does not drop",
                   warn=conf["relative"] <= 0)
    else:
        est = dict(zip(best.effect.params, best.estimate))
        robot, rest = extended_robot(d.robot, best.effect.name, est)
        why = conf["why"] if conf is not None else "not requested (mjtrack diagnose --confirm)"
        nx.paragraph(f"Not run: {why}. Extended description for a re-simulation: {describe(robot.to_dict())}"
                     + (f"; other changes: {describe(rest)}" if rest else "") + ".")
    return rep
