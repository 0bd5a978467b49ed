"""Section 4.1 of the tracked-robot thesis: the MPP, MICR and MVIR models agree.

The thesis drives a U-shaped path with track-speed commands V_L(t), V_R(t) (its fig. 4.1),
takes the MPP model (2.9) with prescribed slips as the truth, computes from the MPP twist at
every sample the ICRs (2.13) for MICR (2.14) and the virtual robot (2.16)-(2.20) for MVIR, and
shows that the three models drive the same path (figs. 4.2, 4.4, 4.6) in three cases: (a) no
slip (all equal the nominal path of (2.1)), (b) longitudinal slip, (c) lateral slip.

Reconstruction of fig. 4.1 (the printed figure carries no numbers; :class:`UPath`). The robot
(T = 0.4 m, the default robot's gauge) drives straight at V = 0.5 m/s, makes a left half-turn
(yaw +pi) whose yaw rate ramps linearly 0 -> pi/6 rad/s in 1 s, holds pi/6 rad/s for 5 s and
ramps back to 0 in 1 s (angle = (pi/6)(5 + 1) s = pi), then drives straight again:
straight 0-10 s, turn 10-17 s, straight 17-27 s. Why this shape: the thesis's slip schedule of
case (b) switches at 10 s and 17 s and its lateral case holds "pi/6 rad/s while rotating"; a
constant-rate half-turn at pi/6 lasts 6 s, so a 7 s turn window with 1 s ramps is the profile
whose turn coincides with the schedule's both-tracks-slip window (``UPath(turn_start=10.5,
ramp=0)`` is the constant-rate alternative). V_L = V - w T/2, V_R = V + w T/2 (inverse of (2.1)).
V = 0.5 m/s, a walking-pace speed of a small tracked robot, gives 5 m legs and a 0.95 m turn
radius, so the U (1.9 m wide) is wide compared with the gauge and reads as a U in the figures.
The slip values are the thesis's: 0.1, pi/12 rad and 2 %; the constant left slip of case (c) is
not printed and is taken equal to case (b)'s 0.1; "while rotating at pi/6" is the hold phase
(11-16 s), the ramps count as "otherwise".

``max_dev_m`` is the largest distance between the MPP, MICR and MVIR positions at any sample.

Derivation and measurements: docs/theory/tracked.md, "Section 4.1 reproduced".
"""

from __future__ import annotations

import logging
import math
from dataclasses import asdict, dataclass
from typing import ClassVar

import numpy as np

from mjtrack.errors import InputError
from mjtrack.icr import icr_from_twist, virtual_robot_from_twist
from mjtrack.models import MICR, MPP, MVIR, KinematicModel, Nominal, integrate

log = logging.getLogger(__name__)

MODEL_NAMES = ("MPP", "MICR", "MVIR")  # the compared models; "nominal" is the reference path (2.1)
AGREE_TOL = 1e-9  # [m] paths count as identical below this distance
FALLBACK_TOL = 1e-12  # [m/s, rad/s] the nominal parameters count as exact where the twists differ by less


def _on_grid(value: float, dt: float) -> bool:
    return abs(value / dt - round(value / dt)) < 1e-9


@dataclass(frozen=True)
class UPath:
    """Reconstructed command profile of fig. 4.1 (see the module docstring). SI units."""

    speed: float = 0.5  # V [m/s]
    track_gauge: float = 0.4  # T [m]
    turn_rate: float = math.pi / 6  # peak yaw rate of the left half-turn [rad/s]
    turn_start: float = 10.0  # [s]
    ramp: float = 1.0  # duration of each linear yaw-rate ramp [s]
    duration: float = 27.0  # [s]
    dt: float = 0.01  # [s]

    def __post_init__(self):
        for name in ("speed", "track_gauge", "turn_rate", "duration", "dt"):
            if not getattr(self, name) > 0:
                raise InputError(f"UPath: {name} must be > 0, got {getattr(self, name)}")
        if self.ramp < 0 or self.hold < 0:
            raise InputError(f"UPath: ramp must be in [0, pi/turn_rate = {math.pi / self.turn_rate:g}] s, got {self.ramp}")
        if not (0 <= self.turn_start and self.turn_end <= self.duration + self.dt / 2):
            raise InputError(f"UPath: the turn [{self.turn_start}, {self.turn_end:g}] s must lie in [0, {self.duration}] s")
        for name, value in (("turn_start", self.turn_start), ("ramp", self.ramp), ("hold", self.hold), ("duration", self.duration)):
            if not _on_grid(value, self.dt):
                raise InputError(f"UPath: {name} = {value:g} s is not a multiple of dt = {self.dt:g} s")

    @property
    def hold(self) -> float:
        """Time at the peak rate [s]: rate·(hold + ramp) = pi (two half-area ramps)."""
        return math.pi / self.turn_rate - self.ramp

    @property
    def turn_end(self) -> float:
        return self.turn_start + 2 * self.ramp + self.hold

    @property
    def times(self) -> np.ndarray:
        """(N,) sample times [s], N = duration/dt + 1."""
        return np.arange(round(self.duration / self.dt) + 1) * self.dt

    @property
    def midpoints(self) -> np.ndarray:
        """(N,) t_k + dt/2 [s], where the held command of sample k is evaluated."""
        return self.times + self.dt / 2

    def holding(self) -> np.ndarray:
        """(N,) bool: samples that rotate at the peak rate (the hold phase)."""
        tm = self.midpoints
        return (tm > self.turn_start + self.ramp) & (tm < self.turn_end - self.ramp)

    def yaw_rate(self) -> np.ndarray:
        """(N,) nominal yaw rate [rad/s] held over each step (mean of the trapezoid profile)."""
        tm = self.midpoints
        t0, t1, r = self.turn_start, self.turn_end, self.ramp
        if r == 0:
            shape = ((tm > t0) & (tm < t1)).astype(float)
        else:
            shape = np.clip(np.minimum(tm - t0, t1 - tm) / r, 0.0, 1.0)
        return self.turn_rate * shape

    def commands(self) -> tuple[np.ndarray, np.ndarray]:
        """(V_L, V_R), each (N,) [m/s]: V -/+ w·T/2 (inverse of (2.1))."""
        half = self.yaw_rate() * self.track_gauge / 2
        return self.speed - half, self.speed + half

    @property
    def _pi6(self) -> str:
        return " = pi/6" if math.isclose(self.turn_rate, math.pi / 6) else ""

    def describe(self) -> dict:
        """The reconstruction as JSON-ready numbers and one sentence."""
        return {
            **asdict(self),
            "hold": self.hold,
            "turn_end": self.turn_end,
            "samples": int(self.times.size),
            "description": (
                f"fig. 4.1 reconstructed: straight at V = {self.speed:g} m/s for {self.turn_start:g} s, a left half-turn "
                f"{self.turn_start:g}-{self.turn_end:g} s (yaw rate ramps 0 -> {self.turn_rate:.4f} rad/s{self._pi6} in "
                f"{self.ramp:g} s, holds {self.hold:g} s, ramps down in {self.ramp:g} s; total yaw pi), straight to "
                f"{self.duration:g} s; T = {self.track_gauge:g} m, dt = {self.dt:g} s, commands held over each step "
                "(value at the step midpoint)"
            ),
        }


@dataclass(frozen=True)
class SlipCase:
    """Truth parameters of MPP per sample: s_left, s_right [-], alpha [rad], each (N,)."""

    name: str
    description: str
    s_left: np.ndarray
    s_right: np.ndarray
    alpha: np.ndarray

    def __post_init__(self):
        shapes = {np.shape(self.s_left), np.shape(self.s_right), np.shape(self.alpha)}
        if len(shapes) != 1 or len(next(iter(shapes))) != 1:
            raise InputError(f"SlipCase {self.name}: s_left, s_right, alpha must be 1-D of one length, got {shapes}")


def no_slip(path: UPath) -> SlipCase:
    """Case (a): s_L = s_R = alpha = 0."""
    z = np.zeros(path.times.size)
    return SlipCase("no_slip", "no slip: s_L = s_R = alpha = 0", z, z.copy(), z.copy())


def longitudinal_slip(path: UPath, *, slip: float = 0.1, t_both: float = 10.0, t_right: float = 17.0) -> SlipCase:
    """Case (b): s_L = slip before t_both, both tracks until t_right, then only s_R; alpha = 0."""
    tm = path.midpoints
    s_left = np.where(tm < t_right, slip, 0.0)
    s_right = np.where(tm > t_both, slip, 0.0)
    return SlipCase(
        "longitudinal_slip",
        f"longitudinal slip {slip:g}: left track alone 0-{t_both:g} s, both tracks {t_both:g}-{t_right:g} s, "
        f"right track alone {t_right:g}-{path.duration:g} s; alpha = 0",
        s_left, s_right, np.zeros_like(tm),
    )


def lateral_slip(path: UPath, *, slip_left: float = 0.1, alpha_turn: float = math.pi / 12, fraction: float = 0.02) -> SlipCase:
    """Case (c): constant s_L; alpha = alpha_turn while holding the peak rate, fraction·alpha_turn otherwise."""
    n = path.times.size
    alpha = np.where(path.holding(), alpha_turn, fraction * alpha_turn)
    return SlipCase(
        "lateral_slip",
        f"lateral slip: s_L = {slip_left:g} throughout, s_R = 0, alpha = {alpha_turn:.4f} rad (pi/12) while rotating at "
        f"pi/6 rad/s ({path.turn_start + path.ramp:g}-{path.turn_end - path.ramp:g} s), {fraction:g} of that otherwise",
        np.full(n, slip_left), np.zeros(n), alpha,
    )


CASES = (no_slip, longitudinal_slip, lateral_slip)


@dataclass(frozen=True)
class _Replay(KinematicModel):
    """Replays a given body-twist sequence (N, 3) whatever the commands (for :func:`integrate`)."""

    values: np.ndarray
    name: ClassVar[str] = "replay"
    param_names: ClassVar[tuple[str, ...]] = ()

    def twist(self, v_left, v_right) -> np.ndarray:
        return self.values


@dataclass(frozen=True)
class CaseResult:
    """Paths and parameters of one case. Arrays (N,) unless stated; paths (N, 3) [m, m, rad]."""

    case: SlipCase
    paths: dict  # "nominal", "MPP", "MICR", "MVIR", "MICR_finite", "MVIR_finite" -> (N, 3)
    twists: dict  # same keys except "nominal": body twists (N, 3) [m/s, m/s, rad/s] that were integrated
    icr: dict  # "y_l", "y_r", "x_c" [m] fed to MICR (finite everywhere; nominal where not regular)
    virtual: dict  # "x_o", "y_o", "track" [m] fed to MVIR (likewise)
    virtual_raw: dict  # the same by (2.16)-(2.20) as printed-corrected, NaN where wz = 0 (for fig. 4.7 only)
    regular: np.ndarray  # bool: parameters by (2.13)
    straight: np.ndarray  # bool: ICRs at infinity, nominal parameters exact
    unrepresentable: np.ndarray  # bool: no finite parameters reproduce the MPP twist


def run_case(path: UPath, case: SlipCase, *, pose0=(0.0, 0.0, 0.0)) -> CaseResult:
    """Integrate the nominal model, MPP (truth) and MICR/MVIR with parameters from the MPP twist."""
    t = path.times
    vl, vr = path.commands()
    big_t = path.track_gauge
    mpp = MPP(big_t, s_left=case.s_left, s_right=case.s_right, alpha=case.alpha)
    tw = mpp.twist(vl, vr)
    icr = icr_from_twist(tw[:, 0], tw[:, 1], tw[:, 2], vl, vr, on_singular="mask")
    vir = virtual_robot_from_twist(tw[:, 0], tw[:, 1], tw[:, 2], vl, vr, on_singular="mask")
    regular = icr.valid & (vl != vr)
    nominal_err = np.max(np.abs(tw - Nominal(big_t).twist(vl, vr)), axis=-1)
    straight = ~regular & (nominal_err <= FALLBACK_TOL)
    unrep = ~regular & ~straight
    icr_p = {
        "y_l": np.where(regular, icr.y_l, big_t / 2),
        "y_r": np.where(regular, icr.y_r, -big_t / 2),
        "x_c": np.where(regular, icr.x_c, 0.0),
    }
    vir_p = {
        "x_o": np.where(regular, vir.x_o, 0.0),
        "y_o": np.where(regular, vir.y_o, 0.0),
        "track": np.where(regular, vir.track, big_t),
    }
    twists = {"MPP": tw}
    paths = {"nominal": integrate(Nominal(big_t), pose0, t, vl, vr), "MPP": integrate(mpp, pose0, t, vl, vr)}
    for name, model in (("MICR", MICR(**icr_p)), ("MVIR", MVIR(**vir_p))):
        finite = model.twist(vl, vr)
        extended = np.where(unrep[:, None], tw, finite)
        twists[name], twists[name + "_finite"] = extended, finite
        paths[name] = integrate(_Replay(extended), pose0, t, vl, vr)
        paths[name + "_finite"] = integrate(model, pose0, t, vl, vr)
    if unrep.any():
        log.info("%s: %d of %d samples cannot be represented by finite ICRs (largest twist error %.3g)",
                 case.name, int(unrep.sum()), unrep.size, float(nominal_err[unrep].max()))
    vir_raw = {"x_o": vir.x_o, "y_o": vir.y_o, "track": vir.track}
    return CaseResult(case, paths, twists, icr_p, vir_p, vir_raw, regular, straight, unrep)


def _max_dist(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(np.hypot(a[:, 0] - b[:, 0], a[:, 1] - b[:, 1])))


def max_dev_m(result: CaseResult, names=MODEL_NAMES) -> float:
    """Largest distance [m] between any two of the ``names`` paths (MPP, MICR, MVIR) at any sample."""
    p = result.paths
    return max(_max_dist(p[a], p[b]) for i, a in enumerate(names) for b in names[i + 1:])


def virtual_centre_steps(path: UPath, result: CaseResult) -> list[dict]:
    """The virtual centre (2.16) before/after each step of alpha (fig. 4.7): times [s], x_o, y_o [m].

    Values are None where the centre is undefined (wz = 0).
    """
    a, v = result.case.alpha, result.virtual_raw

    def at(k: int) -> dict:
        return {key: (float(v[key][k]) if np.isfinite(v[key][k]) else None) for key in ("x_o", "y_o")}

    steps = []
    for k in np.flatnonzero(np.diff(a) != 0) + 1:
        before, after = at(k - 1), at(k)
        known = None not in (*before.values(), *after.values())
        steps.append({
            "t_s": float(path.times[k]), "alpha_before": float(a[k - 1]), "alpha_after": float(a[k]),
            "before": before, "after": after,
            "jump_m": math.hypot(after["x_o"] - before["x_o"], after["y_o"] - before["y_o"]) if known else None,
        })
    return steps


def summarize(path: UPath, result: CaseResult) -> dict:
    """JSON-ready numbers of one case (see the module docstring for the sample classes)."""
    p, tw = result.paths, result.twists
    rep = ~result.unrepresentable
    yaw = max(float(np.max(np.abs(p[a][:, 2] - p[b][:, 2]))) for a in MODEL_NAMES for b in MODEL_NAMES)
    out = {
        "description": result.case.description,
        "max_dev_m": max_dev_m(result),
        "max_dev_yaw_rad": yaw,
        "nominal_dev_m": {name: _max_dist(p[name], p["nominal"]) for name in MODEL_NAMES},
        "final_pose": {name: [float(v) for v in p[name][-1]] for name in ("nominal", *MODEL_NAMES)},
        "samples": {
            "regular": int(result.regular.sum()),
            "straight_icr_at_infinity": int(result.straight.sum()),
            "unrepresentable": int(result.unrepresentable.sum()),
        },
        "max_twist_err_representable": {
            name: float(np.max(np.abs(tw[name][rep] - tw["MPP"][rep]), initial=0.0)) for name in ("MICR", "MVIR")
        },
        "max_dev_finite_m": max_dev_m(result, ("MPP", "MICR_finite", "MVIR_finite")),
        "final_pose_finite": {name: [float(v) for v in p[name + "_finite"][-1]] for name in ("MICR", "MVIR")},
    }
    if np.any(result.case.alpha != result.case.alpha[0]):
        out["virtual_centre_steps"] = virtual_centre_steps(path, result)
    return out


@dataclass(frozen=True)
class Ex41:
    """Everything section 4.1 computes: the reconstruction, its commands and the three cases."""

    path: UPath
    v_left: np.ndarray
    v_right: np.ndarray
    results: dict  # case name -> CaseResult


def compute(path: UPath | None = None) -> Ex41:
    """Run the three cases of section 4.1 on ``path`` (default: the reconstruction of fig. 4.1)."""
    path = path or UPath()
    vl, vr = path.commands()
    results = {}
    for make in CASES:
        case = make(path)
        results[case.name] = run_case(path, case)
        log.info("4.1 %s: max_dev_m = %.3g", case.name, max_dev_m(results[case.name]))
    return Ex41(path, vl, vr, results)


def summary(ex: Ex41) -> dict:
    """The section's entry of thesis.json (without the figures)."""
    out = {"reconstruction": ex.path.describe()}
    out.update({name: summarize(ex.path, r) for name, r in ex.results.items()})
    out["models_agree"] = all(out[name]["max_dev_m"] < AGREE_TOL for name in ex.results)
    out["models_agree_finite"] = all(out[name]["max_dev_finite_m"] < AGREE_TOL for name in ex.results)
    out["note"] = (
        "max_dev_m: MICR/MVIR with parameters from the MPP twist by (2.13) per sample; where no finite "
        "parameters reproduce the MPP twist (commands equal but MPP rotates, or equal slip on a straight: "
        "(2.14) is 0/0) the MPP twist is used (continuous extension; agreement there by construction). "
        "max_dev_finite_m: the models with nominal finite parameters at those samples instead."
    )
    return out
