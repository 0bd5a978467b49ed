"""Adaptive process noise: an interacting-multiple-model (IMM) pair of slow and fast parameter dynamics.

**Why.** Every parameter filter of this package models its parameters p (slips, ψ) as a random
walk with one intensity q: p_k = p_{k−1} + w, w ~ N(0, q² Δt). The real ICRs are not a random
walk: they sit still for long stretches (constant ground, constant command) and jump when the
ground or the manoeuvre changes (a friction patch, a change of turn direction or speed under
load transfer). A single q is then wrong somewhere. A small q gives accurate, well-smoothed
estimates while the world is still, but after a jump the filter's covariance says "σ_p is
small" while the error is large: parameter NEES of 10²–10³ for many seconds, and a recovery
time of order 1/(q·√J) (J: information per second on p). A large q recovers quickly but
passes measurement noise into p all the time. Neither covariance is right in both regimes.

Derivation and measurements: docs/theory/filters.md, "Adaptive process noise (IMM)".
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from mjtrack.errors import InputError


@dataclass(frozen=True)
class IMMSettings:
    """Settings of the slow/fast IMM pair (module docstring).

    Attributes:
        fast_factor: c, the fast mode's parameter random-walk intensity over the slow one's.
        fast_meas_factor: r, the fast mode's measurement noise std over the slow one's.
        dwell_s: mean dwell times (τ_slow, τ_fast) [s] of the mode chain.
        prior: initial probabilities (slow, fast).
        command_scale: u_c [m/s] of the command-triggered switch (module docstring), None: off.
    """

    fast_factor: float = 300.0
    fast_meas_factor: float = 2.0
    dwell_s: tuple[float, float] = (1000.0, 1.0)
    prior: tuple[float, float] = (0.5, 0.5)
    command_scale: float | None = 0.2

    def __post_init__(self):
        if not (math.isfinite(self.fast_factor) and self.fast_factor > 0):
            raise InputError(f"IMM: fast_factor must be a positive number, got {self.fast_factor!r}")
        if not (math.isfinite(self.fast_meas_factor) and self.fast_meas_factor >= 1):
            raise InputError(f"IMM: fast_meas_factor must be a number >= 1, got {self.fast_meas_factor!r}")
        if self.command_scale is not None and not (math.isfinite(self.command_scale) and self.command_scale > 0):
            raise InputError(f"IMM: command_scale must be a positive speed [m/s] or None, got {self.command_scale!r}")
        if len(self.dwell_s) != 2 or not all(math.isfinite(d) and d > 0 for d in self.dwell_s):
            raise InputError(f"IMM: dwell_s must be two positive times [s], got {self.dwell_s!r}")
        p = np.asarray(self.prior, float)
        if p.shape != (2,) or np.any(p < 0) or not math.isclose(float(p.sum()), 1.0, rel_tol=1e-9):
            raise InputError(f"IMM: prior must be two probabilities summing to 1, got {self.prior!r}")

    def transition_matrix(self, dt: float, du: float = 0.0) -> np.ndarray:
        """π (2, 2), π[i, j] = P(mode j at k | mode i at k−1) over a step of ``dt`` [s] in which the
        track speeds changed by ``du`` [m/s] (Euclidean norm of the change of (V_L, V_R))."""
        hazard = dt / np.asarray(self.dwell_s, float)
        if self.command_scale is not None:
            hazard[0] += abs(du) / self.command_scale
        stay = np.exp(-hazard)
        return np.array([[stay[0], 1 - stay[0]], [1 - stay[1], stay[1]]])

    def to_dict(self) -> dict:
        return {"fast_factor": self.fast_factor, "fast_meas_factor": self.fast_meas_factor,
                "command_scale": self.command_scale, "dwell_s": list(self.dwell_s), "prior": list(self.prior)}


def imm_settings(adaptive, default: IMMSettings | None = None) -> IMMSettings | None:
    """``None``/``False`` -> None; ``"imm"``/``True`` -> ``default`` (or :class:`IMMSettings`());
    an :class:`IMMSettings` as is."""
    if adaptive is None or adaptive is False:
        return None
    if adaptive is True or (isinstance(adaptive, str) and adaptive == "imm"):
        return default or IMMSettings()
    if isinstance(adaptive, IMMSettings):
        return adaptive
    raise InputError(f"adaptive must be None, 'imm' or IMMSettings, got {adaptive!r}")


def mix(xs: Sequence[np.ndarray], Ps: Sequence[np.ndarray], mu: np.ndarray, pi: np.ndarray):
    """Step 1: returns (x⁰_j, P⁰_j lists, c̄ (M,))."""
    cbar = pi.T @ mu
    cbar = np.maximum(cbar, 1e-300)
    w = pi * mu[:, None] / cbar[None, :]  # w[i, j] = mu_{i|j}
    x0, P0 = [], []
    for j in range(len(xs)):
        xj = sum(w[i, j] * xs[i] for i in range(len(xs)))
        Pj = sum(w[i, j] * (Ps[i] + np.outer(xs[i] - xj, xs[i] - xj)) for i in range(len(xs)))
        x0.append(xj)
        P0.append(0.5 * (Pj + Pj.T))
    return x0, P0, cbar


def combine(xs: Sequence[np.ndarray], Ps: Sequence[np.ndarray], w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Moment-matched mixture: (Σ w_j x_j, Σ w_j (P_j + d_j d_jᵀ))."""
    x = sum(wj * xj for wj, xj in zip(w, xs))
    P = sum(wj * (Pj + np.outer(xj - x, xj - x)) for wj, xj, Pj in zip(w, xs, Ps))
    return x, 0.5 * (P + P.T)


def log_likelihood(e: np.ndarray, S: np.ndarray) -> float:
    """log N(e; 0, S)."""
    L = np.linalg.cholesky(S)
    y = np.linalg.solve(L, e)
    return float(-0.5 * y @ y - np.sum(np.log(np.diag(L))) - 0.5 * e.size * math.log(2 * math.pi))


def posterior_probabilities(loglik: np.ndarray, cbar: np.ndarray) -> np.ndarray:
    """Step 3: μ_j ∝ Λ_j c̄_j, in logs."""
    a = np.asarray(loglik, float) + np.log(cbar)
    a = a - a.max()
    p = np.exp(a)
    return p / p.sum()
