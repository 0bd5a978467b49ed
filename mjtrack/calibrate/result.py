"""What calibrate found (:class:`Calibration`, whose ``to_json`` is calibration.json) and the
files it writes (:func:`write_outputs`)."""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from mjtrack.calibrate.causes import Cause, cap_words, not_explained, saturation_words, speeds_worse, yaw_class_gaps
from mjtrack.calibrate.identify import Verdict
from mjtrack.calibrate.rounds import MAX_ROUNDS
from mjtrack.io.atomic import atomic_write_text, make_output_dir
from mjtrack.io.jsonfile import json_value
from mjtrack.io.logs import DriveLog
from mjtrack.io.robot import Robot
from mjtrack.windows import AGAINST_WHY, STUCK_WHY, WARMUP_S, WindowSet, commanded_log

if TYPE_CHECKING:  # MuJoCo is loaded by the functions that simulate, not by importing calibrate
    from mjtrack.calibrate.fit import FitResult
    from mjtrack.sim.windows import WindowResult

#: why windows are left out (calibration.json "left_out")
LEFT_OUT_WHY = (f'kind "against": {AGAINST_WHY}; kind "stuck": {STUCK_WHY} '
                "(keep them with --keep-contradicting)")


@dataclass
class Scored:
    """A robot scored on a log's windows: per-window errors (M, 3), RMS position error [m], the
    windows' simulated poses and track speeds (for yaw ratios and ICRs)."""

    errors: np.ndarray
    rms: float
    poses: np.ndarray
    speeds: np.ndarray
    diverged: int
    diverged_mask: np.ndarray  # (M,) windows whose simulation blew up

    def rms_on(self, index: np.ndarray) -> float:
        """RMS position error [m] of the windows ``index`` (:attr:`rms` when they are all)."""
        e = self.errors[np.asarray(index)]
        return float(np.sqrt(np.mean(e[:, 0] ** 2 + e[:, 1] ** 2)))

    @classmethod
    def of(cls, res: WindowResult, p: int = 0) -> "Scored":
        e = res.errors[p]
        return cls(errors=e, rms=float(np.sqrt(np.mean(e[:, 0] ** 2 + e[:, 1] ** 2))), poses=res.poses[p],
                   speeds=res.speeds[p], diverged=int(res.diverged[p].sum()), diverged_mask=res.diverged[p].copy())


#: calibration.json "simulated_wheel_speed" "metric"
WHEEL_SPEED_METRIC = ("wheel_speed_rms_m_s: the MuJoCo robot's simulated track (wheel) speeds minus the measured ones, "
                      "every row of every window after its start, windows that diverged before or after left out; "
                      "with the drives following measured or fitted speeds, the simulated speeds over the speed scale "
                      "(an effective rolling radius: the log measures turn rate times the nominal radius)")


#: the share of the largest |command| between which the commands are "lower" (speed_ratio)
LOW_COMMANDS = (0.2, 0.5)


def wheel_speed_rms(lg: DriveLog, ws: WindowSet, runs: list[tuple[np.ndarray, float]],
                    skip: np.ndarray) -> list[dict[str, float]] | None:
    """Per side RMS [m/s] of simulated / scale - measured track speeds of each run (speeds (M, K, 2)
    at the windows' rows, as :class:`Scored` has them; scale) over the rows of the windows not in
    ``skip`` (M,) after their start; None without measured speeds on those rows."""
    if not lg.has_track_speeds:
        return None
    meas = np.stack([lg.v_left, lg.v_right], -1).astype(float)
    keep = [j for j in range(len(ws)) if not skip[j]]
    if not keep:
        return None
    m = np.concatenate([meas[ws.starts[j] + 1:ws.ends[j] + 1] for j in keep])
    out = []
    for speeds, scale in runs:
        sim = np.concatenate([speeds[j, 1:ws.ends[j] - ws.starts[j] + 1] for j in keep]) / scale
        d = sim - m
        rms = {}
        for i, side in enumerate(("left", "right")):
            ok = np.isfinite(d[:, i])
            if not ok.any():
                return None
            rms[side] = float(np.sqrt(np.mean(d[ok, i] ** 2)))
        out.append(rms)
    return out


def speed_ratio(command: np.ndarray, measured: np.ndarray, peak: float) -> float:
    """Median measured over commanded speed of one side on the rows whose |command| lies between
    :data:`LOW_COMMANDS` of its ``peak`` (well below any saturation, above the noise of a standstill);
    1 when there are none."""
    c, m = np.abs(np.asarray(command, float)), np.abs(np.asarray(measured, float))
    if not peak > 0:
        return 1.0
    rows = (c >= LOW_COMMANDS[0] * peak) & (c <= LOW_COMMANDS[1] * peak) & np.isfinite(m)
    return float(np.median(m[rows] / c[rows])) if rows.any() else 1.0


def drive_caps(lg: DriveLog, chain: dict[str, float] | None = None) -> str:
    """What the log's measured track speeds show the robot's own speed controller capping, in
    words ("" when nothing, or when the log has no measured speeds): each side's speed
    (:func:`mjtrack.calibrate.causes.saturation_words`), the turn (the half difference of the two
    sides) and the mean speed (:func:`mjtrack.calibrate.causes.cap_words`), each judged by its
    largest |command| and |measured value| with the commands scaled by what the lower commands
    give (:func:`speed_ratio`); ``chain``: a drivetrain fitted to the measured speeds
    (:mod:`mjtrack.calibrate.drivetrain`), whose limits are quoted beside."""
    if not lg.has_track_speeds:
        return ""
    chain = chain or {}
    cmd = commanded_log(lg)
    cl, cr = (np.asarray(v, float) for v in (cmd.v_left_cmd, cmd.v_right_cmd))
    ml, mr = (np.asarray(v, float) for v in (lg.v_left, lg.v_right))

    def peaks(c, m):
        pc, pm = float(np.nanmax(np.abs(c))), float(np.nanmax(np.abs(m)))
        return pc, pm, speed_ratio(c, m, pc)

    sides = [peaks(cl, ml), peaks(cr, mr)]
    words = [saturation_words(tuple(p[0] for p in sides), tuple(p[1] for p in sides),
                              tuple(chain.get(f"drive_speed_limit_{side}") for side in ("left", "right")),
                              tuple(p[2] for p in sides))]
    for what, c, m, key in (("the turn", (cr - cl) / 2, (mr - ml) / 2, "drive_turn_limit"),
                            ("the mean speed", (cl + cr) / 2, (ml + mr) / 2, "drive_mean_speed_limit")):
        words.append(cap_words(what, *peaks(c, m), limit=chain.get(key)))
    return "; ".join(w for w in words if w)


@dataclass
class Calibration:
    """Everything calibrate found; :meth:`to_json` is calibration.json.

    ``names``: every parameter the fit was allowed to move; ``values``: their calibrated values
    (the described value for those the log does not determine or does not need changed);
    ``verdicts``: what the log says of each (:class:`mjtrack.calibrate.identify.Verdict`);
    ``fit``: the first fit (all of ``names``; after a blow-up on an unused window, the second
    attempt's fit of the parameters the first one changed), ``refit``: the final fit of the kept parameters
    (None when nothing was kept or all were); ``causes``: the measured causes of the improvement."""

    train_path: str
    test_path: str | None
    robot: Robot
    calibrated: Robot
    track_model: str
    horizon_s: float
    names: list[str]
    values: dict[str, float]
    described: dict[str, float]
    verdicts: dict[str, Verdict]
    fixed: dict[str, float]
    assumed: dict[str, str]
    fit: FitResult
    refit: FitResult | None
    model_form: dict[str, dict[str, float]]
    causes: list[Cause]
    train_windows: WindowSet
    test_windows: WindowSet | None
    train_log: DriveLog
    test_log: DriveLog | None
    before: Scored
    after: Scored
    test_before: Scored | None
    test_after: Scored | None
    findings: list[dict]
    sentence: str
    config: dict
    timings: dict[str, float] = field(default_factory=dict)
    drive_input: str = "commanded"
    #: the drive input calibrate used ("commanded", "measured" or "fitted": ``drive_input`` is what the
    #: calibrated robot's drives follow, commands with "fitted") and why (what "auto" saw in the log)
    drive_input_mode: str = "commanded"
    drive_input_why: str = "asked for"
    fit_windows: WindowSet | None = None  # the windows the fit used (None: every training window)
    rounds: int = MAX_ROUNDS  # the most refits after the first fit it was allowed (calibrate's ``rounds``)
    #: the fit started again from other friction levels because a changed value ended on a bound: one
    #: record per attempt ("mu_start", "train_rms_m", "on_bound", "kept"), the first the fit's own start
    restarts: list[dict] = field(default_factory=list)
    #: the turn stage's record (:meth:`mjtrack.calibrate.turns.TurnMatch.to_json`) when it ran: the
    #: pose fit's robot turned unlike the log in a class of the training part's steady turns
    turns: dict | None = None
    #: windows simulated by the whole calibration: every stage and every attempt (a window's warm-up
    #: is part of its simulation); None: not counted (then the fit's own passes are reported)
    simulated_windows: int | None = None
    #: windows left out because their poses move against the tracks (see
    #: :func:`mjtrack.sim.windows.contradicting_windows`), by part ("train", "test")
    left_out: dict[str, list[dict]] = field(default_factory=dict)
    #: the drivetrain fitted first to the log's measured track speeds (commanded drive, a log
    #: with measured speeds: :mod:`mjtrack.calibrate.drivetrain`), else None
    drivetrain: object = None

    @property
    def fitted_windows(self) -> WindowSet:
        return self.train_windows if self.fit_windows is None else self.fit_windows

    @property
    def changed(self) -> list[str]:
        return [n for n in self.names if self.verdicts[n].changed]

    def simulated_wheel_speeds(self) -> dict | None:
        """The MuJoCo robot's simulated track speeds against the measured ones, per part ("train",
        "test"): ``before`` and ``after`` RMS per side [m/s] (:data:`WHEEL_SPEED_METRIC`) and the
        windows; None when the log has no measured track speeds."""
        measured_in = self.drive_input_mode in ("measured", "fitted")
        before = self.described.get("track_speed_scale", 1.0) if measured_in else 1.0
        after = self.values["track_speed_scale"] if measured_in and "track_speed_scale" in self.changed else before
        parts = [("train", self.train_log, self.train_windows, self.before, self.after)]
        if self.test_log is not None and self.test_before is not None and self.test_after is not None:
            parts.append(("test", self.test_log, self.test_windows, self.test_before, self.test_after))
        out = {}
        for label, lg, ws, b, a in parts:
            skip = b.diverged_mask | a.diverged_mask
            r = wheel_speed_rms(lg, ws, [(b.speeds, before), (a.speeds, after)], skip)
            if r is None:
                return None
            out[label] = {"before": r[0], "after": r[1], "windows": int((~skip).sum())}
        return out

    def saturation(self) -> str:
        """The drives' saturation in words, as the training log's measured track speeds show it
        (:func:`drive_caps`), or ""."""
        return drive_caps(self.train_log, {} if self.drivetrain is None else self.drivetrain.values)

    def not_explained(self, speeds: dict | None = None) -> list[dict]:
        """What the log shows that no candidate describes (calibration.json ``not_explained``): the
        implausible causes and contradicting simulated speeds
        (:func:`mjtrack.calibrate.causes.not_explained`; ``speeds``: :meth:`simulated_wheel_speeds`),
        and, with the drives following the commands, drives that saturate."""
        out = not_explained(self.causes, speeds)
        sat = self.saturation()
        if sat and self.drive_input_mode == "commanded":
            out.append({"what": "drives that saturate", "parameters": [], "acts_like": sat, "why": [], "share": None})
        yaw = yaw_class_gaps(self.findings) if self.changed else ""
        if yaw:
            out.append({"what": "yaw ratio by turn class", "parameters": [], "acts_like": yaw, "why": [], "share": None})
        return out

    def evidence(self) -> str:
        """What the measured track speeds add to the summary: the drives' saturation (with
        ``--drive-input commanded``, as what no candidate describes), a calibrated robot whose
        simulated speeds are further from them than the described robot's; "" when nothing."""
        text = ""
        sat = self.saturation()
        if sat and self.drive_input_mode == "fitted":
            text += f" The drivetrain fitted to the measured speeds says {sat}."
        elif sat and self.drive_input_mode == "commanded":
            text += (f" The log's measured track speeds show what no candidate here describes: {sat} "
                     "(--drive-input fitted fits the drives to them).")
        yaw = yaw_class_gaps(self.findings) if self.changed else ""
        if yaw:
            text += (f" {yaw[0].upper()}{yaw[1:]}: the end poses and the steady turns ask for different values of the "
                     "candidates, or for something none of them describes.")
        worse = speeds_worse(self.simulated_wheel_speeds())
        if worse:
            text += f" Warning: {worse}."
        return text

    def to_json(self) -> dict:
        fits = [self.fit] + ([self.refit] if self.refit is not None else [])
        out = {
            "simulator": "mujoco", "track_model": self.track_model, "drive_input": self.drive_input,
            "drive_input_mode": self.drive_input_mode, "drive_input_why": self.drive_input_why,
            "parameters": {n: self.values[n] for n in self.names},
            "intervals": {n: list(v.interval) for n, v in self.verdicts.items() if v.interval is not None},
            "determined": {n: self.verdicts[n].to_json() for n in self.names},
            "described": self.described,
            "changed": self.changed,
            "fixed": self.fixed, "assumed": self.assumed,
            "train": {"log": self.train_path, "metric": "pos_err_m", "horizon_s": self.horizon_s,
                      "before": self.before.rms, "after": self.after.rms, "windows": len(self.train_windows),
                      "fit_windows": len(self.fitted_windows)},
            "findings": self.findings,
            "causes": [c.to_json() for c in self.causes],
            "summary": self.sentence,
            "model_form": self.model_form,
            "start": self.fit.start, "starts_tried": [{"parameters": p, "cost": c} for p, c in self.fit.starts_tried],
            "method": {"optimizer": self.fit.method, "rounds": self.rounds, "friction_restarts": self.restarts,
                       "turns": self.turns,
                       "fits": [{"parameters": f.names, "iterations": f.iterations, "cost_start": f.cost_start,
                                 "cost_final": f.cost_final} for f in fits],
                       "simulated_windows": (sum(f.evaluations for f in fits) * len(self.fitted_windows)
                                             if self.simulated_windows is None else self.simulated_windows),
                       "intervals": "95 %: cluster-robust sandwich over clusters of consecutive windows (Student t), "
                                    "plus the model-form shift of each parameter (a finer simulator, a longer "
                                    "warm-up of the hidden states), linearised at the optimum",
                       "determined": "half-width at most the parameter's resolution; a parameter that is not "
                                     "determined, or whose described value lies in its interval, keeps the "
                                     "described value",
                       "windows": "each window simulated from the measured state at its start (pose, twist, "
                                  f"track speeds), hidden states warmed up over up to {WARMUP_S:g} s of the log "
                                  "before it; errors at the window's end in its start frame"},
            "sim_config": self.config,
            "timings_s": self.timings,
            "left_out": {part: {"why": LEFT_OUT_WHY, "windows": rows} for part, rows in self.left_out.items() if rows},
        }
        speeds = self.simulated_wheel_speeds()
        out["not_explained"] = self.not_explained(speeds)
        if speeds is not None:
            out["simulated_wheel_speed"] = {"metric": WHEEL_SPEED_METRIC, "before_is": (
                "the described contact driven through the fitted drivetrain" if self.drive_input_mode == "fitted"
                else "the described robot"), **speeds}
        if self.drivetrain is not None:
            out["drivetrain"] = {**self.drivetrain.to_dict(), "metric": "wheel_speed_rms_m_s (measured - the "
                                 "chain's prediction from the commands, rows of every window after its start)"}
        if self.test_before is not None and self.test_after is not None:
            b, a = self.test_before.rms, self.test_after.rms
            out["test"] = {"log": self.test_path, "metric": "pos_err_m", "horizon_s": self.horizon_s,
                           "before": b, "after": a, "relative": 1.0 - a / b if b > 0 else 0.0,
                           "windows": len(self.test_windows)}
        return out


def write_outputs(cal: Calibration, out: str | os.PathLike) -> None:
    """DIR/robot.json, DIR/calibration.json, DIR/report.html (each written atomically)."""
    from mjtrack.calibrate.report import build_report

    out = Path(out)
    report = build_report(cal)  # built first: a failure here leaves nothing half-written
    make_output_dir(out)
    atomic_write_text(out / "robot.json", json.dumps(json_value(cal.calibrated.to_dict()), indent=2, sort_keys=True) + "\n")
    atomic_write_text(out / "calibration.json", json.dumps(json_value(cal.to_json()), indent=2) + "\n")
    report.write(out / "report.html")


__all__ = ["Calibration", "Scored", "write_outputs"]
