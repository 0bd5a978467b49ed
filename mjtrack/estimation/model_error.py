"""Model-error term: covariance matching of the parameter covariance on the filter's own innovations.

**Why.** A parameter filter is consistent only while its model describes the motion and its
process noise describes how fast the parameters move. MPP's slips (:mod:`mjtrack.estimation.slip_ekf`)
are neither well described by one random walk nor by the IMM's slow/fast pair: at a change of the
command they jump by amounts that have no fixed scale (s = 1 − u/V is a ratio: a track commanded
at a few cm/s jumps by O(1); MPP's slip angle α = −atan(v_y/v_x) swings by a radian when a spin
turn starts with the centre of gravity off the geometric centre). Then the filter's covariance
says "σ_α = 0.08 rad" while the error is 1 rad and the twist innovations sit at −10σ for a
second (benchmarks/filter_consistency.py, ``tuning`` case, t = 46.6 s): NIS/dof ≈ 2 and
parameter NEES/dof ≈ 3–5.

Derivation and measurements: docs/theory/filters.md, "Model-error term".
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mjtrack.errors import InputError


@dataclass(frozen=True)
class ModelErrorSettings:
    """Settings of the model-error term (module docstring).

    Attributes:
        window_s: time constant [s] of the exponentially weighted innovation average ⟨·⟩.
        lambda_max: upper bound of the per-step factor λ.
        gate_z: the matching acts only when the averaged twist NIS exceeds its mean m by
            ``gate_z`` standard deviations of that average (module docstring); 0: always.
        params: indices of the parameters whose covariance is scaled (None: all).
        restart_after_s: restart the parameters from the model's inverse of the recent twist
            when the gate has stayed open this long [s] (module docstring, "Restart"); None: never.
            Needs a filter that was given an inverse (``twist_inverse``).
        restart_window_s: length [s] of the twist average the restart inverts.
        steady_tol: the track speeds must stay within this band [m/s] over that window.
        restart_t: the restart also needs a bias in the twist innovations while the gate was open:
            the largest |t| statistic (mean / (std/√n)) of their components ≥ ``restart_t``.
    """

    window_s: float = 0.2
    lambda_max: float = 100.0
    gate_z: float = 2.33
    params: tuple[int, ...] | None = None
    restart_after_s: float | None = None
    restart_window_s: float = 0.2
    steady_tol: float = 0.02
    restart_t: float = 4.0

    def __post_init__(self):
        if not (math.isfinite(self.window_s) and self.window_s > 0):
            raise InputError(f"model error: window_s must be a positive time [s], got {self.window_s!r}")
        if not (math.isfinite(self.lambda_max) and self.lambda_max >= 1.0):
            raise InputError(f"model error: lambda_max must be a number >= 1, got {self.lambda_max!r}")
        if not (math.isfinite(self.gate_z) and self.gate_z >= 0):
            raise InputError(f"model error: gate_z must be a number >= 0, got {self.gate_z!r}")
        if self.restart_after_s is not None and not (math.isfinite(self.restart_after_s) and self.restart_after_s > 0):
            raise InputError(f"model error: restart_after_s must be a positive time [s] or None, got {self.restart_after_s!r}")
        if not (math.isfinite(self.restart_window_s) and self.restart_window_s > 0):
            raise InputError(f"model error: restart_window_s must be a positive time [s], got {self.restart_window_s!r}")
        if not (math.isfinite(self.restart_t) and self.restart_t >= 0):
            raise InputError(f"model error: restart_t must be a number >= 0, got {self.restart_t!r}")
        if not (math.isfinite(self.steady_tol) and self.steady_tol >= 0):
            raise InputError(f"model error: steady_tol must be a speed >= 0 [m/s], got {self.steady_tol!r}")

    def to_dict(self) -> dict:
        return {"kind": "matching", "window_s": self.window_s, "lambda_max": self.lambda_max, "gate_z": self.gate_z,
                "params": None if self.params is None else list(self.params),
                "restart_after_s": self.restart_after_s, "restart_window_s": self.restart_window_s,
                "steady_tol": self.steady_tol, "restart_t": self.restart_t}


def model_error_settings(value) -> ModelErrorSettings | None:
    """None/False -> None; True or "matching" -> :class:`ModelErrorSettings`(); an instance as is."""
    if value is None or value is False:
        return None
    if value is True or (isinstance(value, str) and value == "matching"):
        return ModelErrorSettings()
    if isinstance(value, ModelErrorSettings):
        return value
    raise InputError(f"model_error must be None, True, 'matching' or ModelErrorSettings, got {value!r}")


class CovarianceMatching:
    """Running estimate of the parameter-covariance factor λ (ME2) from the twist innovations."""

    def __init__(self, settings: ModelErrorSettings):
        self.settings = settings
        self.reset()

    def reset(self) -> None:
        self.w = 0.0  # normalising weight of ⟨·⟩
        self.v = 0.0  # ⟨Σ ε²/R⟩
        self.n = 0.0  # ⟨Σ noise part / R⟩
        self.w2 = 0.0  # Σ of squared weights (effective number of steps 1 / Σ (w_k/Σw)²)
        self.nis = 0.0  # ⟨ε_twᵀ S_tw⁻¹ ε_tw⟩
        self.dof = 0.0
        self.lam = 1.0
        self.gate_open = False
        self.open_s = 0.0  # how long the gate has been open without a break [s]

    def factor(self) -> float:
        """λ to scale the parameter block of the next prediction with (≥ 1)."""
        return self.lam

    def observe(self, dt: float, e: np.ndarray, S: np.ndarray, r_diag: np.ndarray, noise_mult: float) -> None:
        """One step's twist innovations ``e`` with their S, the sensor's R_ii and the noise
        multiplier n the filter used (module docstring)."""
        e, S, r_diag = (np.asarray(a, float) for a in (e, S, r_diag))
        if e.size == 0:
            return
        S_diag = np.diag(S)
        a = math.exp(-dt / self.settings.window_s)
        self.w = a * self.w + 1.0
        self.w2 = a * a * self.w2 + 1.0
        self.nis = a * self.nis + float(e @ np.linalg.solve(S, e))
        self.dof = a * self.dof + e.size
        self.v = a * self.v + float(np.sum(e**2 / r_diag))
        self.n = a * self.n + noise_mult * e.size
        m = float(np.sum(S_diag / r_diag)) - noise_mult * e.size
        excess = (self.v - self.n) / self.w
        n_eff = self.w**2 / self.w2
        dof = self.dof / self.w
        self.gate_open = self.nis / self.w > dof + self.settings.gate_z * math.sqrt(2.0 * dof / n_eff)
        self.open_s = self.open_s + dt if self.gate_open else 0.0
        if not self.gate_open:
            self.lam = 1.0
            return
        self.lam = float(np.clip(excess / m, 1.0, self.settings.lambda_max)) if m > 0 else 1.0


def scale_param_block(P: np.ndarray, lam: float, n_pose: int = 3, params=None, var_max=None) -> np.ndarray:
    """D P D with D = diag(1 (pose), √λ_i (the parameters ``params``, default all), 1 (the others)).

    λ_i = λ, or less where that would take the parameter's variance above ``var_max[i]`` (never
    below 1): the matching never makes a parameter more uncertain than a fresh start.
    """
    d = np.ones(P.shape[0])
    idx = list(range(P.shape[0] - n_pose)) if params is None else list(params)
    lam_i = np.full(len(idx), float(lam))
    if var_max is not None:
        var = np.diag(P)[[n_pose + i for i in idx]]
        cap = np.asarray(var_max, float)[idx]
        with np.errstate(divide="ignore", invalid="ignore"):
            lam_i = np.clip(np.minimum(lam_i, np.where(var > 0, cap / var, lam_i)), 1.0, None)
    d[[n_pose + i for i in idx]] = np.sqrt(lam_i)
    return P * np.outer(d, d)
