"""The validation's words: plain-language verdicts, definitions, and the HTML report.

Verdict rule (one sentence per predictor and truth, from the 2-s position RMSE): with
r = nominal / predictor, "a large improvement" for r ≥ 3, "better" for 1.25 ≤ r < 3, "no clear
gain" for 0.8 < r < 1.25, "worse" for r ≤ 0.8; a reason follows where the design explains the
outcome (:func:`_why`).
"""

from __future__ import annotations

import math

import numpy as np

from mjtrack.io.robot import Robot
from mjtrack.report.html import Report
from mjtrack.validate import figures
from mjtrack.validate.evaluate import CaseResult
from mjtrack.validate.wheeled import WheeledResult

VERDICT_HORIZON = 2.0  # [s]

DEFINITIONS = {
    "prediction from t_s over h": "start at the true pose at a sample time t_s, hold the predictor's parameters "
                                  "known at t_s, drive the model with the logged track speeds (see Setup) and "
                                  "integrate its twist exactly for h seconds",
    "position RMSE at h [m]": "root mean square, over all start times t_s, of the distance between the predicted "
                              "and the true position at t_s + h",
    "heading RMSE at h [deg]": "root mean square of the predicted minus the true heading at t_s + h, "
                               "wrapped to ±180°",
    "n": "number of start times scored (every few samples; starts whose horizon runs past the log's end are dropped)",
    "online (filter) parameters": "the parameters a filter had estimated from the measurements up to t_s only; "
                                  "an online robot could use them",
    "oracle": "the best constant parameters fitted (least squares) to the true motion inside the very window being "
              "predicted: not usable online, it shows the best any constant-parameter model of that family can do",
    "own ICRs (eq. (2.13) of [Mendaluk])": "the instantaneous centres of rotation computed from the true twist and the same track "
                       "speeds: y_l = (vx − V_L)/ω, y_r = (vx − V_R)/ω, x_c = −vy/ω; undefined when ω is near 0",
    "ICR error [m]": "median absolute difference between the ICRs implied by a predictor's parameters and the own "
                     "ICRs, over the samples with true |ω| ≥ the ICR threshold, after the settling time (the median: "
                     "the own ICRs spike for a moment at every change of command)",
    "open-loop drift [m]": "distance between the end of the model's path, dead-reckoned over the whole log from "
                           "the true start, and the true end (summed over segments)",
    "parameter error (MPP truth)": "absolute difference between the slip EKF's final estimate and the known "
                                   "s_L, s_R [-], α [rad] of the MPP truth",
}


def _ratio_words(r: float) -> str:
    if not math.isfinite(r):
        return "not comparable"
    if r >= 1000:
        return "over 1000× smaller than nominal: a large improvement"
    if r >= 3:
        return f"{r:.1f}× smaller than nominal: a large improvement"
    if r >= 1.25:
        return f"{r:.1f}× smaller than nominal: better"
    if r > 0.8:
        return "about the same as nominal: no clear gain"
    return f"{1 / r:.1f}× larger than nominal: worse"


def pos_at(res: CaseResult, key: str, h: float = VERDICT_HORIZON) -> float:
    return res.metrics["predictors"][key]["horizons"][f"{h:g}"]["pos_rmse_m"]


def verdicts(results: dict[str, CaseResult]) -> dict[str, str]:
    """One plain-language verdict per predictor, over all truths."""
    first = next(iter(results.values()))
    out = {}
    parts = [f"{pos_at(r, 'nominal'):.3g} m on the {r.case.title}" for r in results.values()]
    out["nominal"] = (f"Nominal (no slip): the baseline. Its {VERDICT_HORIZON:g}-s position error is " +
                      " and ".join(parts) + ": this is how far slip carries the robot away from the no-slip "
                      "prediction in that time.")
    for p in first.predictors[1:]:
        parts = []
        for r in results.values():
            v, n = pos_at(r, p.key), pos_at(r, "nominal")
            failed = r.metrics["predictors"][p.key].get("failed")
            if failed:
                parts.append(f"on the {r.case.title} no prediction: the {failed}")
                continue
            parts.append(f"on the {r.case.title} {v:.3g} m vs {n:.3g} m ({_ratio_words(n / v if v > 0 else math.inf)})")
        kind = "Upper bound, not usable online. " if not p.causal else ""
        out[p.key] = f"{p.label}: {kind}{VERDICT_HORIZON:g}-s position error " + "; ".join(parts) + "."
        why = _why(p, results)
        if why:
            out[p.key] += " " + why
    return out


def _ratio(results: dict[str, CaseResult], truth: str, key: str) -> float:
    if truth not in results:
        return math.nan
    v = pos_at(results[truth], key)
    return pos_at(results[truth], "nominal") / v if v and v > 0 else math.nan


def _why(p, results: dict[str, CaseResult]) -> str:
    """A plain-language reason for the outcomes the design explains (empty when none applies)."""
    if p.key == "mpp_slip_ekf" and "log" in results:
        alpha = results["log"].filters["slip_ekf"].params[:, 2]
        if np.nanmax(np.abs(alpha), initial=0.0) > math.radians(60) or results["log"].filters["slip_ekf"].error:
            return ("On the physics its lateral slip α reached ±60° or more: in turns on the spot (v_x ≈ 0) an offset "
                    "centre of gravity moves the robot sideways, which MPP (v_y = −v_x tan α) can only express with "
                    "α → ±90°, and its predictions blow up.")
    if p.model in ("MICR", "MVIR") and p.causal and _ratio(results, "mpp", p.key) < 1.25:
        return ("Expected on the MPP truth: constant slip ratios mean ICRs that change with every command (with "
                "equal track speeds the MPP robot still turns, which no finite ICRs can express), so a filter "
                "tracking slowly varying ICRs lags behind each change.")
    if p.key == "mpp_slip_ekf" and _ratio(results, "log", "micr_own_icr") > _ratio(results, "log", "mpp_fit") \
            and _ratio(results, "log", p.key) < 3:
        return ("On the physics, the slip is described better by ICRs that stay put than by slip ratios: the fitted "
                "slips change with each manoeuvre (the ICR figure shows the MPP's implied ICRs jumping).")
    if p.key == "mpp_fit" and _ratio(results, "mpp", p.key) >= 1000:
        return "On the MPP truth it is exact by construction (the truth belongs to the family it fits)."
    if p.key == "micr_own_icr" and _ratio(results, "log", p.key) > _ratio(results, "log", "mpp_fit"):
        return "On the physics, fixed ICRs describe the motion better than fixed slip ratios."
    return ""


def _setup(report: Report, robot: Robot, setup: dict) -> None:
    s = report.section("Setup")
    s.paragraph(setup["summary"])
    items = {
        "data": setup["source"],
        "robot": ", ".join(f"{k} = {v:g}" for k, v in robot.to_dict().items() if isinstance(v, (int, float))),
        "samples": f"{setup['samples']} over {setup['duration_s']:.3g} s",
        "model inputs": f"{setup['speeds']} track speeds drive every model and filter ({setup['speeds_why']})",
        "MPP analytic truth": setup["mpp_truth"],
        "measurement noise": setup["noise_text"],
        "filters": setup["filters_text"],
        "horizons": ", ".join(f"{h:g} s" for h in setup["horizons_s"]),
        "ICR threshold": f"ICRs are compared only where the true |ω| ≥ {setup['wz_min']:g} rad/s",
    }
    s.definitions(items)


def _wheeled_section(rep: Report, res: WheeledResult) -> None:
    """The wheeled-robot thesis's four models on the log: inputs, parameters, errors, the best per horizon."""
    m = res.metrics
    s = rep.section("Wheeled-robot models")
    s.paragraph("The robot is wheeled, so the wheeled-robot thesis's four models are scored too, on the log only: "
                "from each window's start each starts from the logged state (pose, twist, wheel speeds) and is "
                "integrated with its own RK4 step over the horizon. Errors are at the robot's geometric centre; "
                "median and worst over the windows.")
    s.table(["model", "input", "parameters not in the robot description"],
            [[p.label, p.input_text, "; ".join(f"{k}: {v}" for k, v in p.assumed.items()) or "none"]
             for p in res.predictors], caption="what each model receives")
    hs = list(next(iter(m["models"].values()))["horizons"])
    rows = []
    for p in res.predictors:
        hz = m["models"][p.key]["horizons"]
        rows.append([p.label] + [v for h in hs for v in (hz[h]["pos_median_m"], hz[h]["pos_max_m"])] +
                    [v for h in hs for v in (hz[h]["yaw_median_deg"], hz[h]["yaw_max_deg"])])
    s.table(["model"] + [f"pos {h} s {w} [m]" for h in hs for w in ("median", "worst")] +
            [f"heading {h} s {w} [deg]" for h in hs for w in ("median", "worst")], rows,
            caption=f"prediction errors on the log ({m['models'][res.predictors[0].key]['horizons'][hs[0]]['n']} "
                    f"windows at the shortest horizon)")
    labels = {p.key: p.label for p in res.predictors}
    s.table(["horizon [s]", "best median position", "best median heading", "best worst position"],
            [[h, labels.get(b["position"], "none"), labels.get(b["heading"], "none"),
              labels.get(b["position_worst"], "none")] for h, b in m["best"].items()],
            caption="ranking: the model with the lowest error at each horizon")
    s.figure(figures.wheeled_figure(res), "Position (top) and heading (bottom) error of the wheeled models against "
             "the horizon: median over the windows (solid) and worst (dashed). Log scale.")


def build_report(results: dict[str, CaseResult], robot: Robot, setup: dict, verdict: dict[str, str], *,
                 wheeled: WheeledResult | None = None) -> Report:
    """The whole HTML report (sections described in the module docstring of :mod:`mjtrack.validate.run`)."""
    rep = Report("mjtrack validate: kinematic slip models against physics", intro=(
        "This report checks how well four kinematic models of a tracked robot (nominal differential drive, MPP slip "
        "parameters, MICR instantaneous centres of rotation, MVIR virtual wheeled robot) predict its motion a few "
        "seconds ahead, with their parameters estimated online by three filters, against two truths: the drive "
        f"log ({next(iter(results.values())).case.title}) and an analytic MPP truth with known slips on the same "
        "commands. Lower errors are better."))
    v = rep.section("Verdicts")
    for key, text in verdict.items():
        v.verdict(text, warn=("worse" in text or "failed" in text) and key != "nominal")
    hdr = ["predictor"] + [f"{r.case.title}: pos [m]" for r in results.values()] + \
          [f"{r.case.title}: heading [deg]" for r in results.values()]
    rows = []
    for p in next(iter(results.values())).predictors:
        rows.append([p.label] + [pos_at(r, p.key) for r in results.values()] +
                    [r.metrics["predictors"][p.key]["horizons"][f"{VERDICT_HORIZON:g}"]["yaw_rmse_deg"]
                     for r in results.values()])
    v.table(hdr, rows, caption=f"RMSE of {VERDICT_HORIZON:g}-s predictions")
    _setup(rep, robot, setup)
    rep.section("Definitions").definitions(DEFINITIONS)
    if wheeled is not None:
        _wheeled_section(rep, wheeled)

    h = rep.section("Prediction error against horizon")
    h.paragraph("Each curve is one predictor; solid: online (parameters known at the start of the prediction), "
                "dashed: oracle upper bounds. Log scale.")
    h.figure(figures.horizon_figure(results), "Position (top) and heading (bottom) RMSE against the prediction "
             "horizon, one column per truth.")
    for r in results.values():
        hs = list(next(iter(r.metrics["predictors"].values()))["horizons"])
        rows = [[p.label] + [r.metrics["predictors"][p.key]["horizons"][k]["pos_rmse_m"] for k in hs] +
                [r.metrics["predictors"][p.key]["horizons"][k]["yaw_rmse_deg"] for k in hs] +
                [r.metrics["predictors"][p.key]["final_drift_m"]] for p in r.predictors]
        h.table(["predictor"] + [f"pos {k} s [m]" for k in hs] + [f"heading {k} s [deg]" for k in hs] +
                ["open-loop drift [m]"], rows, caption=f"truth: {r.case.title}")

    for r in results.values():
        s = rep.section(f"Paths and ICRs: {r.case.title}")
        s.figure(figures.paths_figure(r), f"True path (black) and each predictor's open-loop path over the whole "
                 f"log, from the true start (truth: {r.case.title}). Dashed: oracles.")
        s.figure(figures.icr_figure(r, setup["wz_min"], robot.traction), "ICRs over time: the truth's own ICRs (black dots) and the "
                 "ICRs implied by each filter's online estimate.")
        rows = [[p.label] + [r.metrics["predictors"][p.key]["icr_error_m"][f] for f in ("y_l", "y_r", "x_c")]
                for p in r.predictors if p.key != "nominal"]
        s.table(["predictor", "y_l error [m]", "y_r error [m]", "x_c error [m]"], rows,
                caption=f"ICR tracking over {r.metrics['icr_samples_compared']} samples (after "
                        f"{r.metrics['settle_s']:.3g} s settling)")
        if r.case.truth_params is not None:
            s.figure(figures.mpp_params_figure(r), "Slip EKF estimates against the known MPP slips (dashed).")
            err = r.metrics["filters"]["slip_ekf"]["param_error_final"]
            tp = r.case.truth_params
            est = r.metrics["filters"]["slip_ekf"]["final"]
            s.table(["parameter", "truth", "final estimate", "|error|"],
                    [[k, tp[k], est[k], err[k]] for k in ("s_left", "s_right", "alpha")],
                    caption="parameter recovery by the slip EKF (α in rad)")

    c = rep.section("Filter consistency")
    c.paragraph("A filter is consistent when its errors are as large as its covariance says. NIS (normalised "
                "innovation squared, εᵀS⁻¹ε) needs no truth: its mean should equal the number of measured "
                "components m. Parameter NEES (eᵀP⁻¹e of the parameter error) needs true parameters: its mean "
                "should equal the number of parameters. Ratios far above 1: over-confident (the filter believes "
                "wrong estimates); far below 1: under-confident.")
    rows = []
    for r in results.values():
        for name, fm in r.metrics["filters"].items():
            cm = fm["consistency"]
            rows.append([f"{name} on {r.case.title}", cm["nis_mean"], cm["nis_dof"],
                         cm["nis_mean"] / cm["nis_dof"] if cm["nis_mean"] is not None else None,
                         cm["nees_mean"], cm["nees_dof"],
                         cm["nees_mean"] / cm["nees_dof"] if cm["nees_mean"] is not None else None])
    c.table(["filter", "mean NIS", "m", "NIS/m", "mean NEES", "parameters", "NEES/parameters"], rows,
            caption="consistency after the settling time (NEES: not available without a noise-free truth)")
    for r in results.values():
        c.figure(figures.nis_figure(r), f"NIS over time on the {r.case.title} with its 95 % bands (χ² quantiles).")

    f = rep.section("Filters")
    f.paragraph("Final estimates of each filter (ψ = (x_c, (y_l + y_r)/2, 1)/(y_l − y_r) for the ICR EKF and VIR "
                "filter, which is also (x_o, y_o, 1)/T_v of the virtual robot).")
    rows = []
    for r in results.values():
        for name, fm in r.metrics["filters"].items():
            rows.append([f"{name} on {r.case.title}", fm["measures"],
                         ", ".join(f"{k} = {val:.4g}" for k, val in fm["final"].items())])
    f.table(["filter", "measures", "final parameters"], rows)
    return rep
