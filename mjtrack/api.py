"""The public Python API: one function per job, each named for what it does.

Every function here is re-exported by :mod:`mjtrack` (``import mjtrack as mt; mt.simulate_log(...)``)
and delegates to the one implementation in its subpackage; the command-line tools do the same
jobs. Importing this module does not load MuJoCo: the functions that simulate import it when
called. Units are SI, angles in radians; frames and sign conventions: the documentation's
"Frames and sign conventions" page.
"""

from __future__ import annotations

import os
from typing import TYPE_CHECKING, Any

from mjtrack.errors import InputError

if TYPE_CHECKING:  # pragma: no cover - types for the signatures only
    import numpy as np

    from mjtrack.calibrate.result import Calibration
    from mjtrack.diagnose.result import Diagnosis
    from mjtrack.icr import ICR
    from mjtrack.io.logs import DriveLog
    from mjtrack.io.robot import Robot
    from mjtrack.models.coulomb import SteadyState
    from mjtrack.sim.noise import LogNoise
    from mjtrack.sim.steady import SteadyResult
    from mjtrack.sim.terrain import Terrain
    from mjtrack.validate.run import Validation


def _terrain(terrain: "str | Terrain | None", scenario: str | None = None) -> "Terrain":
    """A terrain from a ``--terrain`` spec or a Terrain; None: the scenario's own, else flat."""
    from mjtrack.sim.scenarios import SCENARIOS
    from mjtrack.sim.terrain import Terrain, parse_terrain

    if terrain is None:
        return SCENARIOS[scenario].terrain if scenario in SCENARIOS else Terrain()
    if isinstance(terrain, Terrain):
        return terrain
    return parse_terrain(terrain)


def simulate_log(robot: "Robot", *, scenario: str | None = None,
                 commands: "tuple[np.ndarray, np.ndarray, np.ndarray] | str | os.PathLike | None" = None,
                 duration: float | None = None, seed: int = 0, log_rate: float = 50.0,
                 terrain: "str | Terrain | None" = None, track_model: str | None = None,
                 timestep: float | None = None, noise: "str | dict | LogNoise | None" = None) -> "DriveLog":
    """Drive the MuJoCo robot with a scenario or a command table and return its drive log.

    The Python form of ``mjtrack simulate`` (same arguments, same log). The robot starts at rest at
    the origin, heading +x; each command is held until the next one.

    Args:
        robot: the robot description.
        scenario: a name of :data:`mjtrack.sim.scenarios.SCENARIOS` (``mjtrack simulate --help``
            lists them); exactly one of ``scenario`` and ``commands``.
        commands: a command table ``(t [s], v_left [m/s], v_right [m/s])`` of equal-length
            arrays, or the path of a CSV with columns ``t, v_left_cmd, v_right_cmd``.
        duration: simulated time [s]; default the scenario's, or the last command time + 1 s.
        seed: seed of the random scenarios and of the measurement noise (the same seed gives the
            same log).
        log_rate: log sample rate [Hz], a divisor of the simulation rate.
        terrain: a ``--terrain`` spec (``"incline:0.1"``) or a Terrain; default the scenario's, else flat.
        track_model: ``"rollers"`` (sprung roller chain) or ``"surfacevel"``; default the robot's
            ``simulator`` settings (what a calibrated robot was fitted with), else rollers.
        timestep: simulation time step [s]; default the robot's ``simulator`` timestep, else 5 ms
            (smaller on terrain with edges).
        noise: measurement noise added to the log (:mod:`mjtrack.sim.noise`): a preset
            (``"none"``, ``"realistic"``: the level of the real Marmotte, Husky and Warthog logs),
            ``"realistic,yaw_std=0.01"``, a dict of ``*_std`` values [SI] with an optional
            ``"preset"``, or a :class:`~mjtrack.sim.noise.LogNoise`; default none.

    Returns:
        The :class:`~mjtrack.io.logs.DriveLog` (plus ``z``, ``roll``, ``pitch`` on terrain).

    Raises:
        InputError: neither or both of ``scenario`` and ``commands``, or a bad scenario, table or terrain.

    Examples:
        >>> import mjtrack as mt
        >>> log = mt.simulate_log(mt.Robot(), scenario="straight", duration=2.0)
        >>> log.n_samples, log.has_twist  # rows at t = 0, 0.02, ..., 2.0 s
        (101, True)
        >>> round(float(log.x[-1]), 1)  # 0.5 m/s for 2 s
        1.0
    """
    from mjtrack.sim.config import sim_config
    from mjtrack.sim.noise import add_noise, log_noise
    from mjtrack.sim.rollout import drive_log
    from mjtrack.sim.scenarios import read_commands, scenario_commands

    if (scenario is None) == (commands is None):
        raise InputError("simulate_log: give exactly one of scenario and commands")
    noise = log_noise(noise)  # a bad spec is refused before the rollout
    config = sim_config(track_model, timestep=timestep, robot=robot)
    if scenario is not None:
        table, duration = scenario_commands(scenario, robot, duration=duration, seed=seed)
    else:
        table = read_commands(commands) if isinstance(commands, (str, os.PathLike)) else _command_table(commands)
        duration = float(duration) if duration is not None else float(table[0][-1]) + 1.0
    return add_noise(drive_log(robot, table, duration=duration, config=config, log_rate=log_rate,
                               terrain=_terrain(terrain, scenario)), noise, seed=seed)


def _command_table(commands: Any) -> "tuple[np.ndarray, np.ndarray, np.ndarray]":
    import numpy as np

    try:
        t, v_left, v_right = (np.asarray(c, dtype=float) for c in commands)
    except (TypeError, ValueError):
        raise InputError("simulate_log: commands must be (t, v_left, v_right) arrays or a CSV path") from None
    if not (t.ndim == 1 and t.shape == v_left.shape == v_right.shape and t.size > 0):
        raise InputError("simulate_log: commands t, v_left, v_right must be 1-D arrays of one length")
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(v_left)) and np.all(np.isfinite(v_right))):
        raise InputError("simulate_log: commands must be finite")
    if np.any(np.diff(t) <= 0):
        raise InputError("simulate_log: command times must increase strictly")
    return t, v_left, v_right


def log_icrs(log: "DriveLog", *, wz_min: float = 1e-3) -> "ICR":
    """The instantaneous centres of rotation of every row of a log, eq. (2.13).

    y_l = (v_x - V_L) / w, y_r = (v_x - V_R) / w, x_c = -v_y / w, from the logged body twist
    and the measured track speeds (what ``simulate_log`` writes).

    Args:
        log: a drive log with the body twist (``vx, vy, wz``) and measured track speeds.
        wz_min: rows whose yaw rate magnitude is below this [rad/s] (straight driving, rest) are masked.

    Returns:
        An :class:`~mjtrack.icr.ICR` of arrays (n,): ``y_l``, ``y_r``, ``x_c``, ``y_c`` [m] in the
        robot frame (NaN where masked) and ``valid``.

    Raises:
        InputError: the log lacks the twist or the measured track speeds.

    Examples:
        >>> import mjtrack as mt
        >>> robot = mt.Robot()
        >>> icr = mt.log_icrs(mt.simulate_log(robot, scenario="circle", duration=4.0))
        >>> bool(icr.y_l[-1] > robot.track_gauge / 2)  # slip moves the left-track ICR outward
        True
    """
    from mjtrack.sim.rollout import log_icrs as icrs

    if not (log.has_twist and log.has_track_speeds):
        raise InputError(f"{log.source or 'drive log'}: ICRs need the columns vx, vy, wz, v_left and v_right")
    return icrs(log, wz_min=wz_min)


def mujoco_steady_state(robot: "Robot", v_left: float, v_right: float, *, terrain: "str | Terrain | None" = None,
                        track_model: str | None = None, settle_s: float = 3.0, window_s: float = 2.0
                        ) -> "SteadyResult":
    """Steady-state twist and ICRs of the MuJoCo robot under constant track speeds.

    The Python form of ``mjtrack steady``: from rest, the commands are held for ``settle_s``,
    then the sensors are averaged over ``window_s``; the ICRs follow from the window means by
    (2.13) with the measured track speeds. Compare :func:`coulomb_steady_state`, the
    rigid-track Coulomb reference of the same description.

    Args:
        robot: the robot description.
        v_left: commanded left track speed [m/s].
        v_right: commanded right track speed [m/s].
        terrain: a ``--terrain`` spec or a :class:`~mjtrack.sim.terrain.Terrain`; default flat.
        track_model: ``"rollers"`` or ``"surfacevel"``; default the robot's ``simulator`` settings
            (with their timestep), else rollers.
        settle_s: time under the constant commands before the averaging window [s].
        window_s: averaging window [s].

    Returns:
        A :class:`~mjtrack.sim.steady.SteadyResult`: ``vx, vy`` [m/s], ``wz`` [rad/s] and their
        window standard deviations, ``y_l, y_r, x_c`` [m] (NaN, with the reason in
        ``icr_undefined``, where the robot does not turn), the measured track speeds and the
        contact fractions; ``unsettled`` says why the window is not a steady state (None when it is).

    Examples:
        >>> import mjtrack as mt
        >>> s = mt.mujoco_steady_state(mt.Robot(), 0.3, 0.6)
        >>> bool(s.wz > 0), bool(s.y_l > 0.2 > -0.2 > s.y_r)  # left turn; ICRs outside the tracks
        (True, True)
    """
    from mjtrack.sim.config import sim_config
    from mjtrack.sim.steady import steady_state

    return steady_state(robot, v_left, v_right, config=sim_config(track_model, robot=robot), settle_s=settle_s,
                        window_s=window_s, terrain=_terrain(terrain))


def coulomb_steady_state(robot: "Robot", v_left: float, v_right: float, *, inertial: bool = True,
                         load_transfer: bool = True) -> "SteadyState":
    """Steady state of the rigid-track Coulomb reference under constant track speeds.

    The exact solution (residual at most 1e-10 of the weight) of the force and moment balance of
    a rigid robot whose tracks slide on the ground with Coulomb friction, the load spread along
    each track by the plate law, with the centripetal load transfer; no MuJoCo. The reference
    the MuJoCo robot is checked against (:func:`mujoco_steady_state`).

    Args:
        robot: the robot description (``track_gauge``, ``track_length``, ``mass``, centre of
            mass, friction and ``ground`` are used).
        v_left: left track speed [m/s].
        v_right: right track speed [m/s].
        inertial: include the centripetal force m v w (False: the quasi-static balance).
        load_transfer: shift the normal loads by the centripetal force at height ``cg_z``.

    Returns:
        A :class:`~mjtrack.models.coulomb.SteadyState`: ``vx, vy`` [m/s], ``wz`` [rad/s], the ICRs
        ``y_l, y_r, x_c`` [m] (they raise :class:`~mjtrack.errors.SingularMotionError` for straight
        motion) and the balance's ``residual``.

    Raises:
        MjtrackError: no steady state exists (e.g. the centripetal force exceeds the friction).

    Examples:
        >>> import mjtrack as mt
        >>> robot = mt.Robot()
        >>> ref = mt.coulomb_steady_state(robot, -0.4, 0.4)  # a pivot turn
        >>> bool(abs(ref.vx) < 1e-9), bool(ref.y_l > robot.track_gauge / 2)
        (True, True)
    """
    from mjtrack.models.coulomb import steady_state

    return steady_state(robot, v_left, v_right, inertial=inertial, load_transfer=load_transfer)


def validate_models(log: "DriveLog", robot: "Robot", out_dir: str | os.PathLike, *, noise_scale: float = 1.0,
                    seed: int = 0, speeds: str = "auto", quiet: bool = True) -> "Validation":
    """Score every kinematic model and filter against a log; write report.html and metrics.json.

    The Python form of ``mjtrack validate LOG.csv``: the nominal model, MPP (slip EKF), MICR (ICR
    EKF), MVIR (virtual-robot filter) and two upper bounds predict the log's motion from each
    window start, at horizons 0.5, 1, 2 and 5 s, on the log and on an MPP analytic truth driven
    by the same commands.

    Args:
        log: the drive log (a simulated one: its twist is the truth the filters are scored on).
        robot: its robot description (``track_gauge`` is what the models use).
        out_dir: folder for ``report.html`` and ``metrics.json`` (created).
        noise_scale: multiplier of the seeded measurement noise given to the filters (0: none).
        seed: seed of that noise.
        speeds: which track speeds drive the models: ``"cmd"``, ``"measured"`` or ``"auto"``
            (measured when the log has them).
        quiet: no progress display.

    Returns:
        A :class:`~mjtrack.validate.run.Validation`: ``metrics`` (the content of metrics.json),
        ``results`` per truth, ``report_path`` and ``metrics_path``.

    Examples:
        >>> import tempfile, mjtrack as mt
        >>> robot = mt.Robot()
        >>> log = mt.simulate_log(robot, scenario="circle", duration=4.0)
        >>> val = mt.validate_models(log, robot, tempfile.mkdtemp())
        >>> sorted(val.metrics["headline"]["pos_rmse_m"])
        ['log', 'mpp']
    """
    from mjtrack.validate import Noise, validate

    return validate(log, robot, out_dir, source=log.source or "drive log", noise=Noise(scale=noise_scale),
                    seed=seed, speeds=speeds, quiet=quiet)


def diagnose_log(log: "DriveLog", robot: "Robot", *, baseline: str = "auto", test_log: "DriveLog | None" = None,
                 horizon_s: float | str = "auto", n_folds: int = 5, effects: list[str] | None = None,
                 out_dir: str | os.PathLike | None = None, quiet: bool = True) -> "Diagnosis":
    """Find what a simulation of the robot gets wrong on a drive log, and why.

    The Python form of ``mjtrack diagnose``: each candidate effect extends the baseline, is fitted on
    part of the log and reported only when its held-out gain is significant (docs/guide/own-log.md).

    Args:
        log: the measured drive log (poses required; measured track speeds help).
        robot: the robot description the simulation is given.
        baseline: ``"mujoco"``, ``"surrogate"`` (rigid-track Coulomb), ``"kinematic"``, or ``"auto"``
            (``mujoco`` when the description lets the MuJoCo robot be built, else ``surrogate``).
        test_log: fit on ``log`` and score on this log of the same robot (else cross-validation).
        horizon_s: prediction window [s], or ``"auto"`` (2 s, shorter on short segments).
        n_folds: cross-validation folds (at least 3).
        effects: the candidate effects to test (default all).
        out_dir: when given, ``diagnosis.json`` and ``report.html`` are written there.
        quiet: no progress display.

    Returns:
        The diagnosis: ``cause`` (the first finding's effect, or ``"none"``), ``findings`` with
        their estimates, 95 % intervals and held-out gains, ``summary()``, ``to_json()`` (the
        content of diagnosis.json).

    Examples:
        >>> import mjtrack as mt
        >>> slow_tracks = mt.Robot(track_speed_scale=0.85)  # the truth: tracks at 85 % of the command
        >>> log = mt.simulate_log(slow_tracks, scenario="random_steps", duration=60.0, log_rate=20.0)
        >>> d = mt.diagnose_log(log, mt.Robot(), baseline="surrogate",
        ...                     effects=["track_speed_scale", "cg_x", "friction_scale"])
        >>> d.cause
        'track_speed_scale'
    """
    from mjtrack.diagnose import diagnose, write_outputs

    result = diagnose(log, robot, baseline=baseline, test_log=test_log, horizon_s=horizon_s, n_folds=n_folds,
                      effects=effects, quiet=quiet)
    if out_dir is not None:
        write_outputs(result, out_dir)
    return result


def calibrate_robot(log: "DriveLog", robot: "Robot", *, test_log: "DriveLog | None" = None,
                    params: list[str] | None = None, horizon_s: float = 2.0, max_iter: int = 8,
                    out_dir: str | os.PathLike | None = None, quiet: bool = True,
                    drive_input: str = "auto", fit_windows: int | None | str = "default",
                    rounds: int = 3) -> "Calibration":
    """Fit the MuJoCo robot's description to a drive log.

    The Python form of ``mjtrack calibrate``: windows of ``horizon_s`` simulated from the measured
    state, parameters fitted to the poses at their ends (a parameter the log leaves open is kept).

    Args:
        log: the measured training log.
        robot: the robot description to start from (what it gives is kept unless fitted).
        test_log: a held-out log of the same robot, scored before and after the fit.
        params: the parameters to fit, as ``mjtrack calibrate --params`` names them (e.g. ``mu``,
            ``cg_x``, ``cg_y``, ``track_length``, ``drive_lag``, ``drive_delay``,
            ``track_speed_scale``, ``rolling_resistance``); default: the command's.
        horizon_s: window length [s].
        max_iter: optimiser iterations.
        out_dir: when given, ``robot.json``, ``calibration.json`` and ``report.html`` are written.
        quiet: no progress display.
        drive_input: what the simulated drives follow: ``"auto"`` (default: ``"fitted"`` when the
            log's measured track speeds show the robot's own speed controller capping its commands
            and the drive's timing is not asked for by name, else ``"commanded"``; the mode used
            and why are in the result's ``drive_input_mode`` and ``drive_input_why``),
            ``"commanded"`` (the logged commands; the drive's lag, delay and speed scale are fitted
            too), ``"fitted"`` (the drivetrain is first fitted to the log's measured track speeds,
            command to speed, and the contact then to the poses under the speeds it predicts from
            the commands) or ``"measured"`` (the logged track speeds: the contact alone).
        fit_windows: windows the fit uses, spread over the log (``--fit-windows``; None: all;
            default: the command's).
        rounds: at most this many refits after the first fit, each after what the log determines
            is decided again (``--rounds``, 0 to 20); a fit that has not settled when they run out
            says what the log points at that it did not reach.

    Returns:
        The calibration: ``calibrated`` (the fitted :class:`~mjtrack.io.robot.Robot`),
        ``before`` / ``after`` (position error at the windows' ends, ``.rms`` [m]), ``test_before``
        / ``test_after`` with a test log, ``causes`` and ``sentence`` (what changed and why),
        ``to_json()`` (the content of calibration.json).

    Examples:
        >>> import mjtrack as mt
        >>> truth = mt.Robot(cg_x=0.06)  # centre of mass 6 cm ahead, unknown to the description
        >>> log = mt.simulate_log(truth, scenario="random_steps", duration=10.0, log_rate=20.0)
        >>> cal = mt.calibrate_robot(log, mt.Robot(), params=["cg_x"], max_iter=2)
        >>> round(cal.calibrated.cg_x, 2), bool(cal.after.rms < cal.before.rms)
        (0.06, True)
    """
    from mjtrack.calibrate.result import write_outputs
    from mjtrack.calibrate.run import calibrate

    cal = calibrate(log, robot, test=test_log, names=None if params is None else ",".join(params), horizon_s=horizon_s,
                    max_iter=max_iter, quiet=quiet, train_path=log.source or "train log", drive_input=drive_input,
                    test_path=None if test_log is None else test_log.source or "test log", rounds=rounds,
                    **({} if fit_windows == "default" else {"fit_windows": fit_windows}))
    if out_dir is not None:
        write_outputs(cal, out_dir)
    return cal
