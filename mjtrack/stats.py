"""Statistics of least-squares fits to windows of a log, shared by calibration and diagnosis.

The residuals of a window fit are not independent draws: the rows of one window share its start
state, and neighbouring windows share the robot's state and the model's errors. The covariance
of the estimate is therefore taken over *clusters* of rows (a few consecutive windows, or blocks
of a log), the cluster-robust sandwich

    cov = A^-1 (sum_c g_c g_c^T) A^-1 C / (C - 1),   A = J^T J,   g_c = J_c^T r_c,

over the C clusters, g_c the gradient contribution (score) of cluster c; C / (C - 1) is the
usual small-sample correction for few clusters. It is formed as W^T W with
W = S A^-1 sqrt(C / (C - 1)), S the (C, P) scores, so that it is symmetric and never negative,
even for a nearly singular A. Intervals use Student's t at C - 1 degrees of freedom
(:func:`t_quantile`).
"""

from __future__ import annotations

import math

import numpy as np
from scipy import stats


def gram_inverse(jac: np.ndarray, *, eig_floor: float | None = None) -> np.ndarray:
    """(J^T J)^-1 (P, P) from the singular values of ``jac`` (R, P) (forming J^T J first loses
    the small ones).

    ``eig_floor``: None: the pseudo-inverse (eigenvalues of J^T J at most P eps times the largest
    count as zero: no variance in a direction the rows do not see); a share: eigenvalues below it
    times the largest are raised to it (a direction the rows barely see gets a large, finite
    variance).
    """
    jac = np.asarray(jac, float)
    _, sv, vt = np.linalg.svd(jac, full_matrices=False)
    if eig_floor is not None:
        sv = np.maximum(sv, max(float(sv.max(initial=0.0)), 1e-300) * math.sqrt(eig_floor))
        return (vt.T / sv ** 2) @ vt
    eig = sv ** 2
    keep = eig > jac.shape[1] * np.finfo(float).eps * float(eig.max(initial=0.0))
    inv = np.zeros_like(eig)
    inv[keep] = 1.0 / eig[keep]
    return (vt.T * inv) @ vt


def cluster_sandwich(jac: np.ndarray, resid: np.ndarray, cluster: np.ndarray, *,
                     eig_floor: float | None = None) -> np.ndarray:
    """Cluster-robust covariance (P, P) of the least-squares estimate with Jacobian ``jac``
    (R, P) and residuals ``resid`` (R,), rows grouped by the labels ``cluster`` (R,) (any
    hashable sortable values; module docstring). ``eig_floor``: how A is inverted
    (:func:`gram_inverse`)."""
    jac = np.asarray(jac, float)
    resid = np.asarray(resid, float)
    _, inv = np.unique(np.asarray(cluster), return_inverse=True)
    n = int(inv.max(initial=-1)) + 1
    scores = np.zeros((n, jac.shape[1]))
    np.add.at(scores, inv.ravel(), jac * resid[:, None])
    w = scores @ gram_inverse(jac, eig_floor=eig_floor) * math.sqrt(n / max(n - 1, 1))
    return w.T @ w


def t_quantile(n_clusters: int, level: float = 0.975) -> float:
    """Student quantile with n_clusters - 1 degrees of freedom (at least 1)."""
    return float(stats.t.ppf(level, max(n_clusters - 1, 1)))


__all__ = ["cluster_sandwich", "gram_inverse", "t_quantile"]
