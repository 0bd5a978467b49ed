"""``diagnose(log, robot)``: symptom -> cause(s) -> gain, and its outputs (docs/reference/formats/diagnosis-json.md).

Stages (timed in ``Diagnosis.timings``):
1. prepare: the baseline and its problem -- the surrogate's
   (:func:`mjtrack.diagnose.surrogate.baseline.surrogate_problem`: the horizon, folds, blocks,
   windows at every sample) or the MuJoCo robot's (imported only then) -- and what can be identified;
2. selection: forward selection over all effects, scored on held-out folds (or on a test log)
   (:func:`mjtrack.diagnose.select.forward_select`);
3. outputs: diagnosis.json (:class:`mjtrack.diagnose.result.Diagnosis`, with the simulator's
   warnings and the answer without the windows that warned) and report.html;
4. optional MuJoCo confirmation (:mod:`.confirm`, ``confirm=True``).
"""

from __future__ import annotations

import json
import logging
import os
import time
from pathlib import Path

import numpy as np

from mjtrack.diagnose import residuals as rs
from mjtrack.diagnose import stats as st
from mjtrack.diagnose.baseline import Baseline
from mjtrack.diagnose.confirm import confirm as confirm_mujoco
from mjtrack.diagnose.problem import Problem, concat_logs
from mjtrack.diagnose.report import build_report
from mjtrack.diagnose.result import Diagnosis, extended_robot
from mjtrack.diagnose.select import Step, first_cause, forward_select
from mjtrack.diagnose.surrogate.baseline import DEFAULT_HORIZON, surrogate_problem
from mjtrack.diagnose.vocabulary import EFFECTS, canonical_effects
from mjtrack.errors import InputError
from mjtrack.io.atomic import atomic_write_text, make_output_dir
from mjtrack.io.jsonfile import json_value
from mjtrack.io.logs import DriveLog
from mjtrack.io.robot import G, Robot, check_same_robot
from mjtrack.progress import clock_text

log = logging.getLogger(__name__)

MIN_TURNING = 0.02  # fraction of samples with |turn ratio| > 0.05 below which ground effects are not tested
MIN_LATERAL = 0.02  # max |a_lat|/(mu g) below which friction_scale is not tested
BASELINES = ("auto", "mujoco", "surrogate", "kinematic")
# surrogate-ranked effects the MuJoCo baseline fits (plus its own ground effects); None: every one.
# Not screened by default: the surrogate cannot see every effect MuJoCo can (on a MuJoCo log whose
# tracks ran at 0.92 of the command it ranked lag, delay and friction first, and the diagnosis named
# nothing; fitting every candidate named the speed scale, 0.92, at about 1.7 times the time)
MUJOCO_SCREEN: int | None = None

__all__ = ["Diagnosis", "diagnose", "extended_robot", "write_outputs", "noise_floor", "BASELINES"]


def noise_floor(data: rs.DriveData) -> float:
    """Window position RMSE [m] that white pose noise alone would give, 2 sigma, with sigma from
    the second differences of x and y inside segments (robust: median absolute deviation)."""
    d2 = []
    for j in (0, 1):
        x = data.poses[:, j]
        same = (data.seg[2:] == data.seg[1:-1]) & (data.seg[1:-1] == data.seg[:-2])
        d2.append((x[2:] - 2 * x[1:-1] + x[:-2])[same])
    d2 = np.concatenate(d2)
    if d2.size < 10:
        return 0.0
    sigma = 1.4826 * float(np.median(np.abs(d2 - np.median(d2)))) / np.sqrt(6.0)
    return 2.0 * sigma


def diagnose(log_: DriveLog, robot: Robot, *, horizon_s: float | str = "auto", n_folds: int = 5,
             min_gain: float = 0.03, baseline: str = "surrogate", effects: list[str] | None = None,
             max_fit_windows: int = 3000, max_effects: int | None = None, confirm: bool = False, quiet: bool = True,
             transient: bool | str = "auto", test_log: DriveLog | None = None,
             test_robot: Robot | None = None, screen: int | None = MUJOCO_SCREEN,
             drive_input: str | None = None) -> Diagnosis:
    """Diagnose what the nominal model gets wrong on a measured log, name the cause(s) and the gain.

    Args:
        log_: the measured drive log (pose required; track speeds optional).
        robot: the nominal robot description.
        horizon_s: prediction horizon [s] of the windows, or "auto" (:func:`choose_horizon`; the
            MuJoCo baseline: 2 s).
        n_folds: cross-validation folds (>= 3).
        min_gain: least held-out relative gain of a finding [-].
        baseline: "surrogate" (default) or "kinematic" (:func:`make_baseline`); "mujoco": the MuJoCo
            robot itself is diagnosed (:class:`mjtrack.diagnose.mujoco_baseline.MujocoBaseline`; every
            MuJoCo effect, or ``effects``; with ``screen`` N the surrogate diagnosis pre-screens them,
            faster: the N effects it ranks best that MuJoCo can simulate, plus the MuJoCo-only ground
            extensions -- it can miss an effect the surrogate does not see); "auto": "mujoco" whenever the
            description lets the MuJoCo robot be built, else "surrogate" with the reason in the notes
            and ``baseline.choice``.
        effects: names to test (default: every effect of :data:`EFFECTS` the baseline can simulate); the
            names replaced in 0.3 (:data:`mjtrack.diagnose.vocabulary.RENAMED`) are read with a
            DeprecationWarning.
        max_fit_windows: windows used per surrogate fit (a stride of them); scoring uses all windows.
        max_effects: forward selection stops after this many effects (default: the baseline's
            ``max_effects``: 3 for the surrogates, 2 for MuJoCo, whose every step costs ~8 window
            passes per remaining candidate, the second taken only when the first leaves an error
            beyond the pose noise that another effect could remove).
        confirm: re-simulate with the MuJoCo robot, nominal and extended by the cause (:mod:`.confirm`).
        transient: model the friction-limited transient after speed changes (coulomb baseline;
            :func:`mjtrack.diagnose.surrogate.friction_limited`): True, False, or "auto" = whichever
            of the two parameter-free nominal baselines predicts the log better.
        test_log: fit on ``log_``, score on this log (no cross-validation); ``test_robot``: its
            description when it has its own (refused when it is another robot).
        drive_input: the MuJoCo baseline's simulated drives follow the logged "commanded" speeds or the
            "measured" track speeds; None (default): what the robot file says (``simulator.drive_input``,
            which a calibration on measured speeds writes), else the commands.
    Raises:
        InputError: horizon longer than every segment, too little data for the folds, unknown
            effect or baseline, a test log of another robot, MuJoCo requested for a robot it cannot build.
    """
    kw = dict(horizon_s=horizon_s, n_folds=n_folds, min_gain=min_gain, baseline=baseline, effects=effects,
              max_fit_windows=max_fit_windows, max_effects=max_effects, confirm=confirm, quiet=quiet,
              transient=transient, test_log=test_log, test_robot=test_robot, screen=screen, drive_input=drive_input)
    if baseline in ("surrogate", "kinematic") and not confirm:  # nothing simulated: MuJoCo is not even imported
        return _diagnose(log_, robot, **kw)
    from mjtrack.sim.rollout import summarised_mujoco_warnings

    with summarised_mujoco_warnings(f"diagnose {log_.source or 'drive log'}", log) as messages:
        diag = _diagnose(log_, robot, **kw)
    if messages and diag.confirmation is not None and diag.confirmation.get("run"):
        # the surrogate's cause re-simulated whole (not in windows): the warnings are the confirmation's
        diag.confirmation["mujoco_warnings"] = {"count": len(messages), "first": messages[0].strip()}
    return diag


def _diagnose(log_: DriveLog, robot: Robot, *, horizon_s, n_folds, min_gain, baseline, effects, max_fit_windows,
              max_effects, confirm, quiet, transient, test_log, test_robot, screen, drive_input) -> Diagnosis:
    clock = {"start": time.perf_counter()}
    src = log_.source or "drive log"
    if n_folds < 3:
        raise InputError(f"diagnose: need at least 3 folds, got {n_folds}")
    if n_folds > log_.n_samples // 2:  # each fold needs a window of two samples at least; checked before any work
        raise InputError(f"{src}: {n_folds} folds: the log's {log_.n_samples} samples make at most "
                         f"{log_.n_samples // 2}")
    if baseline not in BASELINES:
        raise InputError(f"diagnose: unknown baseline {baseline!r} (known: {', '.join(BASELINES)})")
    if effects is not None:
        effects = canonical_effects(effects, EFFECTS, traction=robot.traction)
    if test_log is not None and test_robot is not None:
        check_same_robot(robot, test_robot, test_log.source or "test log")
    if drive_input not in (None, "commanded", "measured"):
        raise InputError(f"diagnose: drive input {drive_input!r} is neither 'commanded' nor 'measured'")
    requested, mujoco_note = baseline, None
    if baseline in ("auto", "mujoco"):
        from mjtrack.diagnose.mujoco_baseline import choose_simulator

        use_mujoco, mujoco_note = choose_simulator(baseline, robot)
        baseline = "mujoco" if use_mujoco else "surrogate"
    if baseline == "mujoco":
        if effects is None and screen is not None:
            effects, screened = _screened(log_, robot, screen, horizon_s=horizon_s, n_folds=n_folds,
                                          min_gain=min_gain, test_log=test_log)
        else:
            screened = None
        clock["screen"] = time.perf_counter()
        model, problem, notes = _mujoco_problem(log_, robot, test_log=test_log, horizon_s=horizon_s, n_folds=n_folds,
                                                drive_input=drive_input)
        # the rate of the baseline's pass over every window (problem() simulated it), for the time expected
        rate = problem.starts.size / max(time.perf_counter() - clock["screen"], 1e-9)
        choice = {"requested": requested, "chosen": "mujoco", "why": mujoco_note, "screened_by_surrogate": screened}
    else:
        model, problem, notes, why = surrogate_problem(log_, robot, horizon_s=horizon_s, n_folds=n_folds,
                                                       baseline=baseline, max_fit_windows=max_fit_windows,
                                                       transient=transient, test_log=test_log)
        choice = {"requested": requested, "chosen": model.name, "why": why}
        if mujoco_note is not None:
            choice["why"] = f"{mujoco_note}; {why}"
            notes.append(mujoco_note)
        if drive_input is not None:
            notes.append(f"drive input {drive_input!r} applies to the MuJoCo baseline; the {model.name} baseline "
                         "does not use it")
    data = problem.data
    n_folds_used = 2 if test_log is not None else n_folds
    names = model.default_effects() if effects is None else list(effects)
    skipped = _not_identifiable(model, names, problem)
    if np.mean(np.abs(rs.turn_ratio(data.cmd)) > 0.05) < MIN_TURNING:
        notes.append("no turning in the log: only the input effects (speed scale, lag, delay, limit) can be tested")
    clock["prepare"] = time.perf_counter()
    tested = [EFFECTS[n] for n in names if n not in skipped]
    intro = None
    if model.name == "mujoco":
        def intro(current: Problem, remaining: list) -> str:
            more = model.expected_windows(current, remaining)
            step = "" if not current.base else f" on top of {' + '.join(e.name for e, _ in current.base)}"
            text = (f"diagnose {src}: {problem.starts.size} windows simulated at {rate:.0f} a second; the "
                    f"{len(remaining)} candidates{step} take about {more} more: about {clock_text(more / rate)}")
            log.info(text)
            return text
    steps, chosen = forward_select(model, problem, tested, n_folds=n_folds_used, min_gain=min_gain,
                                   max_effects=model.max_effects if max_effects is None else max_effects, quiet=quiet,
                                   free_steps=model.free_steps if max_effects is None else None,
                                   noise=noise_floor(data), intro=intro)
    clock["selection"] = time.perf_counter()
    scored = problem.scored
    base_err = model.errors(problem, np.arange(problem.starts.size))[0][scored]
    diag = Diagnosis(log_path=str(log_.source) if log_.source else "", samples=log_.n_samples,
                     duration_s=float(sum(data.t[s.stop - 1] - data.t[s.start] for s in log_.segment_slices())),
                     robot=robot, baseline=model, horizon_s=float(problem.horizon_s), before=st.pos_rmse(base_err),
                     steps=steps, chosen=chosen, skipped=skipped, notes=notes, data=data, starts=problem.starts[scored],
                     ends=problem.ends[scored], base_errors=base_err, n_folds=n_folds_used,
                     noise_floor=noise_floor(data), diverged=int(np.sum(~problem.valid_mask)),
                     test_log=(str(test_log.source) if test_log.source else "test log") if test_log is not None else None,
                     choice=choice)
    diag.simulator_warnings = _simulator_warnings(model, problem, steps, base_err, min_gain)
    diag.timings = {"prepare": clock["prepare"] - clock.get("screen", clock["start"]),
                    "selection": clock["selection"] - clock["prepare"]}
    if "screen" in clock:
        diag.timings["screen"] = clock["screen"] - clock["start"]
    if confirm or model.name == "mujoco":  # (MuJoCo throughout: confirm() says so)
        diag.confirmation = confirm_mujoco(diag)
        diag.timings["mujoco"] = time.perf_counter() - clock["selection"]
    log.info("diagnose %s: cause %s (%s)", src, diag.cause, diag.timings)
    return diag


def _screened(log_: DriveLog, robot: Robot, screen: int, *, horizon_s, n_folds, min_gain,
              test_log) -> tuple[list[str], list[str]]:
    """The effects the MuJoCo baseline fits when the surrogate pre-screens them: the ``screen`` the
    surrogate diagnosis ranks best that MuJoCo can simulate, plus MuJoCo's own ground models;
    returns (effects, those screened)."""
    from mjtrack.diagnose.mujoco_baseline import CHANGES

    sur = diagnose(log_, robot, horizon_s=horizon_s, n_folds=n_folds, min_gain=min_gain, baseline="surrogate",
                   quiet=True, test_log=test_log)
    ranked = [r.effect.name for r in sorted(sur.results, key=lambda r: r.after) if r.effect.name in CHANGES]
    screened = ranked[:screen]
    return screened + [n for n in ("ground_anisotropy", "road_wheels") if n not in screened], screened


def _mujoco_problem(log_: DriveLog, robot: Robot, *, test_log, horizon_s, n_folds,
                    drive_input) -> tuple[Baseline, Problem, list[str]]:
    """The MuJoCo baseline of the log (and test log), its problem and its notes (what drives the
    simulated drives; windows left out)."""
    from mjtrack.diagnose.mujoco_baseline import MujocoBaseline
    from mjtrack.sim.config import robot_sim_settings
    from mjtrack.windows import AGAINST_WHY, STUCK_WHY, left_out_counts, measured_drive_log

    src = log_.source or "drive log"
    notes: list[str] = []
    from_file = robot_sim_settings(robot).get("drive_input")
    if (drive_input or from_file) == "measured":
        log_ = measured_drive_log(log_, src)
        test_log = None if test_log is None else measured_drive_log(test_log, test_log.source or "test log")
        notes.append("the simulated drives follow the logged track speeds, as in the robot's calibration (robot "
                     "key simulator.drive_input: measured)" if drive_input is None else
                     "the simulated drives follow the logged track speeds (drive input: measured)")
    elif drive_input == "commanded" and from_file == "measured":
        notes.append("the simulated drives follow the logged commands, although the robot was calibrated with "
                     "its drives following the measured track speeds (robot key simulator.drive_input)")
    h = DEFAULT_HORIZON if horizon_s == "auto" else float(horizon_s)
    model = MujocoBaseline(robot, log_ if test_log is None else concat_logs(log_, test_log), horizon_s=h)
    problem = model.problem(n_folds, n_train=None if test_log is None else log_.n_samples)
    if model.left_out:
        notes.append(f"{len(model.left_out)} of {len(model.left_out) + len(model.ws)} windows left out (starting at "
                     + ", ".join(f"t = {b['t0']:.2f} s" for b in model.left_out) + f"): {left_out_counts(model.left_out)}"
                     + "".join(f"; {kind}: {why}" for kind, why in (("against", AGAINST_WHY), ("stuck", STUCK_WHY))
                               if any(b["kind"] == kind for b in model.left_out)))
        log.warning("diagnose %s: %s", src, notes[-1])
    return model, problem, notes


def _simulator_warnings(model: Baseline, problem: Problem, steps: list[Step], base_err: np.ndarray,
                        min_gain: float) -> dict | None:
    """diagnosis.json's record of the simulator's warnings (docs/reference/formats/diagnosis-json.md):
    which windows, which simulations and warnings, which windows were left out (those whose
    baseline simulation warned: no prediction to score), and the first step's answer with and
    without every window that warned; None when the baseline simulates nothing."""
    if model.name != "mujoco":
        return None
    records = model.simulator_warnings()
    by_window: dict = {}
    for r in records:
        by_window.setdefault(r["window"], []).append(r)
    t0 = problem.data.t[problem.starts]
    left_out = ~problem.valid_mask
    windows = [{"window": int(w), "t0": float(t0[w]), "simulations": sorted({x["simulation"] for x in rs_}),
                "warnings": sorted({x["warning"] for x in rs_}), "left_out": bool(left_out[w])}
               for w, rs_ in sorted((k, v) for k, v in by_window.items() if k is not None)]
    out = {"simulations_warned": len({(r["window"], r["simulation"]) for r in records}), "windows": windows,
           "outside_windows": sorted({f"{r['simulation']}: {r['warning']}" for r in by_window.get(None, [])}),
           "left_out": sum(w["left_out"] for w in windows)}
    warned = np.zeros(problem.starts.size, bool)
    warned[[w["window"] for w in windows]] = True
    warned = warned[problem.scored]
    if steps and warned.any():
        both = [first_cause(steps[0], problem, base_err, keep, min_gain) for keep in (np.ones_like(warned), ~warned)]
        out["answer"] = {"with_warned_windows": {"cause": both[0][0], "gain": both[0][1], "windows": int(warned.size)},
                         "without_warned_windows": {"cause": both[1][0], "gain": both[1][1],
                                                    "windows": int((~warned).sum())},
                         "changes": both[0][0] != both[1][0]}
    return out


def _not_identifiable(model: Baseline, names: list[str], problem: Problem) -> dict[str, str]:
    """The effects among ``names`` that the baseline ``model`` cannot test, or this log cannot
    identify, and why."""
    data = problem.data
    skipped = {}
    turning = float(np.mean(np.abs(rs.turn_ratio(data.cmd)) > 0.05))
    lat = model.lateral_acceleration(problem) if "friction_scale" in names else None
    for n in names:
        e = EFFECTS[n]
        if n in model.untestable or n not in model.vocabulary:
            skipped[n] = model.untestable.get(n, f"the {model.noun} cannot simulate it")
        elif e.kind == "ground" and turning < MIN_TURNING:
            skipped[n] = (f"the log has no turning ({100 * turning:.1f} % of samples with |turn ratio| > 0.05): ground "
                          "effects change the motion only in turns (straight driving sticks), not identifiable")
        elif n == "friction_scale" and lat is not None and lat / (model.robot.mu * G) < MIN_LATERAL:
            skipped[n] = (f"lateral acceleration at most {lat / (model.robot.mu * G):.3f} mu g: the friction level does "
                          "not change the motion at these speeds, not identifiable")
        elif n == "drive_turn_limit" and turning < MIN_TURNING:
            skipped[n] = "the log has no turning: a turn limit cannot show"
    return skipped


def write_outputs(diagnosis: Diagnosis, out_dir: str | os.PathLike) -> None:
    """Write DIR/diagnosis.json and DIR/report.html (each atomically), whatever the baseline."""
    t0 = time.perf_counter()
    out = Path(out_dir)
    report = build_report(diagnosis)  # everything is built before anything is written
    diagnosis.timings["report"] = time.perf_counter() - t0
    text = json.dumps(json_value(diagnosis.to_json()), indent=2, allow_nan=False) + "\n"
    html = report.to_html()
    make_output_dir(out)
    atomic_write_text(out / "report.html", html)
    atomic_write_text(out / "diagnosis.json", text)
