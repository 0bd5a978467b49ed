"""``diagnose(log, robot)``: symptom -> cause -> gain, and its outputs (CONTRACTS.md §4).

Stages (timed in ``Diagnosis.timings``):
1. prepare: drive data, folds, windows at the horizon, the baseline and what can be identified;
2. candidates: every testable effect fitted and scored on held-out folds (:mod:`.select`);
3. secondary: when there is a cause, the effects of the other kind (input vs ground) are tested
   again on top of it (the cause fixed at its estimate, part of the baseline): real robots have
   more than one defect, and a large input effect hides a ground effect in the first ranking.
   Reported under the extra key ``secondary``; ``findings`` stay as CONTRACTS.md §4 defines them;
4. outputs (symptom tables and figures are computed for the report): diagnosis.json exactly as CONTRACTS.md §4 (plus extra keys) and report.html.

5. optional MuJoCo confirmation (:mod:`.confirm`, ``confirm=True``): the log re-simulated with the
   MuJoCo robot, nominal and extended by the cause (:func:`extended_robot`), same windows.
"""

from __future__ import annotations

import dataclasses
import json
import logging
import math
import os
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mjtrack.diagnose import residuals as rs
from mjtrack.diagnose.effects import EFFECTS, Surrogate
from mjtrack.diagnose.fit import Problem
from mjtrack.diagnose.select import CandidateResult, evaluate
from mjtrack.errors import InputError
from mjtrack.io.atomic import atomic_write_text
from mjtrack.io.logs import DriveLog
from mjtrack.io.robot import G, Robot

log = logging.getLogger(__name__)

MIN_TURNING = 0.02  # fraction of samples with |turn ratio| > 0.05 below which ground effects are not tested
MIN_LATERAL = 0.02  # max |a_lat|/(mu g) below which friction_scale is not tested


@dataclass
class Diagnosis:
    """The result of :func:`diagnose`; ``to_json()`` is diagnosis.json."""

    log_path: str
    samples: int
    duration_s: float
    robot: Robot
    baseline: str
    horizon_s: float
    before: float
    results: list[CandidateResult]
    skipped: dict[str, str]
    notes: list[str]
    data: rs.DriveData
    starts: np.ndarray
    ends: np.ndarray
    base_errors: np.ndarray
    n_folds: int
    timings: dict[str, float] = field(default_factory=dict)
    secondary: list[CandidateResult] = field(default_factory=list)
    confirmation: dict | None = None
    transient: bool = False

    @property
    def findings(self) -> list[CandidateResult]:
        return [r for r in self.results if r.passed]

    @property
    def cause(self) -> str:
        f = self.findings
        return f[0].effect.name if f else "none"

    def baseline_text(self) -> str:
        if self.baseline == "coulomb":
            return ("nominal robot, rigid-track Coulomb steady-state surrogate (quasi-static ICRs + first-order "
                    "inertial response" + (" + friction-limited transients" if self.transient else "")
                    + "), driven by the commanded track speeds")
        return "nominal kinematic model (2.1), driven by the commanded track speeds"

    def evidence(self, r: CandidateResult) -> str:
        e = r.effect
        est = ", ".join(f"{n} = {_num(v)} [{_num(a)}, {_num(b)}]" for n, v, (a, b) in zip(e.params, r.estimate, r.interval))
        on_top = f" on top of {self.cause}" if any(r is x for x in self.secondary) else ""
        text = (f"{est} removes{on_top} {100 * r.relative:.0f} % of the {self.horizon_s:g} s position error on held-out folds "
                f"({r.before:.3g} -> {r.after:.3g} m, paired t = {r.t_stat:.1f} over {self.n_folds} folds); "
                f"its signature: {e.signature}")
        if r.speed_after is not None:
            text += f"; measured track speeds agree (speed RMSE {r.speed_before:.3g} -> {r.speed_after:.3g} m/s)"
        if r.tied_with:
            text += (f"; cannot be told apart from {', '.join(r.tied_with)} on this log "
                     "(held-out gains equal within noise)")
        return text + "."

    def _finding_json(self, r: CandidateResult) -> dict:
        return {
            "effect": r.effect.name,
            "estimate": {n: _clean(v) for n, v in zip(r.effect.params, r.estimate)},
            "interval": {n: [_clean(a), _clean(b)] for n, (a, b) in zip(r.effect.params, r.interval)},
            "gain": {"metric": "pos_err_m", "before": float(r.before), "after": float(r.after),
                     "relative": float(r.relative), "held_out": True},
            "evidence": self.evidence(r),
        }

    def to_json(self) -> dict:
        secondary = None
        if self.findings:
            sec = [r for r in self.secondary if r.passed]
            secondary = {
                "on_top_of": self.cause,
                "baseline_value": float(self.secondary[0].before) if self.secondary else None,
                "findings": [self._finding_json(r) for r in sec],
                "tested": [r.effect.name for r in self.secondary],
            }
        findings = [self._finding_json(r) for r in self.findings]
        candidates = [{
            "effect": r.effect.name, "kind": r.effect.kind, "finding": bool(r.passed),
            "estimate": {n: _clean(v) for n, v in zip(r.effect.params, r.estimate)},
            "interval": {n: [_clean(a), _clean(b)] for n, (a, b) in zip(r.effect.params, r.interval)},
            "before": float(r.before), "after": float(r.after), "relative": float(r.relative), "t": _clean(r.t_stat),
            "decision": r.why,
        } for r in self.results]
        return {
            "log": self.log_path, "samples": self.samples, "duration_s": self.duration_s,
            "baseline": {"model": self.baseline_text(), "metric": "pos_err_m", "horizon_s": self.horizon_s,
                         "value": float(self.before)},
            "cause": self.cause,
            "findings": findings,
            "candidates": candidates,
            "secondary": secondary,
            "not_tested": dict(self.skipped),
            "notes": list(self.notes),
            "method": {
                "gain": f"RMS position error after {self.horizon_s:g} s of open-loop prediction from every measured pose, "
                        f"pooled over {self.n_folds} contiguous cross-validation folds (fit on the others)",
                "finding": "paired one-sided t-test over folds at 95 % and a pooled gain of at least the floor",
                "interval": f"95 %, delete-one-fold jackknife over the {self.n_folds} fold fits (statistical only: "
                            "the surrogate's own approximation error is not included)",
            },
            "validation": {"stage": "surrogate (held-out cross-validation)",
                           "mujoco": self.confirmation if self.confirmation is not None else
                           {"stage": "mujoco", "run": False, "why": "not requested (mjtrack diagnose --confirm)"}},
            "timings_s": {k: round(v, 3) for k, v in self.timings.items()},
        }


def _clean(v) -> float | None:
    v = float(v)
    return v if math.isfinite(v) else None


def _num(v) -> str:
    return f"{v:.4g}" if math.isfinite(v) else "∞"


def choose_baseline(robot: Robot) -> str:
    """"coulomb" when the description gives the contact length (or was built in code), else "kinematic"."""
    return "coulomb" if robot.provided is None or "track_length" in robot.provided else "kinematic"


def _folds(data: rs.DriveData, n_folds: int) -> np.ndarray:
    nseg = int(data.seg[-1]) + 1
    if nseg >= 2 * n_folds:
        return (data.seg * n_folds) // nseg
    return (np.arange(data.n) * n_folds) // data.n


def speed_timing(data: rs.DriveData) -> bool:
    """Whether a log's measured track speed at t_k is the one just before t_k (True: causal, the
    command of row k in force from t_k on cannot show in it) or already the response to the row's
    command (False). The log format does not say; physical speeds are continuous, so a speed
    sampled at t_k is causal, but loggers that write the command after reading the sensors, and
    synthetic steady-state logs, give the other. The one under which the nominal model (speed =
    command) fits the measured speeds better is kept: parameter-free, the command changes decide
    it (True when the log has no speeds). Note the ambiguity it resolves: a dead time d logged
    one way is a dead time d - dt logged the other way; no data can tell those apart.
    """
    if data.meas is None:
        return True
    same_seg = np.r_[False, data.seg[1:] == data.seg[:-1]]
    ok = same_seg & np.all(np.isfinite(data.meas), axis=1) & np.r_[False, np.all(np.isfinite(data.meas[:-1]), axis=1)]
    if not ok.any():
        return True
    prev = np.r_[data.cmd[:1], data.cmd[:-1]]
    return bool(np.mean((data.meas[ok] - prev[ok]) ** 2) <= np.mean((data.meas[ok] - data.cmd[ok]) ** 2))


def diagnose(log_: DriveLog, robot: Robot, *, horizon_s: float = 2.0, n_folds: int = 5, min_gain: float = 0.03,
             baseline: str = "auto", effects: list[str] | None = None, max_fit_windows: int = 3000,
             secondary: bool = True, confirm: bool = False, quiet: bool = True,
             transient: bool | str = "auto") -> Diagnosis:
    """Diagnose what the nominal model gets wrong on a measured log, name the cause and its gain.

    Args:
        log_: the measured drive log (pose required; track speeds optional).
        robot: the nominal robot description.
        horizon_s: prediction horizon [s] of the windows (default 2 s).
        n_folds: cross-validation folds (>= 3).
        min_gain: least pooled held-out relative gain of a finding [-].
        baseline: "auto" (:func:`choose_baseline`), "coulomb" or "kinematic".
        effects: names to test (default: all of :data:`EFFECTS`).
        max_fit_windows: windows used per fit (a stride of them); scoring uses all windows.
        secondary: run the secondary stage (effects of the other kind on top of the cause).
        confirm: re-simulate with the MuJoCo robot, nominal and extended by the cause (:mod:`.confirm`).
        transient: model the friction-limited transient after speed changes (coulomb baseline;
            :func:`mjtrack.diagnose.surrogate.friction_limited`): True, False, or "auto" = whichever
            of the two parameter-free nominal baselines predicts the log better (RMS position
            error over all windows; nothing is fitted, so no held-out split is needed). A body
            can never follow a step of its tracks faster than its track friction lets it (mu g
            straight, ~0.27 mu g in yaw entering a turn), but logs whose speeds are smoothed
            before they are logged (or synthetic steady-state logs) show no transient.
    Raises:
        InputError: horizon longer than every segment, too little data for the folds, unknown effect.
    """
    clock = {"start": time.perf_counter()}
    src = log_.source or "drive log"
    if n_folds < 3:
        raise InputError(f"diagnose: need at least 3 folds, got {n_folds}")
    names = list(EFFECTS) if effects is None else list(effects)
    unknown = [n for n in names if n not in EFFECTS]
    if unknown:
        raise InputError(f"diagnose: unknown effect(s) {', '.join(unknown)} (known: {', '.join(EFFECTS)})")
    data = rs.DriveData.from_log(log_)
    sample_fold = _folds(data, n_folds)
    if rs.windows(data.t, data.seg, horizon_s)[0].size == 0:
        longest = max(float(data.t[s.stop - 1] - data.t[s.start]) for s in log_.segment_slices())
        raise InputError(f"{src}: no segment is as long as the {horizon_s:g} s horizon (longest {longest:.3g} s): "
                         "no prediction can be checked, nothing can be identified")
    starts, ends = rs.windows(data.t, data.seg * n_folds + sample_fold, horizon_s)
    fold = sample_fold[starts]
    missing = sorted(set(range(n_folds)) - set(fold.tolist()))
    if missing:
        raise InputError(f"{src}: too short to cross-validate at a {horizon_s:g} s horizon: fold(s) {missing} of "
                         f"{n_folds} hold no complete window (give a longer log or a shorter --horizon)")
    stride = max(1, int(np.ceil(starts.size / max_fit_windows)))
    measured = speed_ok = None
    if data.meas is not None:
        speed_ok = np.all(np.isfinite(data.meas), axis=1)
        measured = np.where(np.isfinite(data.meas), data.meas, data.cmd)
    base = choose_baseline(robot) if baseline == "auto" else baseline
    causal = speed_timing(data)
    surrogate = Surrogate(robot, base, transient=transient is True, causal_speeds=causal)
    if transient == "auto" and base == "coulomb":
        with_tr = Surrogate(robot, base, transient=True, causal_speeds=causal)
        rmse = [float(np.sqrt(np.mean(np.sum(rs.window_errors(s.twist(data, data.cmd), data.step_dt(), data.poses,
                                                                  starts, ends)[:, :2] ** 2, 1))))
                for s in (surrogate, with_tr)]
        if rmse[1] < rmse[0]:
            surrogate = with_tr
        log.debug("diagnose: baseline without / with transients %.4g / %.4g m", *rmse)
    transient_note = None
    if surrogate.transient:
        transient_note = ("the baseline includes the friction-limited transient after speed changes (the rigid body "
                          "follows its tracks as fast as the track friction lets it, straight and in yaw)" + (f": it predicts this log better than the steady-state "
                          f"baseline ({rmse[1]:.3g} vs {rmse[0]:.3g} m)" if transient == "auto" else ""))
    problem = Problem(data=data, surrogate=surrogate, horizon_s=float(horizon_s), dt=data.step_dt(), starts=starts,
                      ends=ends, fold=fold, sample_fold=sample_fold, fit_windows=np.arange(0, starts.size, stride),
                      measured=measured, speed_ok=speed_ok)
    skipped, notes = {}, [transient_note] if transient_note else []
    if base == "kinematic":
        notes.append("the robot description lacks " + ", ".join(k for k in ("track_length", "mass", "mu")
                                                                 if robot.provided is not None and k not in robot.provided)
                     + f": the baseline is the kinematic model (2.1); ground effects use the Coulomb response of an "
                       f"assumed contact length L = {robot.track_length:g} m")
    turning = float(np.mean(np.abs(rs.turn_ratio(data.cmd)) > 0.05))
    base_twist = surrogate.twist(data, data.cmd)
    lat = float(np.max(np.abs(base_twist[:, 0] * base_twist[:, 2]))) / (robot.mu * G)
    for n in names:
        e = EFFECTS[n]
        if not surrogate.testable(e):
            skipped[n] = "acts only through the inertial response, which the kinematic baseline does not model"
        elif e.kind == "ground" and turning < MIN_TURNING:
            skipped[n] = (f"the log has no turning ({100 * turning:.1f} % of samples with |turn ratio| > 0.05): ground "
                          "effects change the motion only in turns (straight driving sticks), not identifiable")
        elif n == "friction_scale" and lat < MIN_LATERAL:
            skipped[n] = (f"lateral acceleration at most {lat:.3f} mu g: the friction level does not change the "
                          "motion at these speeds, not identifiable")
    if turning < MIN_TURNING:
        notes.append("no turning in the log: only the input effects (speed scale, lag, delay, limit) can be tested")
    if data.meas is not None:
        notes.append("measured track speeds present: input effects are fitted to them, ground effects are fitted "
                     "with the model driven by them; a speed sample at t is taken as "
                     + ("the speed just before the command of its row (causal)" if causal else
                        "already the response to the command of its row (it fits the speeds better)"))
    clock["prepare"] = time.perf_counter()
    tested = [EFFECTS[n] for n in names if n not in skipped]
    _, results = evaluate(problem, tested, n_folds=n_folds, min_gain=min_gain, quiet=quiet)
    clock["candidates"] = time.perf_counter()
    second = []
    found = [r for r in results if r.passed]
    if found and secondary:  # secondary stage: effects of the other kind, on top of the cause (fixed at its estimate)
        cause = found[0]
        others = [e for e in tested if e.kind != cause.effect.kind]
        if others:
            base_problem = dataclasses.replace(problem, base=(cause.effect, cause.estimate))
            _, second = evaluate(base_problem, others, n_folds=n_folds, min_gain=min_gain, quiet=quiet)
    clock["secondary"] = time.perf_counter()
    base_err = rs.window_errors(base_twist, problem.dt, data.poses, starts, ends)
    before = float(np.sqrt(np.mean(base_err[:, 0] ** 2 + base_err[:, 1] ** 2)))
    diag = Diagnosis(log_path=str(log_.source) if log_.source else "", samples=data.n,
                     duration_s=float(sum(data.t[s.stop - 1] - data.t[s.start] for s in log_.segment_slices())),
                     robot=robot, baseline=base, horizon_s=float(horizon_s), before=before, results=results,
                     skipped=skipped, notes=notes, data=data, starts=starts, ends=ends, base_errors=base_err,
                     n_folds=n_folds, secondary=second, transient=surrogate.transient)
    diag.timings = {"prepare": clock["prepare"] - clock["start"], "candidates": clock["candidates"] - clock["prepare"],
                    "secondary": clock["secondary"] - clock["candidates"]}
    if confirm:
        from mjtrack.diagnose.confirm import confirm as confirm_mujoco

        diag.confirmation = confirm_mujoco(diag)
        diag.timings["mujoco"] = time.perf_counter() - clock["secondary"]
    log.info("diagnose %s: cause %s (%s)", src, diag.cause, diag.timings)
    return diag


def extended_robot(robot: Robot, effect: str, estimate: dict[str, float]) -> tuple[Robot, dict]:
    """Hook for the MuJoCo confirmation stage: the robot description a finding asks for, and the
    remaining non-robot changes (input transform or scene) as a dict."""
    e = dict(estimate)
    if effect == "cg_offset_x":
        return robot.replace(cg_x=e["cg_offset_x"]), {}
    if effect == "cg_offset_y":
        return robot.replace(cg_y=e["cg_offset_y"]), {}
    if effect == "friction_scale":
        s = e["friction_scale"]
        return robot.replace(mu=robot.mu * s, mu_left=None if robot.mu_left is None else robot.mu_left * s,
                             mu_right=None if robot.mu_right is None else robot.mu_right * s), {}
    if effect == "friction_asymmetry":
        return robot.replace(mu_left=robot.friction_right * e["friction_asymmetry"], mu_right=robot.friction_right), {}
    return robot, e


def write_outputs(diagnosis: Diagnosis, out_dir: str | os.PathLike) -> None:
    """Write DIR/diagnosis.json and DIR/report.html (each atomically)."""
    from mjtrack.diagnose.report import build_report

    t0 = time.perf_counter()
    out = Path(out_dir)
    report = build_report(diagnosis)  # everything is built before anything is written
    diagnosis.timings["report"] = time.perf_counter() - t0
    text = json.dumps(diagnosis.to_json(), indent=2, allow_nan=False) + "\n"
    html = report.to_html()
    out.mkdir(parents=True, exist_ok=True)
    atomic_write_text(out / "report.html", html)
    atomic_write_text(out / "diagnosis.json", text)
