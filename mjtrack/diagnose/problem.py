"""A diagnosis problem: a log's windows, folds and blocks, and the effects already found.

Data only: the model that predicts the windows (:class:`mjtrack.diagnose.baseline.Baseline`) is
passed beside the problem, never held in it, so that every baseline builds and reads the same
problem and nothing reaches through it to a model's internals.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mjtrack.diagnose.residuals import DriveData
from mjtrack.diagnose.vocabulary import Effect
from mjtrack.io.logs import DriveLog


@dataclass(frozen=True)
class Problem:
    """Everything a fit needs, computed once per log.

    data: the drive data; horizon_s [s]; dt: (N,) hold times [s]; yaw_scale [m]: the lever that
    turns a yaw error into a length (half the track gauge) when yaw and position errors are
    fitted together; starts, ends: (M,) windows; fold: (M,) fold of each window; sample_fold:
    (N,) fold of each sample; fit_windows: (F,) indices into the windows used for fitting (a
    stride of them); measured: (N, 2) measured track speeds with missing values replaced by the
    command, or None; speed_ok: (N,) samples with both speeds measured; base: effects with fixed
    parameters that are part of the baseline ((Effect, theta) pairs: forward selection tests the
    others on top of those already found); sample_block: (N,) block ids for the intervals
    (:func:`mjtrack.diagnose.stats.sample_blocks`), None = one block per fold; score_folds: the
    folds that are scored, each by the fit on all others (None: every fold, cross-validation;
    (0,): a test log in fold 0, fitted on fold 1); valid: (M,) windows whose baseline prediction
    exists (a simulator's may diverge: those are neither fitted nor scored), None = all.
    """

    data: DriveData
    horizon_s: float
    dt: np.ndarray
    yaw_scale: float
    starts: np.ndarray
    ends: np.ndarray
    fold: np.ndarray
    sample_fold: np.ndarray
    fit_windows: np.ndarray
    measured: np.ndarray | None
    speed_ok: np.ndarray | None
    base: tuple = ()
    sample_block: np.ndarray | None = None
    score_folds: tuple | None = None
    valid: np.ndarray | None = None

    @property
    def valid_mask(self) -> np.ndarray:
        """(M,) bool: :attr:`valid`, all True when None."""
        return np.ones(self.starts.size, bool) if self.valid is None else self.valid

    @property
    def scored(self) -> np.ndarray:
        """(M,) bool: the valid windows that are scored (all, or those of ``score_folds``: a test log)."""
        if self.score_folds is None:
            return self.valid_mask
        return np.isin(self.fold, self.score_folds) & self.valid_mask

    @property
    def window_block(self) -> np.ndarray:
        """(M,) block of each window (that of its start sample)."""
        blocks = self.sample_block if self.sample_block is not None else self.sample_fold
        return blocks[self.starts]

    @property
    def speed_block(self) -> np.ndarray:
        """(N,) block of each sample for the track-speed statistics."""
        return self.sample_block if self.sample_block is not None else self.sample_fold

    def uses_speeds(self, effect: Effect) -> bool:
        """Input effects are fitted to the measured track speeds when the log has them."""
        return effect.kind == "input" and self.speed_ok is not None and bool(self.speed_ok.any())


def concat_logs(a: DriveLog, b: DriveLog) -> DriveLog:
    """Log ``a`` followed by log ``b`` as one log whose segments are theirs (a column that only one
    of them has is NaN, missing, in the other); its source is ``a``'s."""
    cols = {}
    for name in ("t", "v_left_cmd", "v_right_cmd", "x", "y", "yaw", "v_left", "v_right", "vx", "vy", "wz"):
        if getattr(a, name) is None and getattr(b, name) is None:
            continue
        cols[name] = np.concatenate([np.full(x.n_samples, np.nan) if getattr(x, name) is None else getattr(x, name)
                                     for x in (a, b)])
    seg = [np.repeat(np.arange(len(x.segment_slices())), [s.stop - s.start for s in x.segment_slices()]) for x in (a, b)]
    cols["window"] = np.concatenate([seg[0], seg[1] + seg[0][-1] + 1])
    return DriveLog.from_columns(cols, source=a.source)


__all__ = ["Problem", "concat_logs"]
