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

**Model.** The parameter block P_pp of the predicted covariance is right up to an unknown factor
λ_k ≥ 1 (the random walk under-states how far the parameters moved); the pose block and the
measurement noise are as given. Only the twist components are used to find λ: their prediction
h = ν(p, u) depends on the parameters alone, so their innovation covariance is

    E[ε εᵀ] = J P⁻_pp Jᵀ + R_tw                                                  (ME1)

(the pose components also carry the pose process noise and the integration of the twist over
the step, which is the IMM's and q_pose's business).

**Covariance matching (the "strong tracking" fading factor of Zhou & Frank 1996; Mehra 1970).**
With R-normalised components (v_i = ε_i²/R_ii, m_i = (S_ii − n R_ii)/R_ii the parameter part of
the step's S, n R_ii the noise part the filter put into S — n = 1 for one EKF, the mixture
Σ_j c̄_j r_j² of the IMM's modes' noise factors otherwise), the factor that makes the trace of (ME1)
match an exponentially weighted average ⟨·⟩ of the recent innovations (time constant
``window_s``) is

    λ = max(1, (⟨Σ_i v_i⟩ − ⟨Σ_i n⟩) / Σ_i m_i),                                 (ME2)

⟨⟩ over the past steps, m from the latest step (so that λ falls back to 1 as soon as the
inflated covariance explains the innovations — the STF's rule). The next step's prediction
starts from the posterior with its parameter block scaled, D P⁺ D with
D = diag(1, 1, 1, √λ, …, √λ) (positive definite for any λ > 0; the pose–parameter correlations
scale with √λ; ``params`` picks which parameters get the √λ), in every IMM mode. λ ≥ 1 always:
the matching only ever says "you moved more than you thought". No parameter's variance is
scaled above its variance at a fresh start (``param_std0``²): where the twist hardly depends on a
parameter (a track at rest: ∂ν/∂s = 0) the denominator of (ME2) is ~0, λ would sit at
``lambda_max`` every step, and the covariance would grow without bound (it did, on the real
Marmotte log with a measurement noise far below the log's, until S was no longer positive
definite).

**Gate.** A noisy average exceeds its mean half of the time, and every λ > 1 on a still
parameter widens a covariance that then takes many steps to shrink again (on the ``tuning``
circle an ungated 0.2-s average made the slips' rmse 10x larger, 0.015 instead of 0.0015). The
matching therefore acts only when the innovations are significantly too large: when the averaged
twist NIS ⟨ε_twᵀ S_tw⁻¹ ε_tw⟩ (mean d = the number of twist components for a consistent filter,
variance ≈ 2d/N_eff for an average of N_eff = (Σw)²/Σw² independent steps) exceeds
d + z·√(2d/N_eff), z = ``gate_z`` (2.33: one-sided 1 %). Otherwise λ = 1 and the filter is the
plain EKF/IMM.

**Restart.** Fading cannot leave a wrong basin of a non-linear model. MPP's α = −atan(v_y/v_x)
has a pole where v_x changes sign — as it does in the first 0.3 s of a spin turn, while the
tracks' speeds ramp — and the EKF can end up at (α = +85°, the slips turning v_x to +0.01 m/s)
against a truth of (−59°, v_x = −0.11 m/s): a local optimum in which the twist innovations stay
at 6σ for seconds whatever λ does (``tuning`` case, t = 46.6 s). When the gate has stayed open
for ``restart_after_s`` without a break, the track speeds have stayed within ``steady_tol`` over
the last ``restart_window_s`` and the model can be inverted there (``twist_inverse``; MPP:
u = v_x ∓ ωT/2, s = 1 − u/V, tan α = −v_y/v_x, defined for |V_L|, |V_R|, |v_x| ≥ 0.05 m/s,
:func:`~mjtrack.estimation.slip_ekf.mpp_from_twist`), the parameters restart from the inverse of
the mean measured twist z̄ of those n steps, with the first-order covariance of that inverse,

    p₀ = ν⁻¹(z̄, u),   P₀ = J⁻¹ R_tw J⁻ᵀ / n   (J = ∂ν/∂p at p₀),

and no correlation with the pose (in every IMM mode; the matching's averages restart too). A
restart also needs the innovations to be *biased*: a wrong basin shows as a mean innovation that
stays away from zero (6σ above), a measurement noise larger than the filter's R only as a larger
spread. So the twist innovations (each over its √S_ii) of the steps with the gate open must have
a component whose t statistic |mean|/(std/√n) is at least ``restart_t`` (4: for white
innovations over the ~12 steps of 0.5 s the largest of the three exceeds it with p ≈ 0.006): a guard against restarting from the noise of a mis-stated R (it moved the
``tuning`` case's NEES/dof by less than 0.03 and the Marmotte numbers below by less than 1 cm). This
is the usual answer to a diverged filter — detect it from the innovations, re-initialise from a
direct solution of the measurement equation. The n twists were used by the filter already; the
restart discards its parameter estimate and keeps only them, so the parameters count nothing
twice (the pose keeps what it learnt through them and is now taken as uncorrelated with the
parameters, which over-states what the pose and the parameters know together; not measured).

**Where it does harm: a measurement noise far below the real one.** The gate then stays open
(the innovations exceed S because R is wrong, not because the parameters moved), and the slips'
covariance sits at its cap: on the real Marmotte log with validate's *default* noise (σ 1 cm,
0.02 m/s, far below the log's differenced twist, 0.3 m/s; benchmarks/filters_marmotte.py,
carried across windows, IMM) the slip EKF's NIS/dof fell from 264 to 64 but its 2-s predictions
got worse, 0.68 → 1.37 m (nominal: 0.24 m); with the noise estimated from the log, as validate
does now, nothing changed (0.243 m, NIS/dof 0.73). Restricting the matching to innovations with
a significant mean (a bias test on the EW mean of ε/√S, z = 2 or 3) was tried and rejected: on
the ``tuning`` cases NIS/dof rose to 1.7–2.0 and the circle's NEES/dof fell to 0.30.

Rejected (measured on the ``tuning`` case of benchmarks/filter_consistency.py, slip EKF with
its IMM, three noise seeds): matching the *measurement* noise instead (R_ii scaled by the excess
of ⟨ε_i²⟩ with a long-run factor for its correlation, Myers & Tapley 1976) made the parameter
NEES/dof 8–15 instead of 2.6–3.1: a larger twist noise moves the misfit into the pose innovations
(NIS of x, y, θ ≈ 2.1) and the parameter covariance, held small by the pose information, did not
grow; with the pose components matched as well the filter ran away (NIS/dof 0.1, NEES/dof 10³).
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
