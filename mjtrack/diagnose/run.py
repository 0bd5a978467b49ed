"""``diagnose(log, robot)``: symptom -> cause(s) -> gain, and its outputs (docs/reference/formats/diagnosis-json.md).

Stages (timed in ``Diagnosis.timings``):
1. prepare: drive data, the horizon (:func:`choose_horizon`), folds, blocks, windows, the
   baseline (:func:`make_baseline`, the one place where it is chosen) and what can be identified;
2. selection: forward selection over all effects, scored on held-out folds (or on a test log)
   (:func:`mjtrack.diagnose.select.forward_select`);
3. outputs: diagnosis.json (:class:`mjtrack.diagnose.result.Diagnosis`) and report.html;
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
from mjtrack.diagnose.confirm import confirm as confirm_mujoco
from mjtrack.diagnose.effects import EFFECTS
from mjtrack.diagnose.fit import Problem
from mjtrack.diagnose.mujoco_baseline import CHANGES as MJ_CHANGES
from mjtrack.diagnose.mujoco_baseline import MujocoBaseline, choose_simulator
from mjtrack.diagnose.report import build_report
from mjtrack.diagnose.result import Diagnosis, extended_robot
from mjtrack.diagnose.select import forward_select
from mjtrack.diagnose.surrogate_baseline import SurrogateBaseline
from mjtrack.diagnose.vocabulary import canonical_effects
from mjtrack.errors import InputError
from mjtrack.io.atomic import atomic_write_text, make_output_dir
from mjtrack.io.logs import DriveLog
from mjtrack.io.robot import G, Robot
from mjtrack.sim.config import robot_sim_settings
from mjtrack.sim.rollout import summarised_mujoco_warnings
from mjtrack.sim.windows import AGAINST_WHY, STUCK_WHY, left_out_counts, measured_drive_log

log = logging.getLogger(__name__)

MIN_TURNING = 0.02  # fraction of samples with |turn ratio| > 0.05 below which ground effects are not tested
MIN_LATERAL = 0.02  # max |a_lat|/(mu g) below which friction_scale is not tested
DEFAULT_HORIZON = 2.0  # [s]
BASELINES = ("auto", "mujoco", "surrogate", "kinematic")
# surrogate-ranked effects the MuJoCo baseline fits (plus its own ground effects); None: every one.
# Not screened by default: the surrogate cannot see every effect MuJoCo can (on a MuJoCo log whose
# tracks ran at 0.92 of the command it ranked lag, delay and friction first, and the diagnosis named
# nothing; fitting every candidate named the speed scale, 0.92, at about 1.7 times the time)
MUJOCO_SCREEN: int | None = None
ROBOT_KEYS = ("track_gauge", "track_length", "track_width", "mass", "cg_x", "cg_y", "cg_z", "mu", "mu_left", "mu_right")

__all__ = ["Diagnosis", "diagnose", "extended_robot", "write_outputs", "choose_horizon", "make_baseline",
           "speed_timing", "noise_floor", "concat_logs", "BASELINES"]


def choose_baseline(robot: Robot) -> str:
    """"coulomb" when the description gives the contact length (or was built in code), else "kinematic"."""
    return "coulomb" if robot.provided is None or "track_length" in robot.provided else "kinematic"


def make_baseline(name: str, robot: Robot, data: rs.DriveData, starts: np.ndarray, ends: np.ndarray, *,
                  transient: bool | str = "auto") -> tuple[SurrogateBaseline, str, list[str]]:
    """The surrogate baseline of ``name``: returns (model, why it was chosen, notes).

    ``name``: "surrogate" (the rigid-track Coulomb surrogate when the description gives the contact
    length, else the kinematic model, said in a note), "kinematic" (the kinematic model 2.1), or
    "auto" (the MuJoCo robot could not be built: as "surrogate"). ``transient``: see :func:`diagnose`."""
    if name not in BASELINES:
        raise InputError(f"diagnose: unknown baseline {name!r} (known: {', '.join(BASELINES)})")
    notes = []
    if name == "kinematic":
        base, why = "kinematic", "kinematic: requested"
    else:
        base = choose_baseline(robot)
        why = (f"{name}: the rigid-track Coulomb surrogate (the description gives the contact length)" if base == "coulomb"
               else f"{name}: the kinematic model (the description lacks the contact length the Coulomb surrogate needs)")
    causal = speed_timing(data)
    model = SurrogateBaseline(robot, base, transient=transient is True, causal_speeds=causal)
    if transient == "auto" and base == "coulomb":
        with_tr = SurrogateBaseline(robot, base, transient=True, causal_speeds=causal)
        rmse = [float(np.sqrt(np.mean(np.sum(rs.window_errors(m.surrogate.twist(data, data.cmd), data.step_dt(),
                                                                  data.poses, starts, ends)[:, :2] ** 2, 1))))
                for m in (model, with_tr)]
        if rmse[1] < rmse[0]:
            model = with_tr
        log.debug("diagnose: baseline without / with transients %.4g / %.4g m", *rmse)
    if model.transient:
        notes.append("the baseline includes the friction-limited transient after speed changes (the rigid body "
                     "follows its tracks as fast as the track friction lets it, straight and in yaw)"
                     + (f": it predicts this log better than the steady-state baseline ({rmse[1]:.3g} vs {rmse[0]:.3g} m)"
                        if transient == "auto" else ""))
    if base == "kinematic" and name != "kinematic":
        notes.append("the robot description lacks " + ", ".join(k for k in ("track_length", "mass", "mu")
                                                                 if robot.provided is not None and k not in robot.provided)
                     + f": the baseline is the kinematic model (2.1); ground effects use the Coulomb response of an "
                       f"assumed contact length L = {robot.track_length:g} m")
    return model, why, notes


def choose_horizon(data: rs.DriveData, requested: float | str = "auto") -> tuple[float, str | None]:
    """The prediction horizon [s] and a note when it was adapted to the log.

    A number is used as given. "auto": 2 s when the segments allow it, else the longest horizon
    the segments allow: 3/4 of the median segment length (every segment then starts windows at a
    quarter of its samples; e.g. 1.45 s for the 1.95 s segments of a DRIVE log), rounded down
    to 0.05 s."""
    if requested != "auto":
        return float(requested), None
    cuts = np.flatnonzero(data.seg[1:] != data.seg[:-1]) + 1
    lens = np.array([data.t[hi - 1] - data.t[lo] for lo, hi in zip(np.r_[0, cuts], np.r_[cuts, data.n])])
    allowed = 0.75 * float(np.median(lens))
    if allowed >= DEFAULT_HORIZON:
        return DEFAULT_HORIZON, None
    h = max(np.floor(allowed / 0.05) * 0.05, 0.05)
    return float(h), (f"horizon {h:g} s instead of {DEFAULT_HORIZON:g} s: the log's segments are {np.median(lens):.3g} s "
                      f"long (median of {lens.size}); the longest horizon they allow is 3/4 of that, so that every "
                      "segment starts windows at a quarter of its samples")


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


def concat_logs(a: DriveLog, b: DriveLog) -> DriveLog:
    """Log ``a`` followed by log ``b`` as one log whose segments are theirs (a column that only one
    of them has is NaN, missing, in the other); its source is ``a``'s."""
    cols = {}
    for name in ("t", "v_left_cmd", "v_right_cmd", "x", "y", "yaw", "v_left", "v_right", "vx", "vy", "wz"):
        if getattr(a, name) is None and getattr(b, name) is None:
            continue
        cols[name] = np.concatenate([np.full(x.n_samples, np.nan) if getattr(x, name) is None else getattr(x, name)
                                     for x in (a, b)])
    seg = [np.repeat(np.arange(len(x.segment_slices())), [s.stop - s.start for s in x.segment_slices()]) for x in (a, b)]
    cols["window"] = np.concatenate([seg[0], seg[1] + seg[0][-1] + 1])
    return DriveLog.from_columns(cols, source=a.source)


def same_robot(a: Robot, b: Robot) -> list[str]:
    """Keys on which two descriptions of a robot disagree (both given), empty when they agree."""
    out = []
    for k in ROBOT_KEYS:
        given = (a.provided is None or k in a.provided) and (b.provided is None or k in b.provided)
        va, vb = getattr(a, k), getattr(b, k)
        if given and va != vb and not (va is not None and vb is not None and abs(float(va) - float(vb)) <= 1e-9 * (1 + abs(float(va)))):
            out.append(f"{k} {va} vs {vb}")
    return out


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
            ``max_effects``: 3 for the surrogates, 1 for MuJoCo, whose every step costs ~8 window
            passes per remaining candidate).
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
    src = log_.source or "drive log"
    with summarised_mujoco_warnings(f"diagnose {src}", log):
        return _diagnose(log_, robot, horizon_s=horizon_s, n_folds=n_folds, min_gain=min_gain, baseline=baseline,
                         effects=effects, max_fit_windows=max_fit_windows, max_effects=max_effects, confirm=confirm,
                         quiet=quiet, transient=transient, test_log=test_log, test_robot=test_robot, screen=screen,
                         drive_input=drive_input)


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
        differ = same_robot(robot, test_robot)
        if differ:
            raise InputError(f"{test_log.source or 'test log'}: another robot than {src}'s ({'; '.join(differ)}): "
                             "a test log must come from the same robot")
    if drive_input not in (None, "commanded", "measured"):
        raise InputError(f"diagnose: drive input {drive_input!r} is neither 'commanded' nor 'measured'")
    requested, mujoco_note, screened = baseline, None, None
    if baseline in ("auto", "mujoco"):
        use_mujoco, mujoco_note = choose_simulator(baseline, robot)
        baseline = "mujoco" if use_mujoco else "surrogate"
    if baseline == "mujoco":
        if effects is None and screen is not None:
            sur = diagnose(log_, robot, horizon_s=horizon_s, n_folds=n_folds, min_gain=min_gain, baseline="surrogate",
                           quiet=True, test_log=test_log)
            ranked = [r.effect.name for r in sorted(sur.results, key=lambda r: r.after) if r.effect.name in MJ_CHANGES]
            screened = ranked[:screen]
            effects = screened + [n for n in ("ground_anisotropy", "road_wheels") if n not in screened]
        clock["screen"] = time.perf_counter()
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
        choice = {"requested": requested, "chosen": "mujoco", "why": mujoco_note, "screened_by_surrogate": screened}
        if model.left_out:
            notes.append(f"{len(model.left_out)} of {len(model.left_out) + len(model.ws)} windows left out (starting at "
                         + ", ".join(f"t = {b['t0']:.2f} s" for b in model.left_out) + f"): {left_out_counts(model.left_out)}"
                         + "".join(f"; {kind}: {why}" for kind, why in (("against", AGAINST_WHY), ("stuck", STUCK_WHY))
                                   if any(b["kind"] == kind for b in model.left_out)))
            log.warning("diagnose %s: %s", src, notes[-1])
    else:
        problem, notes, why = _surrogate_problem(log_, robot, horizon_s=horizon_s, n_folds=n_folds, baseline=baseline,
                                                 max_fit_windows=max_fit_windows, transient=transient,
                                                 test_log=test_log)
        model = problem.baseline
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
    skipped = _not_identifiable(names, problem)
    if np.mean(np.abs(rs.turn_ratio(data.cmd)) > 0.05) < MIN_TURNING:
        notes.append("no turning in the log: only the input effects (speed scale, lag, delay, limit) can be tested")
    clock["prepare"] = time.perf_counter()
    tested = [EFFECTS[n] for n in names if n not in skipped]
    steps, chosen = forward_select(problem, tested, n_folds=n_folds_used, min_gain=min_gain,
                                   max_effects=model.max_effects if max_effects is None else max_effects, quiet=quiet)
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
    diag.timings = {"prepare": clock["prepare"] - clock.get("screen", clock["start"]),
                    "selection": clock["selection"] - clock["prepare"]}
    if "screen" in clock:
        diag.timings["screen"] = clock["screen"] - clock["start"]
    if confirm or model.name == "mujoco":  # (MuJoCo throughout: confirm() says so)
        diag.confirmation = confirm_mujoco(diag)
        diag.timings["mujoco"] = time.perf_counter() - clock["selection"]
    log.info("diagnose %s: cause %s (%s)", src, diag.cause, diag.timings)
    return diag


def _surrogate_problem(log_: DriveLog, robot: Robot, *, horizon_s, n_folds, baseline, max_fit_windows, transient,
                       test_log) -> tuple[Problem, list[str], str]:
    """The surrogate's problem (windows starting at every sample, folds of samples; with a test log:
    the log fold 1, the test log fold 0), its notes and why its model was chosen."""
    src = log_.source or "drive log"
    train_n = log_.n_samples
    data = rs.DriveData.from_log(log_ if test_log is None else concat_logs(log_, test_log))
    horizon_s, horizon_note = choose_horizon(rs.DriveData.from_log(log_), horizon_s)
    if test_log is not None:
        sample_fold = (np.arange(data.n) < train_n).astype(np.int64)
        n_folds_used = 2
    else:
        sample_fold = st.contiguous_folds(data.n, n_folds, data.seg)
        n_folds_used = n_folds
    if rs.windows(data.t, data.seg, horizon_s)[0].size == 0:
        longest = max(float(data.t[data.seg == k][-1] - data.t[data.seg == k][0]) for k in np.unique(data.seg))
        raise InputError(f"{src}: no segment is as long as the {horizon_s:g} s horizon (longest {longest:.3g} s): "
                         "no prediction can be checked, nothing can be identified")
    starts, ends = rs.windows(data.t, data.seg * n_folds_used + sample_fold, horizon_s)
    fold = sample_fold[starts]
    missing = sorted(set(range(n_folds_used)) - set(fold.tolist()))
    if missing:
        if test_log is not None:
            which = test_log.source or "test log" if 0 in missing else src
            raise InputError(f"{which}: no segment is as long as the {horizon_s:g} s horizon: nothing to "
                             + ("score on" if 0 in missing else "fit on"))
        raise InputError(f"{src}: too short to cross-validate at a {horizon_s:g} s horizon: fold(s) {missing} of "
                         f"{n_folds} hold no complete window (give a longer log or a shorter --horizon)")
    stride = max(1, int(np.ceil(starts.size / max_fit_windows)))
    measured = speed_ok = None
    if data.meas is not None:
        speed_ok = np.all(np.isfinite(data.meas), axis=1)
        measured = np.where(np.isfinite(data.meas), data.meas, data.cmd)
    model, why, notes = make_baseline(baseline, robot, data, starts, ends, transient=transient)
    if horizon_note:
        notes.insert(0, horizon_note)
    if data.meas is not None:
        notes.append("measured track speeds present: input effects are fitted to them and must reduce their held-out "
                     "error (an input effect they contradict is refuted), ground effects are fitted with the model "
                     "driven by them; a speed sample at t is taken as "
                     + ("the speed just before the command of its row (causal)" if model.surrogate.causal_speeds else
                        "already the response to the command of its row (it fits the speeds better)"))
    sample_block = st.sample_blocks(data.t, data.seg * n_folds_used + sample_fold, horizon_s)
    problem = Problem(data=data, baseline=model, horizon_s=float(horizon_s), dt=data.step_dt(), starts=starts,
                      ends=ends, fold=fold, sample_fold=sample_fold, fit_windows=np.arange(0, starts.size, stride),
                      measured=measured, speed_ok=speed_ok, sample_block=sample_block,
                      score_folds=(0,) if test_log is not None else None)
    return problem, notes, why


def _not_identifiable(names: list[str], problem: Problem) -> dict[str, str]:
    """The effects among ``names`` that the baseline cannot test, or this log cannot identify, and why."""
    model, data = problem.baseline, problem.data
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
        elif n == "yaw_rate_limit" and turning < MIN_TURNING:
            skipped[n] = "the log has no turning: a yaw-rate limit cannot show"
    return skipped


def write_outputs(diagnosis: Diagnosis, out_dir: str | os.PathLike) -> None:
    """Write DIR/diagnosis.json and DIR/report.html (each atomically), whatever the baseline."""
    t0 = time.perf_counter()
    out = Path(out_dir)
    report = build_report(diagnosis)  # everything is built before anything is written
    diagnosis.timings["report"] = time.perf_counter() - t0
    text = json.dumps(diagnosis.to_json(), indent=2, allow_nan=False) + "\n"
    html = report.to_html()
    make_output_dir(out)
    atomic_write_text(out / "report.html", html)
    atomic_write_text(out / "diagnosis.json", text)
