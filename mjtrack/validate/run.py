"""``validate``: every kinematic model and filter against physics and against MPP truth.

Pipeline: the drive log becomes the ``mujoco`` truth and, on the same commands, the ``mpp``
analytic truth (:mod:`mjtrack.validate.truth`); on each, the three filters run online on noisy
measurements and every predictor (:mod:`mjtrack.validate.predictors`) is scored
(:mod:`mjtrack.validate.evaluate`). Outputs in ``out_dir``: ``report.html`` (one
self-contained file: verdicts, setup, definitions, error-vs-horizon figure and tables, paths,
ICRs over time, parameter recovery, filters) and ``metrics.json`` (the same numbers:
``setup``, ``definitions``, ``verdicts``, ``headline`` (2-s errors per truth and predictor),
``truths.<name>.predictors.<key>.horizons.<h>.{pos_rmse_m, yaw_rmse_deg, n}``,
``truths.<name>.filters.<filter>.consistency.{nis_mean, nis_dof, nees_mean, nees_dof, band95}``, ...).
On a wheeled robot (``traction: "wheels"``) also the wheeled-robot thesis's four models scored on
the log (:mod:`mjtrack.validate.wheeled`): ``wheeled_models.models.<key>.horizons.<h>.{pos_median_m,
pos_max_m, yaw_median_deg, yaw_max_deg, pos_rmse_m, yaw_rmse_deg, n}`` and ``wheeled_models.best.<h>``.
"""

from __future__ import annotations

import logging
import math
import os
from dataclasses import dataclass
from pathlib import Path

from mjtrack.io.atomic import make_output_dir
from mjtrack.io.jsonfile import json_value, write_json
from mjtrack.io.logs import DriveLog
from mjtrack.io.robot import Robot
from mjtrack.progress import Progress
from mjtrack.validate.evaluate import HORIZONS, WZ_MIN, CaseResult, evaluate_case
from mjtrack.validate.report import DEFINITIONS, VERDICT_HORIZON, build_report, verdicts
from mjtrack.validate.truth import MPP_TRUTH, Noise, case_from_log, estimate_noise, mpp_case, resolve_speeds
from mjtrack.validate.wheeled import MAX_STARTS, WheeledResult, evaluate_wheeled

log = logging.getLogger(__name__)

REPORT_NAME = "report.html"
METRICS_NAME = "metrics.json"
N_PREDICTORS = 6


@dataclass(frozen=True, eq=False)
class Validation:
    """What :func:`validate` computed and wrote."""

    results: dict[str, CaseResult]
    metrics: dict
    report_path: Path
    metrics_path: Path
    wheeled: WheeledResult | None = None


def validate(
    drive: DriveLog,
    robot: Robot,
    out_dir: str | os.PathLike,
    *,
    source: str = "drive log",
    truth_title: str = "simulated log",
    horizons=HORIZONS,
    noise: Noise = Noise(),
    seed: int = 0,
    speeds: str = "auto",
    mpp_params: dict | None = None,
    wz_min: float = WZ_MIN,
    quiet: bool = False,
    bar: Progress | None = None,
    log_noise_free: bool | None = None,
    wheeled_max_starts: int = MAX_STARTS,
) -> Validation:
    """Validate all models and filters on ``drive`` (with ``robot``); write report and metrics to ``out_dir``.

    Args:
        source: words saying where the log came from (shown in the report).
        truth_title: short name of the log as a truth in tables and figures ("simulated log",
            "logged motion").
        horizons: prediction horizons [s]; noise: measurement noise given to the filters
            (:class:`~mjtrack.validate.truth.Noise`); seed: its seed.
        speeds: ``"cmd"``, ``"measured"`` or ``"auto"`` (measured if logged) track speeds drive the models.
        mpp_params: the MPP truth's (s_left, s_right, alpha) (default thesis 4.2).
        wz_min: |ω| [rad/s] below which ICRs are not compared.
        bar: a progress display to advance (one is made otherwise, silent with ``quiet``).
        log_noise_free: whether the log is a noise-free simulation, so that the filters' parameter
            NEES can be scored against its own parameters (default: unless ``truth_title`` is
            "measured log" or "logged motion").
        wheeled_max_starts: on a wheeled robot, the most windows per horizon over which the
            thesis's wheeled models are scored (:mod:`mjtrack.validate.wheeled`).
    """
    speeds = resolve_speeds(drive, speeds)
    horizons = tuple(sorted(float(h) for h in horizons))
    if VERDICT_HORIZON not in horizons:
        horizons = tuple(sorted(horizons + (VERDICT_HORIZON,)))
    mpp_params = dict(MPP_TRUTH if mpp_params is None else mpp_params)
    own_bar = bar is None
    wheels = robot.traction == "wheels"
    bar = bar or Progress(2 * (N_PREDICTORS + 1) + 1 + wheels, label="validate", quiet=quiet)
    try:
        noise_free = (truth_title not in ("measured log", "logged motion") if log_noise_free is None
                      else bool(log_noise_free))
        mj = case_from_log(drive, speeds=speeds, noise=noise, seed=seed, title=truth_title, noise_free=noise_free)
        cases = [mj, mpp_case(mj, robot, params=mpp_params, noise=noise, seed=seed)]
        # a measured log's filters get the log's own noise as R (estimated), a simulation's the noise added
        filter_noise = {"log": noise if noise_free else estimate_noise(mj), "mpp": noise}
        results = {c.name: evaluate_case(c, robot.track_gauge, horizons=horizons, noise=filter_noise[c.name],
                                         wz_min=wz_min, bar=bar) for c in cases}
        verdict = verdicts(results)
        wheeled = None
        if wheels:
            wheeled = evaluate_wheeled(mj, drive, robot, horizons=horizons, max_starts=wheeled_max_starts)
            bar.update(note="wheeled models")
        setup = _setup(drive, robot, source, horizons, noise, seed, speeds, mpp_params, wz_min)
        if not noise_free:
            est = filter_noise["log"]
            setup["filter_noise_log"] = {"pose_std": list(est.pose_std), "twist_std": list(est.twist_std),
                                         "how": "estimated from the log (second differences of the poses)"}
            setup["noise_text"] += (f"; on the logged motion the filters' measurement noise is estimated from the log "
                                    f"itself: σ = {est.pose_std[0]:.3g} m, {est.pose_std[1]:.3g} m, "
                                    f"{math.degrees(est.pose_std[2]):.3g}° on the pose, {est.twist_std[0]:.3g} m/s, "
                                    f"{est.twist_std[1]:.3g} m/s, {est.twist_std[2]:.3g} rad/s on the twist")
        report = build_report(results, robot, setup, verdict, wheeled=wheeled)
        bar.update(note="report")
        metrics = json_value({
            "setup": setup, "definitions": DEFINITIONS, "verdicts": verdict,
            "headline": {"horizon_s": VERDICT_HORIZON,
                         "pos_rmse_m": {n: {k: v["horizons"][f"{VERDICT_HORIZON:g}"]["pos_rmse_m"]
                                            for k, v in r.metrics["predictors"].items()} for n, r in results.items()},
                         "yaw_rmse_deg": {n: {k: v["horizons"][f"{VERDICT_HORIZON:g}"]["yaw_rmse_deg"]
                                              for k, v in r.metrics["predictors"].items()} for n, r in results.items()}},
            "truths": {n: r.metrics for n, r in results.items()},
            **({"wheeled_models": wheeled.metrics} if wheeled is not None else {}),
        })
        out = Path(out_dir)
        make_output_dir(out)
        report.write(out / REPORT_NAME)
        write_json(out / METRICS_NAME, metrics)
    finally:
        if own_bar:
            bar.close()
    return Validation(results, metrics, out / REPORT_NAME, out / METRICS_NAME, wheeled)


def _setup(drive, robot, source, horizons, noise, seed, speeds, mpp_params, wz_min) -> dict:
    applied = noise.to_dict()
    if noise.scale == 0:
        noise_text = "none: the filters see the noise-free truth"
    else:
        ps, ts = applied["pose_std_applied"], applied["twist_std_applied"]
        noise_text = (f"the filters see the truth plus seeded Gaussian noise (seed {seed}): σ = {ps[0]:.3g} m on x and "
                      f"y, {math.degrees(ps[2]):.3g}° on yaw, {ts[0]:.3g} m/s on vx and vy, {ts[2]:.3g} rad/s on ω; "
                      "all errors are scored against the noise-free truth")
    return {
        "summary": ("The first truth is the drive log itself (a log simulated here is noise-free; a logged one, "
                    "from a robot or a simulation with noise added, carries its own noise, so errors there include it). The MPP truth drives the "
                    "same commands through the MPP model with known slips, integrated exactly, so the filters can be "
                    "checked for recovering known parameters."),
        "source": source, "samples": int(drive.n_samples), "duration_s": float(drive.duration),
        "robot": robot.to_dict(), "speeds": "commanded" if speeds == "cmd" else "measured",
        "speeds_why": ("the kinematic models relate the actual track speeds to the motion; commanded speeds also "
                       "carry the drives' lag, which no kinematic model describes") if speeds == "measured" else
                      "the log has no measured track speeds" if not drive.has_track_speeds else "chosen by the user",
        "mpp_truth": (f"s_L = {mpp_params['s_left']:g}, s_R = {mpp_params['s_right']:g}, "
                      f"α = {math.degrees(mpp_params['alpha']):g}° (thesis 4.2)"),
        "mpp_truth_params": mpp_params, "noise": applied, "noise_text": noise_text, "seed": seed,
        "filters_text": ("slip EKF (MPP; measures pose and twist), improved ICR EKF (MICR; measures the pose), "
                         "improved VIR filter (MVIR; measures the twist); each with adaptive process noise (a slow "
                         "and a fast random walk of its parameters mixed as an interacting multiple model), starts "
                         "from the nominal parameters and runs online through the log; on a log of several windows "
                         "the parameters are carried from one window to the next (their covariance grown over the "
                         "gap) and only the pose restarts"),
        "horizons_s": list(horizons), "wz_min": wz_min,
    }
