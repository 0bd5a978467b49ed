"""The result of a diagnosis (:class:`Diagnosis`, whose ``to_json()`` is diagnosis.json) and the
robot description a finding asks for (:func:`extended_robot`).

Below :mod:`.run`, :mod:`.confirm` and :mod:`.report`, which all use it: none of them imports
another to reach it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from mjtrack.diagnose import residuals as rs
from mjtrack.diagnose.baseline import Baseline
from mjtrack.diagnose.select import CandidateResult, Step, all_findings
from mjtrack.diagnose.vocabulary import slope_angle
from mjtrack.io.robot import Robot
from mjtrack.models.shear import lateral_shear_ratio_of

# what each baseline is, for the report's headings
TITLES = {"mujoco": "the MuJoCo robot as described", "coulomb": "the Coulomb surrogate of the robot as described",
          "kinematic": "the kinematic model of the robot as described"}
UNEXPLAINED = 0.5  # a warning when the final model keeps more than this share of the baseline RMSE


@dataclass
class Diagnosis:
    """The result of :func:`mjtrack.diagnose.run.diagnose`, whatever the baseline; ``to_json()`` is
    diagnosis.json.

    ``baseline``: the model diagnosed (:class:`mjtrack.diagnose.baseline.Baseline`); ``choice``:
    how it was chosen ({"requested", "chosen", "why"}; MuJoCo: also "screened_by_surrogate", the
    candidates the surrogate diagnosis ranked best, or None);
    ``starts``, ``ends``, ``base_errors``: the scored windows and the baseline's errors on them;
    ``diverged``: windows whose baseline simulation diverged (neither fitted nor scored);
    ``simulator_warnings``: the simulator's warnings, by window, and the answer with and without
    the windows that warned (:func:`mjtrack.diagnose.run.diagnose`), None when nothing is simulated.
    """

    log_path: str
    samples: int
    duration_s: float
    robot: Robot
    baseline: Baseline
    horizon_s: float
    before: float
    steps: list[Step]
    chosen: list[CandidateResult]
    skipped: dict[str, str]
    notes: list[str]
    data: rs.DriveData
    starts: np.ndarray
    ends: np.ndarray
    base_errors: np.ndarray
    n_folds: int
    noise_floor: float = 0.0
    timings: dict[str, float] = field(default_factory=dict)
    confirmation: dict | None = None
    test_log: str | None = None
    choice: dict = field(default_factory=dict)
    diverged: int = 0
    simulator_warnings: dict | None = None

    @property
    def transient(self) -> bool:
        """Whether the baseline models the friction-limited transient (the Coulomb surrogate)."""
        return bool(self.baseline.transient)

    @property
    def baseline_title(self) -> str:
        """What the baseline is, in words for headings ("the MuJoCo robot as described", ...)."""
        return TITLES.get(self.baseline.name, self.baseline.noun)

    @property
    def results(self) -> list[CandidateResult]:
        """Every candidate of the first step (against the nominal baseline)."""
        return self.steps[0].results if self.steps else []

    @property
    def findings(self) -> list[CandidateResult]:
        return all_findings(self.steps, self.chosen)

    @property
    def cause(self) -> str:
        f = self.findings
        return f[0].effect.name if f else "none"

    @property
    def final_after(self) -> float:
        """Held-out RMSE [m] of the model with every effect found (the baseline's when none)."""
        return float(min(r.after for r in self.chosen)) if self.chosen else float(self.before)

    @property
    def unexplained(self) -> float:
        """Share of the baseline RMSE that the model with every effect found keeps [-]."""
        return self.final_after / self.before if self.before > 0 else 0.0

    def warnings(self) -> list[str]:
        """Verdict warnings: unexplained error beyond the pose noise; effects the measured track
        speeds (input effects) or the pose (ground effects, or input effects without measured
        speeds) suggest in too few blocks of the log to establish them."""
        out = []
        sw = self.simulator_warnings
        if sw and (sw["windows"] or sw["outside_windows"]):
            out.append(self.simulator_warning_sentence())
        last = self.steps[-1].results if self.steps else []
        out += [r.below_floor for r in last if r.below_floor and not r.passed]
        if self.unexplained > UNEXPLAINED and self.final_after > 2.0 * self.noise_floor:
            what = " with " + " + ".join(r.effect.name for r in self.chosen) if self.chosen else ""
            out.append(f"most of the error remains unexplained: the model{what} keeps {100 * self.unexplained:.0f} % "
                       f"of the baseline's {self.horizon_s:g} s position RMSE ({self.final_after:.3g} of {self.before:.3g} m; "
                       f"the pose noise alone accounts for about {self.noise_floor:.2g} m). Something the effect "
                       "vocabulary does not name is at work: read the symptom tables before trusting the estimates")
        return out

    def simulator_warning_sentence(self) -> str:
        """The verdict's sentence on the simulator's warnings (:attr:`simulator_warnings`)."""
        sw = self.simulator_warnings
        ws = sw["windows"]
        text = (f"MuJoCo warned in {sw['simulations_warned']} simulation(s)"
                + (f" of {len(ws)} window(s) (starting at " + ", ".join(f"t = {w['t0']:.2f} s" for w in ws[:8])
                   + (", ..." if len(ws) > 8 else "") + ")" if ws else "")
                + (f" and {len(sw['outside_windows'])} time(s) outside any window" if sw["outside_windows"] else "")
                + f" ({(ws[0]['warnings'] if ws else sw['outside_windows'])[0]}): a simulation that warned is unstable "
                  "and counts as diverged")
        if sw["left_out"]:
            text += f"; {sw['left_out']} window(s) whose baseline simulation warned are left out (not scored)"
        ans = sw.get("answer")
        if ans:
            w, wo = ans["with_warned_windows"], ans["without_warned_windows"]
            text += (f"; scored without the {w['windows'] - wo['windows']} window(s) that warned, the first step names "
                     f"{wo['cause']}, with them {w['cause']}: "
                     + ("the answer changes with them, read it with care" if ans["changes"] else
                        "the answer does not change"))
        return text

    def summary(self) -> str:
        """The lines a terminal shows: cause(s), estimates, gain, warnings."""
        where = "test-log" if self.test_log else "held-out"
        lines = [f"baseline: {self.baseline.noun}" + (f" ({self.choice['why']})" if self.choice.get("why") else "")]
        if not self.chosen:
            lines.append(f"cause: none; baseline {self.horizon_s:g} s position RMSE {self.before:.3g} m")
        else:
            for i, r in enumerate(self.chosen):
                est = ", ".join(f"{n} = {num(v)}" for n, v in zip(r.effect.params, r.estimate))
                tied = [x.effect.name for x in self.findings if x is not r and r.effect.name in x.tied_with]
                lines.append(f"{'cause' if i == 0 else 'also'}: {r.effect.name} ({est})"
                             + (f" [indistinguishable here from {', '.join(tied)}]" if tied else "")
                             + f"; {where} {self.horizon_s:g} s position RMSE {r.before:.3g} -> {r.after:.3g} m")
        lines += [f"warning: {w}" for w in self.warnings()]
        return "\n".join(lines)

    def evidence(self, r: CandidateResult) -> str:
        e = r.effect
        est = ", ".join(f"{n} = {num(v)} [{num(a)}, {num(b)}]" for n, v, (a, b) in zip(e.params, r.estimate, r.interval))
        on_top = f" on top of {' + '.join(r.on_top_of)}" if r.on_top_of else ""
        where = "on the test log" if self.test_log else "on held-out folds"
        g = r.gain
        if e.name == "slope" and np.all(np.isfinite(r.estimate)):
            est += " ({})".format(describe(slope_angle(*(float(v) for v in r.estimate))) + " rad")
        text = (f"{est} removes{on_top} {100 * r.relative:.0f} % of the {self.horizon_s:g} s position error {where} "
                f"({r.before:.3g} -> {r.after:.3g} m"
                + (f"; one-sided 95 % bound {100 * g.lower:.0f} % by blocked bootstrap over {g.blocks} blocks" if g else "")
                + f"); its signature: {e.signature}")
        if r.speed_after is not None:
            text += f"; measured track speeds agree (speed RMSE {r.speed_before:.3g} -> {r.speed_after:.3g} m/s)"
        for note in r.tie_notes:
            text += "; " + note
        other = [n for n in r.tied_with if not any(n in note for note in r.tie_notes)]
        if other:
            text += (f"; cannot be told apart from {', '.join(other)} on this log "
                     "(held-out gains equal within noise)")
        return text + "."

    def _finding_json(self, r: CandidateResult) -> dict:
        out = {
            "effect": r.effect.name,
            "estimate": {n: clean(v) for n, v in zip(r.effect.params, r.estimate)},
            "interval": {n: [clean(a), clean(b)] for n, (a, b) in zip(r.effect.params, r.interval)},
            "gain": {"metric": "pos_err_m", "before": float(r.before), "after": float(r.after),
                     "relative": float(r.relative), "held_out": True},
            "evidence": self.evidence(r),
        }
        out.update(_derived(r))
        if r.on_top_of:
            out["on_top_of"] = list(r.on_top_of)
        if r.tied_with:
            out["tied_with"] = list(r.tied_with)
        return out

    def _candidate_json(self, r: CandidateResult) -> dict:
        return {
            "effect": r.effect.name, "kind": r.effect.kind, "finding": bool(r.passed),
            "estimate": {n: clean(v) for n, v in zip(r.effect.params, r.estimate)},
            "interval": {n: [clean(a), clean(b)] for n, (a, b) in zip(r.effect.params, r.interval)},
            "before": float(r.before), "after": float(r.after), "relative": float(r.relative),
            "gain_lower_95": clean(r.gain.lower) if r.gain else None, "t_folds": clean(r.t_stat),
            "decision": r.why, **_derived(r),
        }

    def to_json(self) -> dict:
        out = {
            "log": self.log_path, "samples": self.samples, "duration_s": self.duration_s,
            "baseline": {"model": self.baseline.describe(), "metric": "pos_err_m", "horizon_s": self.horizon_s,
                         "value": float(self.before), "simulator": self.baseline.name},
            "cause": self.cause,
            "findings": [self._finding_json(r) for r in self.findings],
            "candidates": [self._candidate_json(r) for r in self.results],
            "steps": [{"on_top_of": list(s.base), "baseline_value": float(s.before),
                       "added": s.chosen.effect.name if s.chosen else None,
                       "candidates": [self._candidate_json(r) for r in s.results]} for s in self.steps],
            "unexplained": {"final_value": self.final_after, "share_of_baseline": self.unexplained,
                            "pose_noise_floor": self.noise_floor},
            "warnings": self.warnings(),
            "not_tested": dict(self.skipped),
            "notes": list(self.notes),
            "method": {
                "gain": f"RMS position error after {self.horizon_s:g} s of open-loop prediction from every measured pose, "
                        + ("fitted on the log and scored on the test log" if self.test_log else
                           f"pooled over {self.n_folds} contiguous cross-validation folds (fit on the others)"),
                "selection": "forward selection over all effects: each step adds the best finding to the baseline and "
                             "tests every remaining effect on top of it, until none passes; an effect on top of others "
                             "must also beat, by the floor beyond noise, every other finding of the step before (a "
                             "model with one effect fewer), else the first is reported tied with that finding",
                "finding": "one-sided 95 % lower bound of the held-out relative gain above zero (blocked bootstrap over "
                           "blocks of windows) and a gain of at least the floor, a share of the nominal model's error "
                           "at every step",
                "interval": f"95 %, estimate +- t se, se the larger of {self.baseline.interval_method()} and the "
                            "delete-one-fold jackknife",
                "model_form": {"relative": self.baseline.model_form.rel,
                               "absolute": dict(self.baseline.model_form.absolute),
                               "measured_by": self.baseline.model_form.measured_by},
            },
            "validation": {"stage": f"{self.baseline.noun} ({'test log' if self.test_log else 'held-out'})",
                           "mujoco": self._confirmation_json()},
            "timings_s": {k: round(v, 3) for k, v in self.timings.items()},
            "diverged_windows": self.diverged,
            "simulator_warnings": self.simulator_warnings,
        }
        if self.test_log:
            out["test_log"] = self.test_log
        if self.choice.get("why"):
            out["baseline"]["choice"] = self.choice["why"]
        if self.choice.get("screened_by_surrogate") is not None:
            out["baseline"]["screened_by_surrogate"] = list(self.choice["screened_by_surrogate"])
        return out

    def _confirmation_json(self) -> dict:
        if self.confirmation is not None:
            return self.confirmation
        return {"stage": "mujoco", "run": False, "why": "not requested (mjtrack diagnose --confirm)"}


def _derived(r: CandidateResult) -> dict:
    """Quantities read off an estimate in other units: a slope's angle and uphill direction."""
    if r.effect.name != "slope" or not np.all(np.isfinite(r.estimate)):
        return {}
    return {"derived": slope_angle(*(float(v) for v in r.estimate))}


def clean(v) -> float | None:
    """A finite float, or None (JSON null) for inf/nan."""
    v = float(v)
    return v if math.isfinite(v) else None


def num(v) -> str:
    """A number for text: 4 significant digits, ∞ for infinities (never a Python repr)."""
    v = float(v)
    return f"{v:.4g}" if math.isfinite(v) else ("∞" if v > 0 else "-∞" if v < 0 else "nan")


def describe(values: dict) -> str:
    """``key = value, ...`` with numbers through :func:`num` (never a Python repr)."""
    parts = []
    for k, v in values.items():
        if isinstance(v, (bool, np.bool_)) or v is None or isinstance(v, str):
            parts.append(f"{k} = {v}")
        elif isinstance(v, (int, float, np.integer, np.floating)):
            parts.append(f"{k} = {num(v)}")
        else:
            parts.append(f"{k} = {v}")
    return ", ".join(parts)


def extended_robot(robot: Robot, effect: str, estimate: dict[str, float]) -> tuple[Robot, dict]:
    """The robot description a finding asks for, and the remaining non-robot changes (input
    transform or scene) as a dict of plain floats."""
    e = {k: float(v) for k, v in estimate.items()}
    if effect == "cg_x":
        return robot.replace(cg_x=e["cg_x"]), {}
    if effect == "cg_y":
        return robot.replace(cg_y=e["cg_y"]), {}
    if effect == "friction_scale":
        s = e["friction_scale"]
        return robot.replace(mu=robot.mu * s, mu_left=None if robot.mu_left is None else robot.mu_left * s,
                             mu_right=None if robot.mu_right is None else robot.mu_right * s), {}
    if effect == "mu_ratio":
        return robot.replace(mu_left=robot.friction_right * e["mu_ratio"], mu_right=robot.friction_right), {}
    if effect == "shear_modulus":  # (a shear ground keeps its ratio of moduli)
        K = e["shear_modulus"]
        ratio = lateral_shear_ratio_of(robot, None)
        return robot.replace(ground={"model": "shear", "shear_modulus": K, "lateral_shear_ratio": ratio} if K > 0
                             else {"model": "coulomb"}), {}
    if effect == "lateral_shear_ratio" and robot.ground.model == "shear":
        return robot.replace(ground={**robot.ground.to_dict(), "lateral_shear_ratio": e["lateral_shear_ratio"]}), {}
    return robot, e
