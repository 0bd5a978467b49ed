"""What calibrate found (:class:`Calibration`, whose ``to_json`` is calibration.json) and the
files it writes (:func:`write_outputs`)."""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from mjtrack.calibrate.causes import Cause
from mjtrack.calibrate.identify import Verdict
from mjtrack.io.atomic import atomic_write_text, make_output_dir
from mjtrack.io.jsonfile import json_value
from mjtrack.io.logs import DriveLog
from mjtrack.io.robot import Robot
from mjtrack.windows import AGAINST_WHY, STUCK_WHY, WARMUP_S, WindowSet

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

    @classmethod
    def of(cls, res: WindowResult, p: int = 0) -> "Scored":
        e = res.errors[p]
        return cls(errors=e, rms=float(np.sqrt(np.mean(e[:, 0] ** 2 + e[:, 1] ** 2))), poses=res.poses[p],
                   speeds=res.speeds[p], diverged=int(res.diverged[p].sum()), diverged_mask=res.diverged[p].copy())


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
    fit_windows: WindowSet | None = None  # the windows the fit used (None: every training window)
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

    def to_json(self) -> dict:
        fits = [self.fit] + ([self.refit] if self.refit is not None else [])
        out = {
            "simulator": "mujoco", "track_model": self.track_model, "drive_input": self.drive_input,
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
            "method": {"optimizer": self.fit.method,
                       "fits": [{"parameters": f.names, "iterations": f.iterations, "cost_start": f.cost_start,
                                 "cost_final": f.cost_final} for f in fits],
                       "simulated_windows": sum(f.evaluations for f in fits) * len(self.fitted_windows),
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
