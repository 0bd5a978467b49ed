"""Section 4.2 of the tracked-robot thesis: EKF estimation of the kinematic models' parameters.

Setting (thesis 4.2). Nominal motion V = 0.4 m/s, ω = −7 °/s; track speeds by inverting (2.1),
V_L = V − ωT/2, V_R = V + ωT/2, with T = 0.4 m (the thesis prints no gauge; 0.4 m is the
project's default robot, as in 4.1). Truth: MPP (2.9) with s_L = 0.2, s_R = 0, α = 15°, integrated
exactly (SE(2) steps, :func:`mjtrack.models.integrate`) — note that the 20 % left slip turns the
commanded right turn into a left turn (ω = +0.090 rad/s). Δt = 0.1 s, 60 s (600 steps; the
thesis's figures 4.9–4.14 show convergence within the first ~20 samples and no duration is
printed). Measurement noise: the thesis prints "variance" (wariancja) but writes σ; we read the
numbers as standard deviations, with θ in degrees: σ_x = σ_y = 0.1 m, σ_θ = 2° = 0.0349 rad,
σ_vx = σ_vy = 0.05 m/s, σ_ω = 0.04 rad/s (the variance reading, σ_x = √0.1 = 0.32 m and
σ_θ = √2 rad = 81°, is implausible for a pose sensor). Gaussian, independent, seeded.

Metrics per filter (JSON ``filters[name]``):
  param_error_final — |estimate − truth| per parameter at the last step (slips [-], α [rad],
      ICRs and centre [m]).
  converged_after_s — the first time t_c after which *every* parameter error stays within its
      tolerance until the end of the run: 0.01 for the slips, 1° for α, 5 % of T/2 = 0.01 m for
      the ICRs, 0.05 m for the virtual centre; null if the final error is outside.
  pred_err_ratio — prediction error over measurement noise: for each step the filter's
      predicted measurement h(x⁻_k) (from the prior, i.e. before seeing z_k) minus the noise-free
      value of that measured quantity, divided component-wise by its noise std (pose increments:
      √2 σ), then the RMS over components and over the steps t ≥ t_c (the second half of the run
      if not converged; ``pred_err_window_s``). 1 means "as bad as one raw measurement".
  nis_mean — mean normalised innovation squared over the same window (its expectation is the
      number of measured components, ``nis_dof``, for a consistent filter).

Derivation and measurements: docs/theory/tracked.md, "Section 4.2 reproduced".
"""

from __future__ import annotations

import logging
import math
from dataclasses import asdict, dataclass, replace

import numpy as np

from mjtrack.errors import InputError
from mjtrack.estimation.common import FilterResult, residual
from mjtrack.estimation.icr_ekf import icr_from_psi, icr_from_thesis_params, run_icr_ekf, run_icr_ekf_thesis
from mjtrack.estimation.slip_ekf import run_slip_ekf
from mjtrack.estimation.vir_filter import centre_from_thesis_state, run_vir_filter, run_vir_thesis, virtual_from_psi
from mjtrack.icr import icr_from_twist
from mjtrack.models import MPP, integrate

log = logging.getLogger(__name__)

FILTER_NAMES = ("slip_ekf", "icr_ekf_thesis", "icr_ekf", "vir_thesis_printed", "vir_thesis_intended",
                "vir_filter_twist", "vir_filter")
MIRROR_NAMES = ("icr_ekf_thesis", "icr_ekf")
CENTRE_TOL = 0.05  # [m] virtual-centre tolerance


@dataclass(frozen=True)
class Ex42Config:
    """The 4.2 setting (module docstring). SI units except the *_deg fields."""

    speed: float = 0.4  # V [m/s]
    turn_rate_deg: float = -7.0  # nominal ω [deg/s]
    track_gauge: float = 0.4  # T [m]
    s_left: float = 0.2
    s_right: float = 0.0
    alpha_deg: float = 15.0
    dt: float = 0.1  # [s]
    duration: float = 60.0  # [s]
    pos_std: float = 0.1  # [m]
    yaw_std_deg: float = 2.0
    vel_std: float = 0.05  # [m/s]
    wz_std: float = 0.04  # [rad/s]
    seed: int = 42

    def __post_init__(self):
        for name in ("speed", "track_gauge", "dt", "duration", "pos_std", "yaw_std_deg", "vel_std", "wz_std"):
            if not getattr(self, name) > 0:
                raise InputError(f"Ex42Config: {name} must be > 0, got {getattr(self, name)}")
        if self.duration < 2 * self.dt:
            raise InputError(f"Ex42Config: duration {self.duration} s is shorter than two steps")

    @property
    def pose_std(self) -> np.ndarray:
        return np.array([self.pos_std, self.pos_std, math.radians(self.yaw_std_deg)])

    @property
    def twist_std(self) -> np.ndarray:
        return np.array([self.vel_std, self.vel_std, self.wz_std])

    def mirrored(self) -> "Ex42Config":
        """The mirror image of the setting (y → −y): turn rate, α negated, slips of the tracks swapped."""
        return replace(self, turn_rate_deg=-self.turn_rate_deg, s_left=self.s_right, s_right=self.s_left,
                       alpha_deg=-self.alpha_deg)

    def truth_model(self) -> MPP:
        return MPP(self.track_gauge, self.s_left, self.s_right, math.radians(self.alpha_deg))

    def commands(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(t, V_L, V_R): constant commands from (2.1) inverted."""
        n = int(round(self.duration / self.dt)) + 1
        t = np.arange(n) * self.dt
        w = math.radians(self.turn_rate_deg)
        half = w * self.track_gauge / 2
        return t, np.full(n, self.speed - half), np.full(n, self.speed + half)


@dataclass(frozen=True, eq=False)
class Truth:
    """Simulated truth and measurements: arrays (N,) or (N, 3); ICRs and virtual robot (3,) [m]."""

    t: np.ndarray
    v_left: np.ndarray
    v_right: np.ndarray
    pose: np.ndarray
    twist: np.ndarray
    pose_meas: np.ndarray
    twist_meas: np.ndarray
    icr: np.ndarray  # (y_l, y_r, x_c)
    centre: np.ndarray  # (x_o, y_o)


def simulate(cfg: Ex42Config) -> Truth:
    """Exact MPP truth and seeded Gaussian measurements (pose noise drawn first, then twist)."""
    t, vl, vr = cfg.commands()
    model = cfg.truth_model()
    pose = integrate(model, (0.0, 0.0, 0.0), t, vl, vr)
    twist = np.broadcast_to(model.twist(vl, vr), (t.size, 3)).copy()
    rng = np.random.default_rng(cfg.seed)
    pose_meas = pose + rng.normal(size=pose.shape) * cfg.pose_std
    twist_meas = twist + rng.normal(size=twist.shape) * cfg.twist_std
    icr = icr_from_twist(*twist[0], vl[0], vr[0])
    icr3 = np.array([icr.y_l, icr.y_r, icr.x_c], float)
    return Truth(t, vl, vr, pose, twist, pose_meas, twist_meas, icr3, np.array([icr3[2], 0.5 * (icr3[0] + icr3[1])]))


@dataclass(frozen=True, eq=False)
class FilterRun:
    """One filter on one truth: its history, parameter estimates (N, P) vs truth (P,), tolerances."""

    name: str
    result: FilterResult
    param_names: tuple[str, ...]
    estimates: np.ndarray
    truth: np.ndarray
    tolerance: np.ndarray
    z_true: np.ndarray  # (N, m) noise-free values of the measured quantities
    z_std: np.ndarray  # (m,)


def _z_true(result: FilterResult, truth: Truth, cfg: Ex42Config) -> tuple[np.ndarray, np.ndarray]:
    cols, std = [], []
    k = slice(1, None)
    inc = residual(truth.pose[1:], truth.pose[:-1], (2,))
    table = {"x": (truth.pose[k, 0], cfg.pose_std[0]), "y": (truth.pose[k, 1], cfg.pose_std[1]),
             "theta": (truth.pose[k, 2], cfg.pose_std[2]), "vx": (truth.twist[k, 0], cfg.twist_std[0]),
             "vy": (truth.twist[k, 1], cfg.twist_std[1]), "wz": (truth.twist[k, 2], cfg.twist_std[2]),
             "dx": (inc[:, 0], math.sqrt(2) * cfg.pose_std[0]), "dy": (inc[:, 1], math.sqrt(2) * cfg.pose_std[1]),
             "dtheta": (inc[:, 2], math.sqrt(2) * cfg.pose_std[2])}
    for name in result.meas_names:
        cols.append(table[name][0])
        std.append(table[name][1])
    return np.stack(cols, -1), np.array(std)


def run_filter(name: str, truth: Truth, cfg: Ex42Config) -> FilterRun:
    """Run the filter ``name`` (one of :data:`FILTER_NAMES`) on ``truth``."""
    T, t, vl, vr = cfg.track_gauge, truth.t, truth.v_left, truth.v_right
    common = dict(pose_std=cfg.pose_std)
    icr_tol = np.full(3, 0.05 * T / 2)
    if name == "slip_ekf":
        r = run_slip_ekf(t, vl, vr, track_gauge=T, pose_meas=truth.pose_meas, **common)
        est, tr = r.x_post[:, 3:], np.array([cfg.s_left, cfg.s_right, math.radians(cfg.alpha_deg)])
        names, tol = ("s_left", "s_right", "alpha"), np.array([0.01, 0.01, math.radians(1.0)])
    elif name == "icr_ekf_thesis":
        r = run_icr_ekf_thesis(t, vl, vr, track_gauge=T, pose_meas=truth.pose_meas, **common)
        est = np.stack(icr_from_thesis_params(r.x_post, vl[1:], vr[1:], track_gauge=T), -1)
        names, tr, tol = ("y_l", "y_r", "x_c"), truth.icr, icr_tol
    elif name == "icr_ekf":
        r = run_icr_ekf(t, vl, vr, track_gauge=T, pose_meas=truth.pose_meas, **common)
        est = np.stack(icr_from_psi(r.x_post[:, 3:]), -1)
        names, tr, tol = ("y_l", "y_r", "x_c"), truth.icr, icr_tol
    elif name in ("vir_thesis_printed", "vir_thesis_intended"):
        r = run_vir_thesis(t, vl, vr, twist_meas=truth.twist_meas, transition=name.rsplit("_", 1)[1], twist_std=cfg.twist_std)
        est = np.stack(centre_from_thesis_state(r.x_post), -1)
        names, tr, tol = ("x_o", "y_o"), truth.centre, np.full(2, CENTRE_TOL)
    elif name in ("vir_filter_twist", "vir_filter"):
        pose = truth.pose_meas if name == "vir_filter" else None
        r = run_vir_filter(t, vl, vr, track_gauge=T, twist_meas=truth.twist_meas, pose_meas=pose,
                           twist_std=cfg.twist_std, **common)
        est = np.stack(virtual_from_psi(r.x_post[:, 3:])[:2], -1)
        names, tr, tol = ("x_o", "y_o"), truth.centre, np.full(2, CENTRE_TOL)
    else:
        raise InputError(f"ex42: unknown filter {name!r}; known: {', '.join(FILTER_NAMES)}")
    z_true, z_std = _z_true(r, truth, cfg)
    return FilterRun(name, r, names, est, tr, tol, z_true, z_std)


def metrics(run: FilterRun) -> dict:
    """The JSON numbers of one run (definitions in the module docstring)."""
    t = run.result.t
    err = np.abs(run.estimates - run.truth)
    ok = np.all(err <= run.tolerance, axis=1)
    if ok[-1]:
        bad = np.flatnonzero(~ok)
        i0 = 0 if bad.size == 0 else int(bad[-1]) + 1
        converged = float(t[i0])
    else:
        i0, converged = t.size // 2, None
    e = residual(run.result.z_pred, run.z_true, run.result.meas_angles) / run.z_std
    ratio = float(np.sqrt(np.nanmean(e[i0:] ** 2)))
    nis = run.result.nis()[i0:]
    return {
        "param_error_final": {n: float(v) for n, v in zip(run.param_names, err[-1])},
        "param_truth": {n: float(v) for n, v in zip(run.param_names, run.truth)},
        "param_final": {n: float(v) for n, v in zip(run.param_names, run.estimates[-1])},
        "tolerance": {n: float(v) for n, v in zip(run.param_names, run.tolerance)},
        "converged_after_s": converged,
        "pred_err_ratio": ratio,
        "pred_err_window_s": [float(t[i0]), float(t[-1])],
        "nis_mean": float(np.nanmean(nis)) if np.any(np.isfinite(nis)) else None,
        "nis_dof": len(run.result.meas_names),
        "skipped_steps": int(np.sum(~run.result.updated)),
    }


@dataclass(frozen=True, eq=False)
class Ex42:
    """Everything section 4.2 computes: the main run (ω = −7°/s), the mirrored and the opposite-command ICR runs."""

    config: Ex42Config
    truth: Truth
    runs: dict  # name -> FilterRun
    mirror_config: Ex42Config | None
    mirror_truth: Truth | None
    mirror_runs: dict
    opposite_config: Ex42Config | None = None
    opposite_truth: Truth | None = None
    opposite_runs: dict | None = None


def compute(config: Ex42Config | None = None, *, names=FILTER_NAMES, mirror_names=MIRROR_NAMES) -> Ex42:
    """Run section 4.2: ``names`` on the thesis's setting, ``mirror_names`` on its mirror image (a true
    right turn) and at the opposite commanded turn rate with the same slips (module docstring)."""
    cfg = config or Ex42Config()
    truth = simulate(cfg)
    runs = {n: run_filter(n, truth, cfg) for n in names}
    mcfg = mtruth = ocfg = otruth = None
    mruns, oruns = {}, {}
    if mirror_names:
        mcfg = cfg.mirrored()
        mtruth = simulate(mcfg)
        mruns = {n: run_filter(n, mtruth, mcfg) for n in mirror_names}
        ocfg = replace(cfg, turn_rate_deg=-cfg.turn_rate_deg)
        otruth = simulate(ocfg)
        oruns = {n: run_filter(n, otruth, ocfg) for n in mirror_names}
    for n, r in runs.items():
        log.info("4.2 %s: converged after %s s", n, metrics(r)["converged_after_s"])
    return Ex42(cfg, truth, runs, mcfg, mtruth, mruns, ocfg, otruth, oruns)


def summary(ex: Ex42) -> dict:
    """The section's entry of thesis.json (without the figures)."""
    cfg = ex.config
    out = {
        "setting": {**asdict(cfg), "noise_reading": "printed values are standard deviations; theta in degrees",
                    "truth_twist": [float(v) for v in ex.truth.twist[0]],
                    "truth_icr": dict(zip(("y_l", "y_r", "x_c"), map(float, ex.truth.icr))),
                    "truth_centre": dict(zip(("x_o", "y_o"), map(float, ex.truth.centre)))},
        "filters": {n: metrics(r) for n, r in ex.runs.items()},
    }
    for key, c, tr, runs in (("mirror", ex.mirror_config, ex.mirror_truth, ex.mirror_runs),
                             ("opposite_command", ex.opposite_config, ex.opposite_truth, ex.opposite_runs)):
        if c is None:
            continue
        w = float(tr.twist[0, 2])
        out[key] = {"turn_rate_deg": c.turn_rate_deg, "s_left": c.s_left, "s_right": c.s_right,
                    "alpha_deg": c.alpha_deg, "truth_wz_rad_s": w, "truth_turn": "left" if w > 0 else "right",
                    "truth_icr": dict(zip(("y_l", "y_r", "x_c"), map(float, tr.icr))),
                    "filters": {n: metrics(r) for n, r in runs.items()}}
    return out


# ---------------------------------------------------------------- figures 4.8-4.14

_DPI = 110
_STYLE = {
    "slip_ekf": dict(color="C0"), "icr_ekf_thesis": dict(color="C1", ls="--"), "icr_ekf": dict(color="C0"),
    "vir_thesis_printed": dict(color="C3", ls=":"), "vir_thesis_intended": dict(color="C1", ls="--"),
    "vir_filter_twist": dict(color="C2", ls="-."), "vir_filter": dict(color="C0"),
}
_UNITS = {"x": "m", "y": "m", "theta": "deg", "dx": "m", "dy": "m", "dtheta": "deg", "vx": "m/s", "vy": "m/s", "wz": "rad/s",
          "s_left": "-", "s_right": "-", "alpha": "deg", "y_l": "m", "y_r": "m", "x_c": "m", "x_o": "m", "y_o": "m"}
_DEG = {"theta", "dtheta", "alpha"}


def _save(fig, path, caption: str) -> None:
    import io
    import textwrap

    from mjtrack.io.atomic import atomic_write_bytes

    w, h = fig.get_size_inches()
    lines = textwrap.wrap(caption, int(w * 16))
    fig.text(0.01, 0.008, "\n".join(lines), fontsize=7.5, va="bottom", ha="left", color="0.2")
    fig.subplots_adjust(bottom=min(0.6, (0.15 + 0.13 * len(lines) + 0.6) / h))
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=_DPI)
    atomic_write_bytes(path, buf.getvalue())


def _scale(name: str) -> float:
    return math.degrees(1.0) if name in _DEG else 1.0


def _fig_path(ex: Ex42):
    from matplotlib.figure import Figure

    from mjtrack.models import Nominal

    fig = Figure(figsize=(7, 6.5))
    ax = fig.subplots()
    tr = ex.truth
    nom = integrate(Nominal(ex.config.track_gauge), (0.0, 0.0, 0.0), tr.t, tr.v_left, tr.v_right)
    ax.plot(nom[:, 0], nom[:, 1], color="0.5", lw=3, alpha=0.6, label="nominal (2.1), desired")
    ax.plot(tr.pose[:, 0], tr.pose[:, 1], color="C0", lw=2, label="truth (MPP)")
    ax.plot(tr.pose_meas[:, 0], tr.pose_meas[:, 1], ".", color="C3", ms=2, alpha=0.5, label="measured")
    ax.set_aspect("equal", "datalim")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return fig


def _fig_pred(runs: list[FilterRun], title: str):
    """Prediction errors h(x⁻) − truth of each measured component vs time, with ±σ of the noise."""
    from matplotlib.figure import Figure

    names = list(dict.fromkeys(n for r in runs for n in r.result.meas_names))
    fig = Figure(figsize=(9, 1.8 * len(names) + 1.2))
    axes = np.atleast_1d(fig.subplots(len(names), 1, sharex=True))
    for ax, comp in zip(axes, names):
        for r in runs:
            if comp not in r.result.meas_names:
                continue
            j = r.result.meas_names.index(comp)
            e = residual(r.result.z_pred[:, j], r.z_true[:, j], (0,) if j in r.result.meas_angles else ())
            ax.plot(r.result.t, e * _scale(comp), lw=1, label=r.name, **_STYLE[r.name])
            ax.axhline(r.z_std[j] * _scale(comp), color="0.6", lw=0.8, ls=":")
            ax.axhline(-r.z_std[j] * _scale(comp), color="0.6", lw=0.8, ls=":")
        ax.set_ylabel(f"{comp} [{_UNITS[comp]}]")
        ax.grid(alpha=0.3)
    axes[0].set_title(title, fontsize=10)
    axes[0].legend(fontsize=7, loc="upper right")
    axes[-1].set_xlabel("t [s]")
    return fig


def _fig_params(groups: list[tuple[str, list[FilterRun]]], title: str, *, ylim_pad: float = 0.5):
    """Parameter estimates vs time (columns: groups, e.g. turn directions) with truth and ±2σ band of the first run."""
    from matplotlib.figure import Figure

    pnames = groups[0][1][0].param_names
    fig = Figure(figsize=(5 * len(groups) + 1, 2.0 * len(pnames) + 1.2))
    axes = np.array(fig.subplots(len(pnames), len(groups), sharex=True, squeeze=False))
    for c, (label, runs) in enumerate(groups):
        for i, p in enumerate(pnames):
            ax = axes[i, c]
            s = _scale(p)
            truth = runs[0].truth[i] * s
            for r in runs:
                ax.plot(r.result.t, r.estimates[:, i] * s, lw=1.2, label=r.name, **_STYLE[r.name])
            ax.axhline(truth, color="k", lw=1, label="truth")
            ax.axhspan(truth - runs[0].tolerance[i] * s, truth + runs[0].tolerance[i] * s, color="0.85", zorder=0)
            span = max(abs(truth), 0.1 * s if p in _DEG else 0.1) * ylim_pad + runs[0].tolerance[i] * s * 4
            ax.set_ylim(truth - span, truth + span)
            ax.set_ylabel(f"{p} [{_UNITS[p]}]")
            ax.grid(alpha=0.3)
        axes[0, c].set_title(label, fontsize=10)
        axes[-1, c].set_xlabel("t [s]")
    axes[0, 0].legend(fontsize=7, loc="upper right")
    fig.suptitle(title, fontsize=10)
    return fig


def plot(ex: Ex42, out_dir) -> dict:
    """Write figs. 4.8–4.14 as PNG into ``out_dir``; return {number: {"file", "caption"}}."""
    from pathlib import Path

    from mjtrack.io.atomic import make_output_dir

    out_dir = Path(out_dir)
    make_output_dir(out_dir)
    cfg, R = ex.config, ex.runs
    setting = (f"Truth MPP s_L = {cfg.s_left}, s_R = {cfg.s_right}, alpha = {cfg.alpha_deg} deg; nominal V = {cfg.speed} m/s, "
               f"w = {cfg.turn_rate_deg} deg/s, T = {cfg.track_gauge} m, dt = {cfg.dt} s, seed {cfg.seed}; noise std "
               f"0.1 m, 2 deg, 0.05 m/s, 0.04 rad/s. Grey band: tolerance; dotted: +-1 noise std.")
    sel = lambda names: [R[n] for n in names if n in R]  # noqa: E731
    specs = [("4.8", "fig4_8_path.png", _fig_path(ex), "Nominal (desired) path and the true MPP path; the left-track "
              "slip turns the commanded right turn into a left turn.")]
    if "slip_ekf" in R:
        specs += [("4.9", "fig4_9_slip_pred.png", _fig_pred(sel(["slip_ekf"]), "slip EKF: pose prediction error"),
                   "Slip EKF (3.9)-(3.13): prior pose prediction minus true pose."),
                  ("4.10", "fig4_10_slip_params.png",
                   _fig_params([("w = %g deg/s" % cfg.turn_rate_deg, sel(["slip_ekf"]))], "slip EKF estimates"),
                   "Slip EKF estimates of s_L, s_R, alpha vs truth.")]
    icr = sel(["icr_ekf_thesis", "icr_ekf"])
    if icr:
        specs.append(("4.11", "fig4_11_icr_pred.png", _fig_pred(icr, "ICR filters: prediction error"),
                      "ICR filters: the thesis's (3.14)-(3.22) predicts pose increments (noise sqrt(2) sigma), the "
                      "improved psi filter predicts the pose."))
        groups = [("w = %g deg/s" % cfg.turn_rate_deg, icr)]
        if ex.mirror_runs:
            groups.append(("mirror image: w = %g deg/s, s_R = %g, alpha = %g deg (right turn)" % (
                ex.mirror_config.turn_rate_deg, ex.mirror_config.s_right, ex.mirror_config.alpha_deg),
                list(ex.mirror_runs.values())))
        if ex.opposite_runs:
            groups.append(("w = %g deg/s, same slips (still a left turn)" % ex.opposite_config.turn_rate_deg,
                           list(ex.opposite_runs.values())))
        specs.append(("4.12", "fig4_12_icr_params.png", _fig_params(groups, "ICR estimates"),
                      "ICR estimates y_l, y_r, x_c: thesis's regressors (3.14) vs the psi parametrisation, on the "
                      "setting, its mirror image (a true right turn) and the opposite command with the same slips."))
    vir = sel(["vir_thesis_printed", "vir_thesis_intended", "vir_filter_twist", "vir_filter"])
    if vir:
        specs.append(("4.13", "fig4_13_vir_pred.png", _fig_pred(vir, "virtual-robot filters: prediction error"),
                      "Virtual-robot filters: prior prediction of the measured twist (and pose) minus truth; the printed "
                      "transition (3.28) predicts dt*v."))
        specs.append(("4.14", "fig4_14_vir_params.png", _fig_params([("w = %g deg/s" % cfg.turn_rate_deg, vir)],
                                                                      "virtual centre estimates", ylim_pad=1.0),
                      "Virtual centre (x_o, y_o): thesis's filter with printed and intended transition vs the psi "
                      "filter (twist only, and twist + pose)."))
    out = {}
    for number, name, fig, text in specs:
        caption = f"Fig. {number}. {text} {setting}"
        _save(fig, out_dir / name, caption)
        out[number] = {"file": name, "caption": caption}
    return out
