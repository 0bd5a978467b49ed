"""Trajectories in the TUM format that ``evo`` reads: one line per pose, ``t x y z qx qy qz qw``.

Space separated, no header, floats written with ``repr`` (exact). The orientation is the
quaternion of the Z-Y-X (yaw, pitch, roll) rotation; ``z``, ``roll`` and ``pitch`` come from
the log's columns of those names when it has them (terrain logs), else 0 (a planar log).
"""

from __future__ import annotations

import os

import numpy as np

from mjtrack.io.atomic import atomic_open
from mjtrack.io.logs import DriveLog


def quaternion_zyx(yaw: np.ndarray, pitch: np.ndarray, roll: np.ndarray) -> np.ndarray:
    """(n, 4) quaternions (qx, qy, qz, qw) of R = Rz(yaw) Ry(pitch) Rx(roll)."""
    cy, sy = np.cos(yaw / 2), np.sin(yaw / 2)
    cp, sp = np.cos(pitch / 2), np.sin(pitch / 2)
    cr, sr = np.cos(roll / 2), np.sin(roll / 2)
    return np.stack([
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
        cr * cp * cy + sr * sp * sy,
    ], axis=-1)


def tum_rows(log: DriveLog) -> np.ndarray:
    """(n, 8) array ``t x y z qx qy qz qw`` of a drive log."""
    cols = log.to_columns()
    zero = np.zeros(log.n_samples)

    def col(name: str) -> np.ndarray:
        a = cols.get(name)
        if a is None or a.dtype.kind != "f":
            return zero
        return np.nan_to_num(np.asarray(a, dtype=float), nan=0.0)

    q = quaternion_zyx(np.asarray(log.yaw, float), col("pitch"), col("roll"))
    return np.column_stack([log.t, log.x, log.y, col("z"), q])


def write_tum(log: DriveLog, path: str | os.PathLike) -> None:
    """Write the log's poses as a TUM trajectory file, atomically."""
    rows = tum_rows(log)
    with atomic_open(path, "w", encoding="utf-8", newline="") as fh:
        for r in rows.tolist():
            fh.write(" ".join(map(repr, r)) + "\n")
