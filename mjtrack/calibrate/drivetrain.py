"""The drivetrain stage of calibrate: the chain command -> track speed of
:mod:`mjtrack.models.drivetrain` fitted to a log's measured track speeds.

A log with measured track (wheel) speeds says how the drives followed their commands, apart from
the contact: the fit of the contact to the poses then need not bend to explain the drives. Over
windows of the log (:func:`mjtrack.sim.windows.make_windows`), each started from its measured
speeds, least squares fits per side the dead time, the lag and the speed limit, and for both sides
the speed scale, the acceleration limit and the twist stage (turn scale, mean and turn limits,
mean and turn ramps) (:func:`mjtrack.calibrate.params.chain_specs`).

What the log determines:

* a limit acts only where the commands exceed it: one that changes the predicted speeds on
  fewer than :data:`MIN_ACTIVE` of a side's rows (or in fewer than :data:`MIN_WINDOWS` windows) is
  "not determined: never reached" and left out of the fit, not given a number;
* intervals: 95 %, the cluster-robust sandwich of :class:`mjtrack.calibrate.identify.Linearised`
  (clusters of consecutive windows: a window's rows share its start and its command);
* a fitted parameter whose interval is wider than its resolution and contains the described
  value is "not determined" and keeps the described value (the fit is then repeated without it).

The wheel-speed error reported is the RMS of measured minus predicted speeds over the windows'
rows after their first, for the chain as described (before) and as fitted (after).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import least_squares

from mjtrack.calibrate.identify import Linearised
from mjtrack.calibrate.params import chain_specs
from mjtrack.errors import InputError
from mjtrack.io.logs import DriveLog
from mjtrack.io.robot import Robot
from mjtrack.models.drivetrain import window_response
from mjtrack.windows import LOGGED_COMMANDS, make_windows

SIDED = ("drive_delay", "drive_lag", "drive_speed_limit")
LIMITS = ("drive_speed_limit_left", "drive_speed_limit_right", "drive_accel_limit", "drive_mean_speed_limit",
          "drive_turn_limit", "drive_mean_accel_limit", "drive_turn_accel_limit")
MIN_ACTIVE = 0.02  # share of a side's rows a limit must change for the log to show it
MIN_WINDOWS = 3  # ... in at least this many windows
ACTIVE_SPEED = 0.01  # [m/s] a change of the predicted speed that counts as the limit acting
LIMIT_SPREAD = 0.5  # a limit whose 95 % half-width exceeds this share of its value is not determined
MIN_MEASURED = 0.5  # share of rows with measured speeds below which the log has none to fit
# [s] of a segment before a window over which the chain warms up from the measured speed: its
# hidden states (ramp, delayed output) start wrong; at 1 s a 0.35 s lag kept 6 % of that error and
# the generated log's fit came out 0.012 s short of it, at 2 s within its interval (tests/test_drivetrain_id.py)
HISTORY_S = 2.0


@dataclass(frozen=True)
class SpeedWindows:
    """Windows of a log padded to one length K: ``t`` (M, K) [s] from each window's start, with
    up to :data:`HISTORY_S` of its segment's rows before it (the prediction starts there, from
    the measured speeds ``v0`` (M, 2), and warms the drive's hidden states up; the dead time
    brings their commands into the window), ``cmd``, ``meas`` (M, K, 2) [m/s], ``valid`` (M, K)
    the rows fitted: inside the window after its start, with measured speeds."""

    t: np.ndarray
    cmd: np.ndarray
    meas: np.ndarray
    valid: np.ndarray
    v0: np.ndarray

    def __len__(self) -> int:
        return int(self.t.shape[0])


def speed_windows(log: DriveLog, horizon_s: float = 2.0) -> SpeedWindows:
    """The log's windows with their commands and measured speeds; InputError without measured speeds."""
    if log.v_left is None or log.v_right is None:
        raise InputError("drivetrain: the log has no measured track speeds (columns v_left, v_right)")
    meas = np.stack([log.v_left, log.v_right], -1).astype(float)
    ok = np.all(np.isfinite(meas), axis=1)
    if ok.mean() < MIN_MEASURED:
        raise InputError(f"drivetrain: measured track speeds on only {100 * ok.mean():.0f} % of the rows")
    ws = make_windows(log, horizon_s)
    keep = ok[ws.starts]
    starts, ends = ws.starts[keep], ws.ends[keep]
    if starts.size < 2:
        raise InputError(f"drivetrain: the log has {starts.size} window(s) of {horizon_s:g} s with measured "
                         "speeds at their start; the drivetrain needs a few")
    slices = log.segment_slices()
    first = np.array([slices[k].start + int(np.searchsorted(log.t[slices[k]], log.t[s] - HISTORY_S - 1e-9))
                      for s, k in zip(starts, ws.segment[keep])], int)
    first = np.where(ok[first], first, starts)  # (a history that starts without measured speeds: none)
    K = int((ends - first).max()) + 1
    M = starts.size
    t = np.empty((M, K))
    cmd = np.empty((M, K, 2))
    out = np.zeros((M, K, 2))
    valid = np.zeros((M, K), bool)
    c_all = np.stack([log.v_left_cmd, log.v_right_cmd], -1).astype(float)
    for j, (f, s, e) in enumerate(zip(first, starts, ends)):
        n, h = e - f + 1, s - f
        tj = np.asarray(log.t[f:e + 1], float) - float(log.t[s])
        t[j, :n] = tj
        t[j, n:] = tj[-1] + np.arange(1, K - n + 1) * (tj[-1] / max(n - h - 1, 1))  # padding: ignored rows
        cmd[j, :n] = c_all[f:e + 1]
        cmd[j, n:] = c_all[e]
        out[j, :n] = np.nan_to_num(meas[f:e + 1])
        valid[j, h + 1:n] = ok[s + 1:e + 1]
    return SpeedWindows(t=t, cmd=cmd, meas=out, valid=valid, v0=meas[first])


def predict(sw: SpeedWindows, values: dict[str, float]) -> np.ndarray:
    """Predicted speeds (M, K, 2) of the chain ``values`` (robot keys; an absent limit: none)."""
    side = {k: np.array([values.get(f"{k}_left", 0.0 if k != "drive_speed_limit" else math.inf),
                         values.get(f"{k}_right", 0.0 if k != "drive_speed_limit" else math.inf)]) for k in SIDED}
    return window_response(sw.t, sw.cmd, sw.v0, scale=values.get("track_speed_scale", 1.0),
                           delay=side["drive_delay"], speed_limit=side["drive_speed_limit"],
                           accel_limit=values.get("drive_accel_limit", math.inf), tau=side["drive_lag"],
                           turn_scale=values.get("drive_turn_scale", 1.0),
                           mean_limit=values.get("drive_mean_speed_limit", math.inf),
                           turn_limit=values.get("drive_turn_limit", math.inf),
                           mean_accel_limit=values.get("drive_mean_accel_limit", math.inf),
                           turn_accel_limit=values.get("drive_turn_accel_limit", math.inf))


def described_chain(robot: Robot) -> dict[str, float]:
    """The chain a description gives, as the stage's parameter names (absent limits left out)."""
    out = {"track_speed_scale": robot.track_speed_scale, "drive_turn_scale": robot.drive_turn_scale}
    for i, s in enumerate(("left", "right")):
        out[f"drive_delay_{s}"] = robot.delay_per_side[i]
        out[f"drive_lag_{s}"] = robot.lag_per_side[i]
        if robot.speed_limit_per_side[i] is not None:
            out[f"drive_speed_limit_{s}"] = robot.speed_limit_per_side[i]
    for k in LIMITS[2:]:
        if getattr(robot, k) is not None:
            out[k] = getattr(robot, k)
    return out


def rms(sw: SpeedWindows, pred: np.ndarray) -> tuple[float, float]:
    """(left, right) RMS of measured - predicted speeds over the valid rows [m/s]."""
    d = (sw.meas - pred)[sw.valid]
    return tuple(float(np.sqrt(np.mean(d[:, i] ** 2))) for i in range(2))


@dataclass
class ChainFit:
    """What the drivetrain stage found.

    Attributes:
        values: the chain after the stage (robot keys); described values where the log does not
            determine them, absent limits where it shows none.
        half: 95 % half-width of each fitted parameter (same units).
        verdicts: each candidate -> "determined", "not determined: ..." (why).
        rms_before, rms_after: (left, right) wheel-speed RMS [m/s], chain as described / fitted.
        windows, clusters: windows fitted, clusters of the intervals.
    """

    values: dict[str, float]
    half: dict[str, float]
    verdicts: dict[str, str]
    rms_before: tuple[float, float]
    rms_after: tuple[float, float]
    windows: int
    clusters: int
    described: dict[str, float] = field(default_factory=dict)

    def robot(self, robot: Robot) -> Robot:
        """``robot`` with the stage's chain (per-side keys, which win over the both-sides ones; a
        limit the log does not show stays as described)."""
        return chain_robot(robot, self.values)

    def to_dict(self) -> dict:
        return {"values": dict(self.values), "half_width_95": dict(self.half), "verdicts": dict(self.verdicts),
                "described": dict(self.described),
                "wheel_speed_rms_before": {"left": self.rms_before[0], "right": self.rms_before[1]},
                "wheel_speed_rms_after": {"left": self.rms_after[0], "right": self.rms_after[1]},
                "windows": self.windows, "clusters": self.clusters}

    def lines(self) -> list[str]:
        """The stage's findings in words, one line each."""
        specs = chain_specs()
        out = [f"drivetrain fitted to the measured track speeds of {self.windows} windows: wheel-speed RMS "
               f"{self.rms_before[0]:.3f} / {self.rms_before[1]:.3f} m/s (left / right) as described, "
               f"{self.rms_after[0]:.3f} / {self.rms_after[1]:.3f} m/s fitted"]
        for name, verdict in self.verdicts.items():
            unit = specs[name].unit
            if name in self.half:
                unit = "" if unit == "–" else f" {unit}"
                out.append(f"  {name} = {self.values[name]:.3g} +- {self.half[name]:.2g}{unit}: {verdict}")
            else:
                out.append(f"  {name}: {verdict}")
        return out


def fit_chain(log: DriveLog, robot: Robot, *, horizon_s: float = 2.0, without: tuple[str, ...] = ()) -> ChainFit:
    """Fit the drivetrain chain of ``robot`` to the measured speeds of ``log`` (module docstring);
    the stages ``without`` (limit names of :data:`LIMITS`) are left out of the chain (a chain
    without them, to measure what they add)."""
    unknown = [n for n in without if n not in LIMITS]
    if unknown:
        raise InputError(f"drivetrain: only limits can be left out of the chain ({', '.join(LIMITS)}), got {unknown}")
    sw = speed_windows(log, horizon_s)
    specs = chain_specs()
    described = {k: v for k, v in described_chain(robot).items() if k not in without}
    before = rms(sw, predict(sw, described))
    start = {k: v for k, v in _start(sw, robot).items() if k not in without}
    free = list(start)
    fixed: dict[str, float] = {}
    verdicts: dict[str, str] = {}
    half: dict[str, float] = {}
    clusters = 0
    values = dict(fixed)
    # each pass either ends the loop or takes one candidate out of ``free``: it always ends
    for _ in range(len(start) + 1):
        if not free:
            values = dict(fixed)
            break
        theta = _least_squares(sw, specs, {n: start[n] for n in free}, fixed)
        values = {**fixed, **theta}
        start.update(theta)  # a refit after a change starts where this one ended
        dropped = False
        for name in [n for n in LIMITS if n in theta]:
            share, windows = _limit_activity(sw, values, name)
            if share < MIN_ACTIVE or windows < MIN_WINDOWS:
                verdicts[name] = (f"not determined: never reached (it changes {100 * share:.1f} % of the rows, in "
                                  f"{windows} windows)")
                free.remove(name)
                dropped = True
        if dropped:
            continue
        lin = _linearised(sw, specs, values, free)
        unc = lin.uncertainty(list(range(len(free))))
        half, clusters = dict(zip(free, unc.half)), unc.clusters
        vague = [n for n in free if n in LIMITS and (half[n] > LIMIT_SPREAD * values[n]
                                                      or values[n] >= specs[n].hi - specs[n].resolution)]
        if vague:
            worst = max(vague, key=lambda n: half[n] / values[n])
            verdicts[worst] = (f"not determined: the fit takes it to the top of its range, {specs[worst].hi:g} "
                               f"{specs[worst].unit} (the log asks for no limit)"
                               if values[worst] >= specs[worst].hi - specs[worst].resolution else
                               f"not determined: reached, but the log leaves it anywhere within +-{half[worst]:.2g} "
                               f"{specs[worst].unit} of {values[worst]:.3g}")
            free.remove(worst)
            continue
        loose = [n for n in free if n not in LIMITS and half[n] > specs[n].resolution
                 and abs(values[n] - described[n]) <= half[n]]
        if not loose:
            break
        worst = max(loose, key=lambda n: half[n] / specs[n].resolution)
        verdicts[worst] = (f"not determined (+-{half[worst]:.2g} {specs[worst].unit} around {values[worst]:.3g}): "
                           f"kept as described, {described[worst]:.3g}")
        free.remove(worst)
        fixed[worst] = described[worst]
    for n in free:
        verdicts.setdefault(n, "determined" if half[n] <= max(specs[n].resolution, 0.1 * abs(values[n]))
                            else f"fitted, interval wider than {max(specs[n].resolution, 0.1 * abs(values[n])):.2g}")
    after = rms(sw, predict(sw, values))
    out_values = {k: v for k, v in values.items() if k in free or k in fixed}
    return ChainFit(values=out_values, half={n: float(half[n]) for n in free},
                    verdicts={n: verdicts[n] for n in specs if n in verdicts}, rms_before=before, rms_after=after,
                    windows=len(sw), clusters=clusters, described=described)


def _start(sw: SpeedWindows, robot: Robot) -> dict[str, float]:
    """First values from what the log suggests: the largest measured speed of each side as its
    limit, the largest measured rate of change as the ramp; a short lag and dead time off their bound."""
    m = np.where(sw.valid[..., None], np.abs(sw.meas), 0.0)
    dt = np.diff(sw.t, axis=1)
    rate = np.abs(np.diff(sw.meas, axis=1)) / np.maximum(dt, 1e-9)[..., None]
    rate = rate[sw.valid[:, 1:] & sw.valid[:, :-1]]
    mean = np.where(sw.valid, 0.5 * np.abs(sw.meas.sum(-1)), 0.0)
    half = np.where(sw.valid, 0.5 * np.abs(np.diff(sw.meas, axis=-1)[..., 0]), 0.0)
    both = sw.valid[:, 1:] & sw.valid[:, :-1]
    twist_rate = [np.abs(np.diff(x, axis=1))[both] / np.maximum(dt, 1e-9)[both]
                  for x in (0.5 * sw.meas.sum(-1), 0.5 * np.diff(sw.meas, axis=-1)[..., 0])]
    return {"track_speed_scale": robot.track_speed_scale, "drive_turn_scale": robot.drive_turn_scale,
            "drive_delay_left": 0.03, "drive_delay_right": 0.03, "drive_lag_left": 0.1, "drive_lag_right": 0.1,
            "drive_speed_limit_left": float(m[..., 0].max()), "drive_speed_limit_right": float(m[..., 1].max()),
            "drive_accel_limit": float(np.quantile(rate, 0.99)) if rate.size else 5.0,
            "drive_mean_speed_limit": float(mean.max()), "drive_turn_limit": float(half.max()),
            **{k: float(np.quantile(r, 0.99)) if r.size else 5.0
               for k, r in zip(("drive_mean_accel_limit", "drive_turn_accel_limit"), twist_rate)}}


def _residuals(sw: SpeedWindows, values: dict[str, float]) -> np.ndarray:
    """(M, 2K): measured - predicted, zero on rows that are not fitted (window-major rows)."""
    d = np.where(sw.valid[..., None], predict(sw, values) - sw.meas, 0.0)
    return d.reshape(len(sw), -1)


def _least_squares(sw, specs, start: dict[str, float], fixed: dict[str, float]) -> dict[str, float]:
    names = list(start)
    sc = np.array([specs[n].scale for n in names])
    lo = np.array([specs[n].lo for n in names]) / sc
    hi = np.array([specs[n].hi for n in names]) / sc
    x0 = np.clip(np.array([start[n] for n in names]) / sc, lo + 1e-6, hi - 1e-6)

    def f(x):
        return _residuals(sw, {**fixed, **dict(zip(names, x * sc))}).ravel()

    # a relative step of 1e-3 scale units: the clamps make the residuals piecewise smooth
    res = least_squares(f, x0, bounds=(lo, hi), diff_step=1e-3, x_scale=1.0, max_nfev=200)
    return dict(zip(names, (res.x * sc).tolist()))


def _linearised(sw, specs, values: dict[str, float], names: list[str]) -> Linearised:
    """The fit linearised at ``values`` for the parameters ``names`` (central differences)."""
    r0 = _residuals(sw, values).ravel()
    cols = []
    for n in names:
        h = 1e-3 * specs[n].scale
        up = _residuals(sw, {**values, n: values[n] + h}).ravel()
        down = _residuals(sw, {**values, n: max(values[n] - h, specs[n].lo)}).ravel()
        cols.append((up - down) / (values[n] + h - max(values[n] - h, specs[n].lo)) * specs[n].scale)
    return Linearised(names=list(names), theta=np.array([values[n] / specs[n].scale for n in names]),
                      jac=np.stack(cols, axis=1), resid=r0, rows_per_window=r0.size // len(sw),
                      specs={n: specs[n] for n in names})


def _limit_activity(sw: SpeedWindows, values: dict[str, float], name: str) -> tuple[float, int]:
    """Share of the sides' valid rows whose predicted speed the limit ``name`` changes by more
    than :data:`ACTIVE_SPEED`, and in how many windows."""
    without = {k: v for k, v in values.items() if k != name}
    changed = np.abs(predict(sw, values) - predict(sw, without)) > ACTIVE_SPEED
    if name.endswith("_left"):
        changed = changed[..., 0]
    elif name.endswith("_right"):
        changed = changed[..., 1]
    else:
        changed = changed.any(axis=-1)
    changed &= sw.valid
    return float(changed.sum() / max(sw.valid.sum(), 1)), int(changed.any(axis=1).sum())




def has_measured_speeds(log: DriveLog) -> bool:
    """Whether the log has measured track speeds on most rows (the stage has something to fit)."""
    if log.v_left is None or log.v_right is None:
        return False
    return bool(np.mean(np.isfinite(log.v_left) & np.isfinite(log.v_right)) >= MIN_MEASURED)


def predicted_drive_log(log: DriveLog, values: dict[str, float]) -> DriveLog:
    """The log driven by the track speeds the chain ``values`` predicts from its commands (each
    segment from its measured start speeds, else at rest), the logged commands kept under
    ``LOGGED_COMMANDS`` as :func:`mjtrack.windows.measured_drive_log` keeps them (which
    windows are steady turns stays a property of the commands)."""
    slices = log.segment_slices()
    K = max(sl.stop - sl.start for sl in slices)
    S = len(slices)
    t = np.empty((S, K))
    cmd = np.empty((S, K, 2))
    v0 = np.zeros((S, 2))
    c_all = np.stack([log.v_left_cmd, log.v_right_cmd], -1).astype(float)
    for j, sl in enumerate(slices):
        n = sl.stop - sl.start
        tj = np.asarray(log.t[sl], float) - float(log.t[sl.start])
        t[j, :n] = tj
        t[j, n:] = tj[-1] + np.arange(1, K - n + 1) * (tj[-1] / max(n - 1, 1) if n > 1 else 0.05)
        cmd[j, :n] = c_all[sl]
        cmd[j, n:] = c_all[sl.stop - 1]
        if log.v_left is not None and log.v_right is not None:
            v0[j] = np.nan_to_num([log.v_left[sl.start], log.v_right[sl.start]])
    pred = predict(SpeedWindows(t=t, cmd=cmd, meas=np.zeros_like(cmd), valid=np.zeros(t.shape, bool), v0=v0), values)
    out = np.empty_like(c_all)
    for j, sl in enumerate(slices):
        out[sl] = pred[j, :sl.stop - sl.start]
    return dataclasses.replace(log, v_left_cmd=out[:, 0], v_right_cmd=out[:, 1],
                               extra={**log.extra, LOGGED_COMMANDS[0]: log.v_left_cmd,
                                      LOGGED_COMMANDS[1]: log.v_right_cmd})


def chain_robot(robot: Robot, values: dict[str, float], rolling: float = 1.0) -> Robot:
    """``robot`` driven by the chain ``values`` (command -> measured speed) and a contact whose
    track speed is ``rolling`` times the measured one (the effective rolling radius over the
    nominal one that the contact's fit found): the scale and the speed limits and ramp, in
    measured-speed units in ``values``, are multiplied by it."""
    changes = {k: float(v) * (rolling if k in LIMITS or k == "track_speed_scale" else 1.0) for k, v in values.items()}
    return robot.replace(**changes)


__all__ = ["ChainFit", "SpeedWindows", "chain_robot", "described_chain", "fit_chain", "has_measured_speeds", "predict",
           "predicted_drive_log", "rms", "speed_windows"]
