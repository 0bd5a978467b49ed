"""``calibrate(train, robot)``: the MuJoCo robot fitted to a measured log, and what it got wrong.

Stages (timed):
1. windows of the training log (and of the test log), each simulated from its measured state with
   hidden states warmed up over the log's past where its segment allows
   (:mod:`mjtrack.sim.windows`);
2. the robot as described (every default it relies on named under ``assumed``) scored on them:
   errors at the horizon binned by curvature, speed, turn direction and time; steady-turn yaw
   ratio and ICRs measured against simulated;
3. the windowed fit (:mod:`mjtrack.calibrate.fit`, ``mujoco.sysid``) of every candidate
   parameter; the model-form error of the fit's simulator measured at the optimum (a finer
   simulator, a longer warm-up); what the log determines and what it says must change
   (:mod:`mjtrack.calibrate.identify`), the rest back at its described value; the kept ones
   fitted again;
4. the calibrated robot scored on the same windows and on the test log (never used in the fit);
   the causes of the improvement measured (:mod:`mjtrack.calibrate.causes`);
5. outputs: robot.json (complete, with the simulator settings the fit used), calibration.json,
   report.html (:mod:`mjtrack.calibrate.report`).
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import math
import time
from dataclasses import dataclass
from typing import TYPE_CHECKING, Callable

import numpy as np

from mjtrack.calibrate.causes import (Cause, find_causes, implausibility, on_bound, summary, traction_defaults,
                                     traction_limit)
from mjtrack.calibrate.drivetrain import chain_robot, fit_chain, has_measured_speeds, predicted_drive_log
from mjtrack.calibrate.identify import Verdict, fmt_value
from mjtrack.calibrate.params import (FRAMED_PARAMS, described_values, geometry_name, parse_names, specs_for,
                                     start_values, window_params)
from mjtrack.calibrate.start import suggested_length
from mjtrack.calibrate.turns import TurnMatch, match_turns, turn_candidates
from mjtrack.errors import InputError
from mjtrack.io.jsonfile import json_value
from mjtrack.io.logs import DriveLog
from mjtrack.io.robot import DRIVE_SIDE_KEYS, Robot
from mjtrack.progress import clock_text
from mjtrack.sim.config import SimConfig, sim_config
from mjtrack.windows import (DRIVE_DEFAULTS, WARMUP_S, WindowSet, geometry_robot,
                             left_out_counts, make_windows, measured_drive_log, measured_window_poses, without_contradicting)

if TYPE_CHECKING:  # MuJoCo is loaded by the functions that simulate, not by importing calibrate
    from mjtrack.sim.windows import WindowSim

from mjtrack.calibrate.measures import class_gap_interval, command_runs, measured_speeds, turn_measures
from mjtrack.calibrate.result import Calibration, Scored, drive_caps, write_outputs

from mjtrack.calibrate.rounds import MAX_ROUNDS, MAX_ROUNDS_LIMIT, Fitted, Fitter, Meter, expected_passes, fit_attempt

log = logging.getLogger(__name__)

#: robot keys whose defaults a description may silently rely on (named under ``assumed``)
DESCRIBED = ("track_length", "track_width", "mass", "cg_x", "cg_y", "cg_z", "mu", "sprocket_radius", "rolling_resistance")
#: windows a fit uses by default, spread evenly over the log: a fit's time grows with them (about
#: 250 evaluations of every fit window), its intervals narrow only with their square root
FIT_WINDOWS = 60


# -- the calibration -----------------------------------------------------------------------------
def assumed_values(robot: Robot, names: list[str]) -> dict[str, str]:
    """Every value the description did not give that the simulation uses, and where it came from."""
    provided = robot.provided if robot.provided is not None else frozenset(DESCRIBED)
    out = {}
    for k in DESCRIBED:
        if k not in provided:
            v = getattr(robot, k)
            out[k] = f"not in the robot description: default {v:g}" + (" (start value; fitted)" if k in names else "")
    for k in DRIVE_DEFAULTS:
        if k not in provided:
            v = getattr(robot, k, None)
            what = "the simulator's default drive" if v is None else f"default {v:g}"
            out[k] = f"not in the robot description: {what}" + (" (fitted)" if k in names else "")
    for k, v in robot.extra.items():
        if isinstance(k, str) and k.startswith("source_") and isinstance(v, str):
            out[k.removeprefix("source_")] = v
    return out


def undescribed(robot: Robot, names: list[str]) -> tuple[str, ...]:
    """The candidates among ``names`` that are robot keys the description does not give (a
    default stands in for each; none when the robot was built in full, in code)."""
    if robot.provided is None:
        return ()
    keys = set(DESCRIBED) | set(DRIVE_DEFAULTS) | {geometry_name(robot)}
    return tuple(n for n in names if n in keys and n not in robot.provided)


def calibrated_robot(robot: Robot, values: dict[str, float], config: SimConfig,
                     drive_input: str = "commanded") -> Robot:
    """The robot with calibrated values written into its description (friction per side, centre
    of mass, contact length, drive keys, ground parameters) and, under ``simulator``, the settings
    of the simulator they were fitted with (with the drive input when it was not the commands). A
    slope is the log's ground, not the robot's: it stays in calibration.json."""
    wp = window_params({k: v for k, v in values.items() if k not in ("slope_x", "slope_y")}, robot)
    r = geometry_robot(robot, wp)
    fields = {k: wp[k] for k in ("mu", "mu_left", "mu_right", "cg_x", "cg_y", "rolling_resistance") if k in wp}
    if "mu_left" in fields and "mu_right" in fields:
        fields["mu"] = math.sqrt(fields["mu_left"] * fields["mu_right"])
        if math.isclose(fields["mu_left"], fields["mu_right"], rel_tol=1e-12):
            fields["mu_left"] = fields["mu_right"] = None
    if "lateral_ratio" in wp:
        fields["ground"] = type(r.ground)(r.ground.model, tuple({**dict(r.ground.params),
                                                                  "lateral_ratio": wp["lateral_ratio"]}.items()))
    if "shear_modulus" in wp or "lateral_shear_ratio" in wp:
        # K > 0: the shear ground (from a Coulomb one too), with its ratio; K = 0: Coulomb, any ratio
        own = dict(r.ground.params) if r.ground.model == "shear" else {"shear_modulus": 0.0, "lateral_shear_ratio": 1.0}
        K = float(wp.get("shear_modulus", own["shear_modulus"]))
        ratio = float(wp.get("lateral_shear_ratio", own["lateral_shear_ratio"]))
        fields["ground"] = (type(r.ground)("shear", (("lateral_shear_ratio", ratio), ("shear_modulus", K))) if K > 0
                            else type(r.ground)("coulomb"))
    r = r.replace(**fields)
    extra = dict(r.extra)
    for k in DRIVE_DEFAULTS:
        if k in wp:
            if hasattr(r, k):
                r = r.replace(**{k: wp[k]})
            else:
                extra[k] = wp[k]
    extra["simulator"] = {"track_model": config.track_model, "n_rollers": int(config.n_rollers)}
    if drive_input != "commanded":  # what its drives followed in the fit: the MuJoCo diagnosis follows it too
        extra["simulator"]["drive_input"] = drive_input
    return dataclasses.replace(r, extra=extra)


def _score(sim: WindowSim, lg: DriveLog, ws: WindowSet, variants: list[dict], *, nthread: int,
           warmup_s: float, progress: Callable[[int], None] | None = None) -> list[Scored]:
    from mjtrack.calibrate.fit import windows_done
    from mjtrack.sim.windows import simulate_windows

    res = simulate_windows(sim, lg, ws, variants, nthread=nthread, warmup_s=warmup_s, progress=windows_done(progress))
    return [Scored.of(res, p) for p in range(len(variants))]


def calibrate(train: DriveLog, robot: Robot, *, test: DriveLog | None = None,
              names: str | list[str] | None = None, horizon_s: float = 2.0, n_rollers: int | None = None,
              max_iter: int = 8, nthread: int = 2, quiet: bool = True, train_path: str | None = None,
              test_path: str | None = None, warmup_s: float = WARMUP_S, drive_input: str = "auto",
              fit_windows: int | None = FIT_WINDOWS, keep_contradicting: bool = False,
              rounds: int = MAX_ROUNDS) -> Calibration:
    """Fit the MuJoCo robot to ``train`` (see the module docstring); bad input raises InputError.

    Args:
        train: the log to fit on.
        robot: its description (the described values are where every parameter starts and where
            each one the log does not determine stays).
        test: a log of the same robot, scored but never fitted.
        names: parameters the fit may move (``--params`` text or a list; default
            :func:`mjtrack.calibrate.params.default_names`).
        horizon_s: window length [s].
        n_rollers: contact rollers per track of the fit's simulator (default: the robot's
            ``simulator`` setting, else 10).
        max_iter: Levenberg-Marquardt iterations of the first fit (the refit gets half).
        nthread: rollout threads (results do not depend on it).
        warmup_s: history [s] over which each window's hidden states are warmed up (0: none).
        drive_input: ``"auto"`` (default): ``"fitted"`` when the log's measured track speeds show
            the robot's own speed controller capping its commands, else ``"commanded"``
            (:func:`auto_drive_input`); ``"commanded"``: the simulated drives follow the logged
            commands (the drive's lag, delay and speed scale are candidates); ``"measured"``: they
            follow the logged track speeds, for a robot whose own speed controller caps or shapes
            its commands in ways the drive keys do not describe; the contact, the speed scale
            (then the effective rolling radius over the nominal one) and the drives' force limit
            (how fast the simulated drives can follow the measured speeds) are calibrated;
            ``"fitted"``: the drivetrain (:mod:`mjtrack.calibrate.drivetrain`) fitted first to the
            log's measured track speeds and fixed, the contact then fitted as with ``"measured"``
            on the track speeds the fitted drivetrain predicts from the commands; the calibrated
            robot carries the drivetrain's keys and is driven by its commands. The mode used and
            why are kept in ``drive_input_mode`` and ``drive_input_why``.
        fit_windows: windows the fit uses, spread evenly over the log (None: every window); the
            errors before and after use every window, the causes the windows the fit used.
        keep_contradicting: keep the windows whose poses move against the tracks (by default they
            are left out of the fit and of every score, and listed under ``left_out``).
        rounds: at most this many refits after the first fit, each after what the log determines
            was decided again for every candidate (0 to 20); a fit that has not settled when they
            run out keeps the candidates it has not reached at their described values and says
            what the log points at. Each round costs about one refit of the kept parameters.
    """
    from mjtrack.sim.rollout import summarised_mujoco_warnings

    src = train_path or train.source or "train log"
    if isinstance(rounds, bool) or not isinstance(rounds, (int, np.integer)) or not 0 <= rounds <= MAX_ROUNDS_LIMIT:
        raise InputError(f"rounds must be a whole number from 0 to {MAX_ROUNDS_LIMIT}, got {rounds!r}")
    if drive_input not in DRIVE_INPUTS:
        raise InputError(f"drive_input must be one of {', '.join(DRIVE_INPUTS)}, got {drive_input!r}")
    drive_input, why = auto_drive_input(train, robot, names) if drive_input == "auto" else (drive_input, "asked for")
    mode = drive_input
    if drive_input == "measured":
        train = measured_drive_log(train, train_path or train.source or "train log")
        test = None if test is None else measured_drive_log(test, test_path or test.source or "test log")
        if names is None:  # the default candidates less the drive's timing, plus how hard the drives push
            names = [n for n in parse_names(None, robot, train) if n not in COMMAND_PARAMS] + list(MEASURED_PARAMS)
        elif isinstance(names, str):
            names = parse_names(names, robot, train)
        bad = [n for n in names if n in COMMAND_PARAMS]
        if bad:
            raise InputError(f"params={','.join(bad)}: describe when the drives follow their commands; with "
                             f"drive_input='measured' the drives follow the measured track speeds")
    chain = None
    if drive_input == "fitted":
        if not has_measured_speeds(train):
            raise InputError(f"{src}: drive_input='fitted' fits the drives to the log's measured track speeds "
                             "(columns v_left, v_right on most rows); the log has none")
        if names is not None and set(parse_names(names, robot, train) if isinstance(names, str) else names) & set(
                COMMAND_PARAMS):
            raise InputError(f"params={','.join(COMMAND_PARAMS)}: with drive_input='fitted' the drives' timing is "
                             "fitted to the measured track speeds first")
        chain, robot_in = fit_chain(train, robot, horizon_s=horizon_s), robot
        train, test, robot, names = _on_predicted_speeds(chain, train, test, robot, names)
        drive_input = "measured"  # the contact's fit: its drives follow the speeds the chain predicts
    with summarised_mujoco_warnings(f"calibrate {src}", log):  # one line, not one per diverged window
        cal = _calibrate(train, robot, test=test, names=names, horizon_s=horizon_s, n_rollers=n_rollers,
                         max_iter=max_iter, nthread=nthread, quiet=quiet, train_path=train_path,
                         test_path=test_path, warmup_s=warmup_s, drive_input=drive_input, fit_windows=fit_windows,
                         keep_contradicting=keep_contradicting, rounds=int(rounds))
    if chain is not None:
        rolling = cal.values["track_speed_scale"] if "track_speed_scale" in cal.changed else 1.0
        calibrated = chain_robot(cal.calibrated, chain.values, rolling)
        simulator = {k: v for k, v in calibrated.extra.get("simulator", {}).items() if k != "drive_input"}
        # the calibrated robot is driven by its commands, through the fitted chain it now carries
        cal.robot, cal.drive_input, cal.drivetrain = robot_in, "commanded", chain
        cal.calibrated = dataclasses.replace(calibrated, extra={**calibrated.extra, "simulator": simulator})
        cal.sentence = (f"The drives were fitted first to the log's measured track speeds (wheel-speed RMS "
                        f"{_mean2(chain.rms_before):.3f} m/s as described, {_mean2(chain.rms_after):.3f} m/s fitted) "
                        f"and the contact to the poses with the drives so fixed. " + cal.sentence)
    cal.drive_input_mode, cal.drive_input_why = mode, why
    cal.sentence += cal.evidence()  # what the measured track speeds show
    return cal


def _mean2(pair) -> float:
    return float(math.sqrt((pair[0] ** 2 + pair[1] ** 2) / 2))


def _on_predicted_speeds(chain, train: DriveLog, test: DriveLog | None, robot: Robot, names):
    """The contact's fit with the drivetrain fixed from the measured speeds: both logs driven by the
    track speeds the fitted chain predicts from their commands, the robot without a drivetrain of its
    own (the chain has it all; the drives' force limit stays), the candidates those of
    ``--drive-input measured`` (the speed scale is then the effective rolling radius)."""
    train = predicted_drive_log(train, chain.values)
    test = None if test is None else predicted_drive_log(test, chain.values)
    plain = dict.fromkeys(DRIVE_SIDE_KEYS)  # every stage of the chain off: its prediction already has them
    robot = robot.replace(drive_lag=0.0, drive_delay=0.0, track_speed_scale=1.0, drive_turn_scale=1.0, **plain)
    if names is None:
        names = [n for n in parse_names(None, robot, train) if n not in COMMAND_PARAMS] + list(MEASURED_PARAMS)
    return train, test, robot, names


DRIVE_INPUTS = ("auto", "commanded", "measured", "fitted")
#: [m/s] measured track speeds within this of the commands on every row are copies of them
COPY_TOLERANCE = 1e-6


def auto_drive_input(train: DriveLog, robot: Robot, names) -> tuple[str, str]:
    """What ``drive_input="auto"`` (the default) uses on ``train``, and why in words: ``"fitted"``
    when the log has measured track speeds (most rows) that are not copies of its commands, show
    the robot's own speed controller capping the commands (:func:`mjtrack.calibrate.result.drive_caps`:
    a side's speed, the turn or the mean speed saturates, which no candidate of the commanded
    drive describes) and the candidates do not name the drive's timing (a user asking for
    ``drive_lag`` wants it fitted to the poses); else ``"commanded"``: the drive's lag, delay and
    speed scale are then candidates of the pose fit, which the MuJoCo drives follow exactly."""
    if not has_measured_speeds(train):
        return "commanded", "auto: the log has no measured track speeds"
    meas = np.stack([train.v_left, train.v_right], -1).astype(float)
    cmd = np.stack([train.v_left_cmd, train.v_right_cmd], -1).astype(float)
    ok = np.all(np.isfinite(meas), axis=1)
    gap = float(np.max(np.abs(meas[ok] - cmd[ok])))
    if gap <= COPY_TOLERANCE:
        return "commanded", "auto: the log's measured track speeds are copies of its commands"
    if names is not None and set(parse_names(names, robot, train) if isinstance(names, str) else names) & set(
            COMMAND_PARAMS):
        return "commanded", f"auto: the parameters name the drive's timing ({', '.join(COMMAND_PARAMS)})"
    rms = float(np.sqrt(np.mean((meas[ok] - cmd[ok]) ** 2)))
    caps = drive_caps(train)
    if caps:
        return "fitted", (f"auto: the log's measured track speeds ({rms:.3g} m/s RMS from the commands) show that {caps}: "
                          "the drivetrain is fitted to them first")
    return "commanded", (f"auto: the log's measured track speeds ({rms:.3g} m/s RMS from the commands) show no speed "
                         "controller capping the commands: the drive's lag, delay and speed scale are fitted to the "
                         "poses with the other candidates")


# when the drives follow their commands: not candidates with --drive-input measured. The speed scale
# stays one: against measured track speeds (wheel or sprocket turn rate times its nominal radius) it
# is the effective rolling radius over the nominal one (a loaded tyre rolls on less than its radius)
COMMAND_PARAMS = ("drive_lag", "drive_delay")
# and a candidate then: the simulated drives follow the measured speeds only as fast as their force
# limit lets them accelerate the drivetrain's inertia; the default limit (SimConfig.torque_limit over
# the wheel radius) lets a 0.3 m wheel of a 260 kg robot change speed at about 1 m/s^2, where the
# Warthog's measured wheels reverse at 4 m/s^2 and more
MEASURED_PARAMS = ("drive_force_limit",)


def fit_index_of(ws: WindowSet, n: int | None) -> np.ndarray:
    """Indices of at most ``n`` of the windows, evenly spread over them in order (all when None or fewer)."""
    if n is None or len(ws) <= n:
        return np.arange(len(ws))
    if n < 1:
        raise InputError(f"fit_windows must be >= 1, got {n!r}")
    return np.unique(np.round(np.linspace(0, len(ws) - 1, int(n))).astype(int))


@dataclass
class _Problem:
    """What the stages share: the logs, their windows, the candidates and where they start."""

    train: DriveLog
    test: DriveLog | None
    robot: Robot
    src: str
    test_src: str | None
    config: SimConfig
    names: list[str]
    start: dict[str, float]
    described: dict[str, float]
    ws: WindowSet
    tws: WindowSet | None
    left_out: dict[str, list[dict]]
    fixed: dict[str, float]
    assumed: dict[str, str]


class _Clock:
    """Wall clock of each stage (``Calibration.timings``, seconds)."""

    def __init__(self) -> None:
        self.t0 = time.perf_counter()
        self.timings: dict[str, float] = {}

    @contextlib.contextmanager
    def stage(self, name: str):
        t = time.perf_counter()
        try:
            yield
        finally:
            self.timings[name] = self.timings.get(name, 0.0) + time.perf_counter() - t
            log.info("calibrate: %s %.1f s", name, self.timings[name])

    def total(self) -> dict[str, float]:
        self.timings["total"] = time.perf_counter() - self.t0
        return self.timings


def _prepare(train: DriveLog, robot: Robot, test: DriveLog | None, names, *, horizon_s: float, n_rollers,
             keep_contradicting: bool, src: str, test_src: str | None) -> _Problem:
    """The simulator settings, the candidates and their start and described values, the windows
    of both logs (less those the ground cannot explain), what is fixed and what is assumed."""
    config = sim_config(None, robot=robot)
    if config.track_model != "rollers":
        raise InputError("calibrate: the robot's simulator is surfacevel; windows restart the robot through "
                         "mujoco.rollout, which drives actuators (the rollers track model)")
    if n_rollers is not None:
        config = config.replace(n_rollers=int(n_rollers))
    # a list is checked as --params is: an empty one or an unknown name is the caller's error, not a crash
    names = parse_names(names if isinstance(names, str) or names is None else ",".join(names), robot, train)
    ws = make_windows(train, horizon_s)
    if len(ws) == 0:
        longest = max(float(train.t[s][-1] - train.t[s][0]) for s in train.segment_slices())
        raise InputError(f"{src}: too short for one {horizon_s:g} s window (longest segment {longest:.3g} s)")
    tws = None
    if test is not None:
        tws = make_windows(test, horizon_s)
        if len(tws) == 0:
            raise InputError(f"{test_src}: too short for one {horizon_s:g} s window")
    left_out: dict[str, list[dict]] = {}
    if not keep_contradicting:
        ws, left_out["train"] = _without_contradicting(train, ws, src, robot.track_gauge)
        if test is not None:
            tws, left_out["test"] = _without_contradicting(test, tws, test_src, robot.track_gauge)
    fixed = {"track_gauge": robot.track_gauge}
    for k in ("track_length", "mass", "sprocket_radius", "cg_z", "track_width"):
        if k not in names and (robot.provided is None or k in robot.provided):
            fixed[k] = getattr(robot, k)
    start, assumed = start_values(robot, names, config), assumed_values(robot, names)
    key = geometry_name(robot)
    if key in names and robot.provided is not None and key not in robot.provided:
        # a length the description does not give starts where the log's steady turns put it, not at
        # the default (mjtrack.calibrate.start): the answer must not hang on a default
        s = suggested_length(train, ws, robot, measured_window_poses(train, ws), measured_speeds(train, ws),
                             specs_for(robot)[key])
        if s.value is not None:
            start[key] = s.value
        assumed[key] = ("not in the robot description: " + (f"start value from the log, {s.why}" if s.value is not None
                        else f"default {robot.contact_length:g} ({s.why})") + " (fitted)")
    return _Problem(train=train, test=test, robot=robot, src=src, test_src=test_src, config=config,
                    names=list(names), start=start, described=described_values(robot, names, config), ws=ws, tws=tws,
                    left_out=left_out, fixed=fixed, assumed=assumed)


#: friction levels a fit starts from again when its first answer has a changed value on a bound
#: (:func:`_guarded_fit`): the cost seen from a start misleads here -- on the Warthog log, from the
#: public description (260 kg, mu 0.5) the fit ended with cg_y on its bound and a left/right friction
#: split, 0.744 m on the training windows, while from mu 1.0 it ended at 0.624 m with neither, though
#: the start at 0.5 cost less than the one at 1.0 (benchmarks/real_robots.py --starts)
FRICTION_STARTS = (0.5, 1.0)
#: a restart is the answer only when it lowers the training RMS by more than this share: attempts
#: that reach one basin differ by the optimiser's tolerance (the Husky's three starts: 0.2192 m each)
RESTART_GAIN = 0.01


def on_bounds(values: dict[str, float], changed: list[str], specs: dict) -> list[str]:
    """The changed parameters whose value ended on a bound of its range (:func:`on_bound`)."""
    return [n for n in changed if on_bound(values[n], specs[n].lo, specs[n].hi, specs[n].resolution)]


def _guarded_fit(fx: Fitter, pb: _Problem, fit_windows: int | None, before: Scored, clock: _Clock, kw: dict
                 ) -> tuple[Fitted, list[str], dict, Scored, list[dict]]:
    """The fit held on every training window (:func:`_guarded_once`), and started again from other
    friction levels (:data:`FRICTION_STARTS`) when its answer has a changed value on a bound: a value
    on a bound is either something no candidate describes or a fit that descended into the wrong
    basin, and only a descent from elsewhere tells the two apart. The answer is the attempt that
    fits every training window best, by more than :data:`RESTART_GAIN` of the first's RMS; the
    attempts are returned as records (start friction, the training RMS, the values on a bound,
    whether it was kept, the windows it simulated)."""
    fit_index = fit_index_of(pb.ws, fit_windows)
    simulated = fx.meter.simulated
    best = _guarded_once(fx, pb, fit_index, pb.start, before, clock, kw)
    cost = [fx.meter.simulated - simulated]
    bound = on_bounds(best[0].values, best[1], fx.specs)
    if not bound or "mu" not in pb.names:
        return (*best, [])
    spec = fx.specs["mu"]
    tries = [(float(pb.start["mu"]), best, bound)]
    for mu in FRICTION_STARTS:
        if abs(mu - pb.start["mu"]) <= spec.resolution:
            continue
        log.info("calibrate: %s ended on a bound; fitting again from friction %g", ", ".join(bound), mu)
        fx.meter.say(f"calibrate: {', '.join(bound)} ended on a bound; fitting again from friction {mu:g}")
        simulated = fx.meter.simulated
        att = _guarded_once(fx, pb, fit_index, {**pb.start, "mu": mu}, before, clock, kw)
        cost.append(fx.meter.simulated - simulated)
        tries.append((mu, att, on_bounds(att[0].values, att[1], fx.specs)))
    k = min(range(len(tries)), key=lambda i: tries[i][1][3].rms)
    if tries[k][1][3].rms >= (1 - RESTART_GAIN) * tries[0][1][3].rms:
        k = 0  # no restart fits better than the optimiser's tolerance: the first answer stands
    records = [{"mu_start": mu, "train_rms_m": a[3].rms, "on_bound": b, "kept": i == k, "simulated_windows": n}
               for i, ((mu, a, b), n) in enumerate(zip(tries, cost))]
    return (*tries[k][1], records)


def restart_sentence(restarts) -> str:
    """The friction restarts of :func:`_guarded_fit` in words ("" without any)."""
    if not restarts:
        return ""
    first, kept = restarts[0], next(r for r in restarts if r["kept"])
    if kept is first:
        starts = " and ".join(f"{r['mu_start']:g}" for r in restarts[1:])
        rms = ", ".join(f"{r['train_rms_m']:.3g}" for r in restarts[1:])
        return (f" The fit ended with {', '.join(first['on_bound'])} on a bound of its range; started again from "
                f"friction {starts}, it fit the training windows no better ({rms} m against "
                f"{first['train_rms_m']:.3g} m), so the bound is not the start's.")
    rest = ", none on a bound" if not kept["on_bound"] else f", with {', '.join(kept['on_bound'])} on a bound"
    return (f" From friction {first['mu_start']:g} the fit ended with {', '.join(first['on_bound'])} on a bound of "
            f"its range ({first['train_rms_m']:.3g} m on the training windows); started again from friction "
            f"{kept['mu_start']:g} it fits them better ({kept['train_rms_m']:.3g} m{rest}), and that is the answer.")


def _guarded_once(fx: Fitter, pb: _Problem, fit_index: np.ndarray, start: dict[str, float], before: Scored,
                  clock: _Clock, kw: dict) -> tuple[Fitted, list[str], dict, Scored]:
    """The fit from ``start``, held on every training window, not only on those it used: a calibrated robot whose
    simulation blows up on a window the fit did not see (its values left the simulator's stable
    range there) is fitted again with those windows added (they then count as diverged), from where
    the first fit ended: the fit has found its basin, the added windows only push it back into the
    stable range, so neither the several starts nor the first fit's iterations are needed again: only
    the changed parameters are fitted, and the decision for every candidate is made again once
    (GUARD_ROUNDS). Returns the attempt, the changed parameters, their window parameters and the
    calibrated robot scored on every training window."""
    ws = pb.ws
    start_at, only = start, None
    for attempt in range(2):
        with clock.stage("fit" if attempt == 0 else "guard_refit"):
            att = fit_attempt(fx, ws.subset(fit_index), start_at, only)
        changed = [n for n in pb.names if att.verdicts[n].changed]
        wp = window_params({n: att.values[n] for n in changed}, pb.robot)
        with clock.stage("guard"):
            fx.meter.stage("guard", fx.meter.tail)
            after = _score(fx.sim, pb.train, ws, [wp], **kw)[0] if changed else before
        new = np.setdiff1d(np.flatnonzero(after.diverged_mask & ~before.diverged_mask), fit_index)
        if attempt == 1 or new.size == 0:
            break
        log.info("calibrate: the fitted robot diverges on %d training windows the fit did not use; fitting again "
                 "with them", new.size)
        fit_index = np.union1d(fit_index, new)
        start_at = {n: float(np.clip(att.values[n], fx.specs[n].lo, fx.specs[n].hi)) for n in pb.names}
        only = changed
    return att, changed, wp, after


def _turn_findings(pb: _Problem, scope) -> tuple[list[dict], dict]:
    """Yaw ratio, forward speed ratios and ICRs, measured and simulated before and after, per part."""
    findings, meas_by = [], {}
    for label, lg, w, b, a in scope:
        meas = turn_measures(lg, w, pb.robot, measured_window_poses(lg, w), measured_speeds(lg, w))
        tb = turn_measures(lg, w, pb.robot, b.poses, b.speeds)
        ta = turn_measures(lg, w, pb.robot, a.poses, a.speeds)
        meas_by[label] = (meas, tb, ta)
        findings.append({"what": "yaw ratio", "part": label, "measured": meas["yaw_ratio"],
                         "simulated_before": tb["yaw_ratio"], "simulated_after": ta["yaw_ratio"],
                         "windows": meas["yaw_windows"],
                         "definition": "median over steady windows of yaw rate / ((v_R - v_L) / T), mean track speeds"})
        runs = command_runs(lg, w)  # the windows of one held command are drawn together
        for (lo, hi), (value, count) in meas["yaw_ratio_by_class"].items():
            gap = (class_gap_interval(meas["yaw_ratio_samples"][(lo, hi)], ta["yaw_ratio_samples"][(lo, hi)],
                                      groups=runs) if (lo, hi) in ta["yaw_ratio_samples"] else None)
            findings.append({"what": f"yaw ratio (|turn ratio| {lo:g} to {hi:g})", "part": label, "measured": value,
                             "simulated_before": tb["yaw_ratio_by_class"].get((lo, hi), (float("nan"),))[0],
                             "simulated_after": ta["yaw_ratio_by_class"].get((lo, hi), (float("nan"),))[0],
                             "windows": count, "turn_class": [lo, hi],
                             "gap_after_interval": None if gap is None else list(gap),
                             "definition": "the yaw ratio over the steady windows of this |turn ratio| class; "
                                           "gap_after_interval: 95 % bootstrap interval of measured minus calibrated over "
                                           "the windows, those of one held command drawn together (how far the "
                                           "class's few windows alone move it)"})
        for (lo, hi), (value, count) in meas["speed_ratio"].items():
            findings.append({"what": f"forward speed ratio (|turn ratio| {lo:g} to {hi:g})", "part": label,
                             "measured": value, "simulated_before": tb["speed_ratio"].get((lo, hi), (float("nan"),))[0],
                             "simulated_after": ta["speed_ratio"].get((lo, hi), (float("nan"),))[0], "windows": count,
                             "definition": "median over steady windows of forward speed / mean track speed"})
        for side in ("left", "right"):
            if side in meas["icr"]:
                for key in ("y_l", "y_r", "x_c"):
                    findings.append({"what": f"ICR {key} ({side} turns)", "part": label, "measured": meas["icr"][side][key],
                                     "simulated_before": tb["icr"].get(side, {}).get(key, float("nan")),
                                     "simulated_after": ta["icr"].get(side, {}).get(key, float("nan")),
                                     "windows": meas["icr"][side]["windows"]})
    return findings, meas_by


def _explain(pb: _Problem, att: Fitted, changed: list[str], causes: list[Cause], scope,
             restarts: list[dict] = ()) -> tuple[list[dict], str]:
    """The findings (turn measures, diverged windows) and the summary sentence."""
    findings, meas_by = _turn_findings(pb, scope)
    test = pb.test is not None
    m, tb, _ = meas_by["test" if test else "train"]
    _, _, _, b, a = scope[-1]
    # a value the log points at but the fit did not reach is said; one that could not be the robot's
    # (on a bound, above what traction transmits) is said as such, never as what the log points at
    specs, traction = specs_for(pb.robot), traction_limit(pb.robot, att.values)
    traction_note = traction_defaults(pb.robot, att.values)
    unsettled, unsettled_implausible = {}, {}
    for n in pb.names:
        v = att.verdicts[n].points_at
        if v is None:
            continue
        why = implausibility(n, v, pb.described[n], (specs[n].lo, specs[n].hi, specs[n].resolution),
                             traction=traction, traction_note=traction_note)
        if why is None:
            unsettled[n] = fmt_value(v, specs[n].unit)
        else:
            unsettled_implausible[n] = (fmt_value(v, specs[n].unit), why)
    sentence = summary(causes, (b.rms, a.rms), where="held-out" if test else "training",
                       yaw=(m["yaw_ratio"], tb["yaw_ratio"]),
                       undetermined=[n for n in pb.names if not att.verdicts[n].determined],
                       unsettled=unsettled, unsettled_implausible=unsettled_implausible,
                       sent_back=[n for n in pb.names if att.verdicts[n].unsettled])
    for label, _, _, b, a in scope:
        findings.append({"what": "diverged windows", "part": label, "measured": None, "simulated_before": b.diverged,
                         "simulated_after": a.diverged, "windows": int(b.diverged_mask.size),
                         "definition": "windows whose simulation blew up (body faster than 20 m/s or not finite)"})
        if a.diverged > b.diverged:
            sentence += (f" Warning: the calibrated robot's simulation blows up in {a.diverged} of "
                         f"{a.diverged_mask.size} {label} windows ({b.diverged} as described): its values leave the "
                         "simulator's stable range there; its errors there count in the position error.")
    sentence += restart_sentence(restarts)
    for label, rows in pb.left_out.items():
        if rows:
            kept = len(pb.ws) if label == "train" else len(pb.tws)
            sentence += (f" {len(rows)} of {len(rows) + kept} {label} windows were left out: {left_out_counts(rows)} "
                         "(listed under left_out).")
    return findings, sentence


def _calibrate(train: DriveLog, robot: Robot, *, test, names, horizon_s, n_rollers, max_iter, nthread, quiet,
               train_path, test_path, warmup_s, drive_input, fit_windows, keep_contradicting, rounds) -> Calibration:
    """The stages, each timed: prepare, before (the robot as described scored), fit (the first fit
    and its rounds of decisions), guard (every training window scored after; guard_refit when the
    second attempt runs), after (the test log scored after, the causes), explain."""
    clock = _Clock()
    meter = Meter(quiet)
    try:
        return _stages(train, robot, test=test, names=names, horizon_s=horizon_s, n_rollers=n_rollers,
                       max_iter=max_iter, nthread=nthread, train_path=train_path, test_path=test_path,
                       warmup_s=warmup_s, drive_input=drive_input, fit_windows=fit_windows,
                       keep_contradicting=keep_contradicting, rounds=rounds, clock=clock, meter=meter)
    finally:
        meter.close()


def _stages(train: DriveLog, robot: Robot, *, test, names, horizon_s, n_rollers, max_iter, nthread, train_path,
            test_path, warmup_s, drive_input, fit_windows, keep_contradicting, rounds, clock: _Clock,
            meter: Meter) -> Calibration:
    from mjtrack.calibrate.fit import multistart_passes, start_points, windows_done
    from mjtrack.sim.windows import WindowSim, simulate_windows

    src = train_path or train.source or "train log"
    test_src = None if test is None else (test_path or test.source or "test log")
    with clock.stage("prepare"):
        pb = _prepare(train, robot, test, names, horizon_s=horizon_s, n_rollers=n_rollers,
                      keep_contradicting=keep_contradicting, src=src, test_src=test_src)
        sim = WindowSim(robot, pb.config, resisted="rolling_resistance" in pb.names,
                        framed=any(n in FRAMED_PARAMS for n in pb.names))
    fx = Fitter(sim=sim, train=train, names=pb.names, described=pb.described, config=pb.config, max_iter=max_iter,
                 nthread=nthread, warmup_s=warmup_s, meter=meter, rounds=rounds,
                 undescribed=undescribed(robot, pb.names))
    n_fit = len(fit_index_of(pb.ws, fit_windows))
    n_test = 0 if pb.tws is None else len(pb.tws)
    starts = multistart_passes(len(start_points(pb.names, fx.specs, np.zeros(len(pb.names)))), n_fit)
    # the fit, then every training window (the guard), the test windows, and the causes' variants (on
    # the fit windows, two per cause: about two causes)
    passes = expected_passes(len(pb.names), starts, max_iter, fx.refit_iter)
    after_windows = len(pb.ws) + n_test + 2 * n_fit
    meter.tail = after_windows
    meter.stage("as described", len(pb.ws) + n_test + passes * n_fit + after_windows)
    kw = dict(nthread=nthread, warmup_s=warmup_s, progress=meter.windows)
    with clock.stage("before"):
        before = _score(sim, train, pb.ws, [{}], **kw)[0]
        test_before = _score(sim, test, pb.tws, [{}], **kw)[0] if test is not None else None
    rate = (len(pb.ws) + n_test) / max(clock.timings["before"], 1e-9)
    meter.say(f"calibrate {src}: {len(pb.ws) + n_test} windows simulated in {clock.timings['before']:.1f} s; "
              f"the fit of {len(pb.names)} parameters takes about {passes} passes over {n_fit} windows: about "
              f"{clock_text((passes * n_fit + after_windows) / rate)} more")
    att, changed, wp, after, restarts = _guarded_fit(fx, pb, fit_windows, before, clock, kw)
    fit_wp = wp
    with clock.stage("turns"):
        turns, sim, changed, wp, after = _turn_stage(fx, pb, sim, att, changed, wp, after, kw)
    with clock.stage("after"):
        meter.stage("causes", n_test + 2 * n_fit)
        test_after = None
        if test is not None:
            test_after = _score(sim, test, pb.tws, [wp], **kw)[0] if changed else test_before
            if turns is not None and turns.accepted:  # the price of turning as the log does, on windows never fitted
                turns.test_rms = (_score(sim, test, pb.tws, [fit_wp], **kw)[0].rms if fit_wp else test_before.rms,
                                  test_after.rms)
        cal_robot = calibrated_robot(robot, {n: att.values[n] for n in changed}, pb.config, drive_input)
        corr = np.eye(len(changed))
        if changed and att.u is not None:  # a value the turn stage added has no correlation in the pose fit
            inl = [i for i, n in enumerate(changed) if n in att.lin.names]
            cidx = [att.lin.names.index(changed[i]) for i in inl]
            corr[np.ix_(inl, inl)] = att.u.corr[np.ix_(cidx, cidx)]

        # the causes are measured on the windows the fit used (all of them up to ``fit_windows``): each
        # cause costs two passes, and on a long log a pass over every window was a sixth of the time
        # (benchmarks/bench_calibrate.py --case marmotte); the fit's own windows are the evidence its
        # values and intervals rest on
        fit_idx = np.flatnonzero(np.isin(pb.ws.starts, att.fws.starts))
        cws = pb.ws.subset(fit_idx)

        def score(variants):
            res = simulate_windows(sim, train, cws, [window_params(v, robot) for v in variants], nthread=nthread,
                                   warmup_s=warmup_s, progress=windows_done(meter.windows))
            return res.rms()

        causes = find_causes(changed, att.values, pb.described, corr, att.ties, score, before.rms_on(fit_idx),
                             after.rms_on(fit_idx),
                             wheels=robot.traction == "wheels", measured=drive_input == "measured",
                             bounds={n: (s.lo, s.hi, s.resolution) for n, s in fx.specs.items()},
                             intervals={n: att.verdicts[n].interval for n in changed}, robot=robot)
    with clock.stage("explain"):
        scope = [("train", train, pb.ws, before, after)]
        if test is not None:
            scope.append(("test", test, pb.tws, test_before, test_after))
        findings, sentence = _explain(pb, att, changed, causes, scope, restarts)
        sentence += "" if turns is None else turns.sentence()
    names = pb.names
    return Calibration(
        train_path=str(train_path or train.source), test_path=None if test is None else str(test_path or test.source),
        robot=robot, calibrated=cal_robot, track_model=pb.config.track_model, horizon_s=float(horizon_s),
        names=list(names), values={n: float(att.values[n]) for n in names}, described=pb.described,
        verdicts=att.verdicts, fixed=pb.fixed, assumed=pb.assumed, fit=att.result, refit=att.refit,
        model_form=att.model_form, causes=causes, train_windows=pb.ws, test_windows=pb.tws, train_log=train,
        test_log=test, before=before, after=after, test_before=test_before, test_after=test_after,
        findings=json_value(findings), sentence=sentence, config=pb.config.to_dict(), timings=clock.total(),
        drive_input=drive_input, fit_windows=att.fws, left_out=pb.left_out, rounds=rounds, restarts=restarts,
        simulated_windows=meter.simulated, turns=None if turns is None else turns.to_json())


def _turn_stage(fx: Fitter, pb: _Problem, sim: WindowSim, att: Fitted, changed: list[str], wp: dict, after: Scored,
                kw: dict) -> tuple[TurnMatch | None, WindowSim, list[str], dict, Scored]:
    """The turn stage (:mod:`mjtrack.calibrate.turns`) after the pose fit: when it is accepted, its
    values replace the fit's in ``att`` (with their verdicts; a turn candidate the calibration did
    not name is added to ``pb.names``; when the robot judged is the one whose other candidates were
    fitted again with the turn candidates held, their values, verdicts and uncertainty too) and the
    simulator, the changed parameters, their window parameters and the training score are those of
    the turn-matched robot."""
    from mjtrack.sim.windows import WindowSim

    names = turn_candidates(pb.names, pb.robot)
    if not names:
        return None, sim, changed, wp, after
    tsim = sim
    if "lateral_shear_ratio" in names and not sim.framed:
        tsim = WindowSim(pb.robot, pb.config, resisted=sim.resisted, framed=True)
    scored: dict[tuple, Scored] = {}
    refitted: list[Fitted] = []  # the refit's attempt (it runs once at most)
    others = [n for n in pb.names if n not in names]

    def score(params: dict[str, float]) -> tuple[np.ndarray, int]:
        scored[_key(params)] = s = _score(tsim, pb.train, pb.ws, [params], **kw)[0]
        return np.hypot(s.errors[:, 0], s.errors[:, 1]), s.diverged

    def refit(values: dict[str, float]) -> tuple[dict[str, float], list[str]] | None:
        # the pose fit's other values were found with the turn candidates where the pose fit left them:
        # before the two robots are compared, the others the pose fit changed are fitted again with the
        # turn candidates held where the turns put them (as the guard refits: from where they are), and the
        # decisions made again with the calibration's rounds: one round leaves a value the pose fit had
        # settled at its description with the log pointing elsewhere
        only = [n for n in changed if n in others]
        if not only:
            return None
        fx2 = dataclasses.replace(fx, sim=tsim, names=list(others), described={n: pb.described[n] for n in others},
                                  undescribed=tuple(n for n in fx.undescribed if n in others), held=dict(values))
        att2 = fit_attempt(fx2, att.fws, {n: float(np.clip(att.values[n], fx.specs[n].lo, fx.specs[n].hi))
                                           for n in others}, only, note="turns: refit", rounds=fx.rounds)
        now = [n for n in others if att2.verdicts[n].changed]
        base = window_params({n: att2.values[n] for n in now}, pb.robot)
        refitted.append(att2)
        return base, [n for n in on_bounds(att2.values, now, fx.specs) if n not in on_bounds(att.values, changed, fx.specs)]

    fx.meter.stage("turns")
    tm = match_turns(tsim, pb.train, pb.ws, pb.robot, wp, names, fx.specs,
                     fitted_errors=np.hypot(after.errors[:, 0], after.errors[:, 1]), fitted_diverged=after.diverged,
                     fitted_poses=after.poses, fitted_speeds=after.speeds, nthread=kw["nthread"],
                     warmup_s=kw["warmup_s"], score=score, refit=refit if others else None, progress=kw["progress"])
    if tm is None or not tm.accepted:
        return tm, sim, changed, wp, after
    specs = fx.specs
    if tm.refit is not None and tm.refit["kept"]:
        att2 = refitted[-1]
        for n in others:
            att.values[n], att.verdicts[n] = att2.values[n], att2.verdicts[n]
        att.u, att.lin, att.ties, att.model_form = att2.u, att2.lin, att2.ties, att2.model_form
    for n in names:
        if n not in pb.names:
            pb.names.append(n)
            pb.described[n] = described_values(pb.robot, [n], pb.config)[n]
            pb.start[n] = tm.start[n]
        lo, hi = tm.intervals.get(n, (None, None))
        half = None if lo is None else (hi - lo) / 2
        determined = half is not None and half < specs[n].resolution
        span = ("no interval" if lo is None else f"95 % interval [{lo:.4g}, {hi:.4g}] {specs[n].unit}".rstrip(" –"))
        rest = [m for m in names if m != n]
        reason = (f"set by the training part's steady turns ({span}; "
                  + ("determined by them" if determined else
                     f"wider than the +-{specs[n].resolution:g} that matters: the turns fix it together with "
                     f"{', '.join(rest)}, a change of one taken up by the others")
                  + f"): {tm.why}")
        att.values[n] = tm.values[n]
        att.verdicts[n] = Verdict(n, determined, True, tm.values[n], pb.described[n],
                                  None if lo is None else (lo, hi), reason)
    changed = [n for n in pb.names if att.verdicts[n].changed]
    wp = window_params({n: att.values[n] for n in changed}, pb.robot)
    return tm, tsim, changed, wp, scored[_key(tm.params)]


def _key(params: dict[str, float]) -> tuple:
    """A dict of window parameters as a key (the same values give the same key)."""
    return tuple(sorted((k, float(v)) for k, v in params.items()))


def _without_contradicting(lg: DriveLog, ws: WindowSet, src: str, gauge: float) -> tuple[WindowSet, list[dict]]:
    """``ws`` less the windows the ground cannot explain (poses against the tracks, a robot held
    still), and those windows (said in a warning; InputError when that is every window)."""
    kept, bad = without_contradicting(lg, ws, gauge)
    if not bad:
        return ws, []
    first = bad[0]
    if first["kind"] == "against":
        example = (f"from t = {first['t0']:.3f} s the tracks drive {first['track_path_m'][0]:+.2f} then "
                   f"{first['track_path_m'][1]:+.2f} m, the body moves {first['body_path_m'][0]:+.2f} then "
                   f"{first['body_path_m'][1]:+.2f} m along its heading")
    else:
        example = (f"from t = {first['t0']:.3f} s a track runs {first['track_path_m'][0]:.2f} then "
                   f"{first['track_path_m'][1]:.2f} m, the body under the tracks gets {first['body_path_m'][0]:.2f} "
                   f"then {first['body_path_m'][1]:.2f} m away")
    if len(kept) == 0:
        raise InputError(f"{src}: no window the ground can explain ({left_out_counts(bad)}; e.g. {example}): check "
                         "the signs of the speed columns and the localisation")
    log.warning("calibrate: %s: %d of %d windows left out: %s (e.g. %s)", src, len(bad), len(ws),
                left_out_counts(bad), example)
    return kept, bad


__all__ = ["Calibration", "calibrate", "calibrated_robot", "write_outputs"]