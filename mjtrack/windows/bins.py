"""Window errors sorted by what the robot was asked to do: the turn ratio of track speeds, means
over windows, and errors binned by one quantity (turn ratio, speed, time).

Shared by calibration and diagnosis, which report the same tables.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def turn_ratio(v: np.ndarray) -> np.ndarray:
    """(V_R - V_L)/(|V_L| + |V_R|) for speeds (N, 2): -1 spin right ... +1 spin left; 0 when stopped."""
    den = np.abs(v[:, 0]) + np.abs(v[:, 1])
    return np.where(den > 1e-9, (v[:, 1] - v[:, 0]) / np.where(den > 1e-9, den, 1.0), 0.0)


def window_means(values: np.ndarray, starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
    """Mean of per-sample values (N, ...) over [start, end) of each window (M, ...)."""
    c = np.concatenate([np.zeros((1,) + values.shape[1:]), np.cumsum(values, axis=0)])
    return (c[ends] - c[starts]) / (ends - starts).reshape((-1,) + (1,) * (values.ndim - 1))


@dataclass(frozen=True)
class BinTable:
    """Errors binned by one quantity: label, edges (B+1,), count (B,), rms pos error [m], mean along,
    across [m] and yaw [rad] errors (B,)."""

    label: str
    edges: np.ndarray
    count: np.ndarray
    pos_rms: np.ndarray
    along: np.ndarray
    across: np.ndarray
    yaw: np.ndarray

    def rows(self, unit: str = "") -> list[list]:
        out = []
        for i in range(self.count.size):
            if self.count[i]:
                out.append([f"{self.edges[i]:.3g} … {self.edges[i + 1]:.3g}{unit}", int(self.count[i]), float(self.pos_rms[i]),
                            float(self.along[i]), float(self.across[i]), float(np.degrees(self.yaw[i]))])
        return out


def bin_errors(label: str, x: np.ndarray, err: np.ndarray, edges) -> BinTable:
    """Bin window errors (M, 3) by x (M,) over ``edges``."""
    edges = np.asarray(edges, float)
    idx = np.clip(np.searchsorted(edges, x, side="right") - 1, 0, edges.size - 2)
    nb = edges.size - 1
    count = np.bincount(idx, minlength=nb)
    safe = np.maximum(count, 1)

    def mean(v):
        return np.where(count > 0, np.bincount(idx, weights=v, minlength=nb) / safe, np.nan)

    pos2 = err[:, 0] ** 2 + err[:, 1] ** 2
    return BinTable(label, edges, count, np.sqrt(mean(pos2)), mean(err[:, 0]), mean(err[:, 1]), mean(err[:, 2]))
