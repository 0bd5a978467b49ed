"""Statistics of diagnosis on per-window error arrays: blocks, the gain test, ties, intervals.

Everything here takes plain arrays (per-window squared position errors, block ids, fit
residuals and Jacobians), so any baseline (the surrogate, MuJoCo) can reuse it.

Blocks. Prediction windows start at every sample and overlap, so neighbouring windows are
strongly correlated; the unit of resampling is a *block* of consecutive samples long enough
for that correlation to die out: at least three horizons and 1 % of the log, never crossing a
gap between segments and never splitting a segment (short segments, e.g. the 2 s windows of
a DRIVE log, are pooled with their neighbours until the block is long enough).

Gain test (:func:`gain_test`). Each window's held-out squared position error, before and after
an effect (each window scored by the fit that did not see its fold); the relative gain
1 - sqrt(sum after / sum before) and its blocked bootstrap distribution over the blocks (the
block sums are resampled, so a replicate costs one matrix product). A finding needs the
one-sided 95 % lower bound above zero and a point gain of at least the floor. Unlike a paired
t-test over K folds it does not depend on K (every window counts once whatever the folds) and
it is fair to an effect that acts in part of the log: a fold in which the effect never shows
is one fold of K for a t-test over folds, but only its share of the windows here.

Intervals (:func:`mjtrack.stats.cluster_sandwich`, :func:`interval`). The least-squares estimate's covariance under resampling of
blocks, linearised (the cluster-robust "sandwich" (J'J)^-1 (sum_b g_b g_b') (J'J)^-1 with
g_b = J_b' r_b, the gradient contribution of block b): the residuals include whatever the
model does not explain (the surrogate's own approximation error included), so the interval
widens with it, as a block bootstrap over windows would, without refitting per replicate.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mjtrack.stats import cluster_sandwich, t_quantile  # noqa: F401 (the one sandwich, used through this module)

N_BOOT = 2000


def pos_rmse(err: np.ndarray) -> float:
    """RMS position error [m] of window errors (W, 3) (along, across, yaw)."""
    return float(np.sqrt(np.mean(err[:, 0] ** 2 + err[:, 1] ** 2))) if err.size else float("nan")


def contiguous_folds(n: int, n_folds: int, group: np.ndarray | None = None) -> np.ndarray:
    """Fold (n,) of n items in time order, ``n_folds`` contiguous folds: whole groups (segments,
    ids 0..G-1 in order) when there are at least 2 n_folds of them, else equal runs of items."""
    if group is not None and group.size:
        n_groups = int(group[-1]) + 1
        if n_groups >= 2 * n_folds:
            return (np.asarray(group) * n_folds) // n_groups
    return (np.arange(n) * n_folds) // n


def sample_blocks(t: np.ndarray, seg: np.ndarray, horizon_s: float, *, min_fraction: float = 0.01) -> np.ndarray:
    """Block id (N,) of every sample (module docstring): consecutive samples, at least
    max(3 horizon, min_fraction x duration) long, segments kept whole."""
    t = np.asarray(t, float)
    seg = np.asarray(seg)
    cuts = np.flatnonzero(seg[1:] != seg[:-1]) + 1
    lo_hi = list(zip(np.r_[0, cuts], np.r_[cuts, t.size]))
    dur = sum(float(t[hi - 1] - t[lo]) for lo, hi in lo_hi)
    length = max(3.0 * horizon_s, min_fraction * dur)
    same = seg[1:] == seg[:-1]
    step = float(np.median(np.diff(t)[same])) if same.any() else 0.0
    out = np.empty(t.size, dtype=np.int64)
    block, acc = 0, 0.0
    for lo, hi in lo_hi:
        seg_len = float(t[hi - 1] - t[lo]) + step  # the time its samples stand for
        if seg_len <= length:  # a short segment: pooled with its neighbours
            out[lo:hi] = block
            acc += seg_len
            if acc >= length:
                block, acc = block + 1, 0.0
            continue
        if acc > 0:
            block, acc = block + 1, 0.0
        k = np.floor((t[lo:hi] - t[lo]) / length).astype(np.int64)
        n_full = int(k[-1])
        if n_full >= 1 and (t[hi - 1] - t[lo]) - n_full * length < 0.5 * length:
            k = np.minimum(k, n_full - 1)  # a short remainder joins the last block
        out[lo:hi] = block + k
        block += int(k[-1]) + 1
    return np.unique(out, return_inverse=True)[1]


def boot_counts(n_blocks: int, n_boot: int, seed: int) -> np.ndarray:
    """(n_boot, n_blocks) how often each block is drawn in each bootstrap replicate (seeded)."""
    rng = np.random.default_rng(seed)
    idx = rng.integers(0, n_blocks, size=(n_boot, n_blocks))
    flat = (idx + n_blocks * np.arange(n_boot)[:, None]).ravel()
    return np.bincount(flat, minlength=n_boot * n_blocks).reshape(n_boot, n_blocks).astype(float)


@dataclass(frozen=True)
class GainTest:
    """Relative held-out gain and its blocked bootstrap: ``relative`` 1 - RMSE_after/RMSE_before,
    ``lower``/``upper`` its one-sided 95 % bounds, ``p`` the bootstrap share of replicates with
    no gain, ``blocks`` the number of blocks."""

    relative: float
    lower: float
    upper: float
    p: float
    blocks: int


_ROUNDOFF = 1e-12  # [-] relative gains this small are round-off


def gain_test(before_sq: np.ndarray, after_sq: np.ndarray, block: np.ndarray, *, n_boot: int = N_BOOT,
              seed: int = 0, level: float = 0.95) -> GainTest:
    """Blocked bootstrap of the relative gain from per-window squared errors (M,) before and
    after, windows grouped by ``block`` (M,) ids (module docstring)."""
    before_sq = np.asarray(before_sq, float)
    after_sq = np.asarray(after_sq, float)
    ids, inv = np.unique(block, return_inverse=True)
    sb = np.bincount(inv, weights=before_sq, minlength=ids.size)
    sa = np.bincount(inv, weights=after_sq, minlength=ids.size)
    rel = 1.0 - np.sqrt(sa.sum() / sb.sum()) if sb.sum() > 0 else 0.0
    w = boot_counts(ids.size, n_boot, seed)
    b, a = w @ sb, w @ sa
    reps = 1.0 - np.sqrt(a / np.where(b > 0, b, 1.0))
    # a resample without the blocks an effect acts in has a == b up to round-off: its gain is zero,
    # not +-1e-16 (on branch width-hybrid an effect acting in 1 block of 10 passed on a bound of 1.7e-14)
    reps[np.abs(reps) < _ROUNDOFF] = 0.0
    lo, hi = np.quantile(reps, [1.0 - level, level])
    return GainTest(float(rel), float(lo), float(hi), float(np.mean(reps <= 0.0)), int(ids.size))


def difference_test(before_sq: np.ndarray, a_sq: np.ndarray, b_sq: np.ndarray, block: np.ndarray, *,
                    n_boot: int = N_BOOT, seed: int = 1, level: float = 0.95) -> tuple[float, float, float]:
    """Gain of model a over model b as a share of the baseline RMSE, (RMSE_b - RMSE_a)/RMSE_before,
    with its two-sided ``level`` blocked-bootstrap interval: (value, lower, upper)."""
    ids, inv = np.unique(block, return_inverse=True)
    s0, sa, sb = (np.bincount(inv, weights=np.asarray(x, float), minlength=ids.size) for x in (before_sq, a_sq, b_sq))
    d = (np.sqrt(sb.sum()) - np.sqrt(sa.sum())) / np.sqrt(s0.sum())
    w = boot_counts(ids.size, n_boot, seed)
    r0 = np.sqrt(w @ s0)
    reps = (np.sqrt(w @ sb) - np.sqrt(w @ sa)) / np.where(r0 > 0, r0, 1.0)
    q = (1.0 - level) / 2
    lo, hi = np.quantile(reps, [q, 1.0 - q])
    return float(d), float(lo), float(hi)


def paired_t(a: np.ndarray, b: np.ndarray) -> float:
    """t statistic of mean(a - b) over folds (inf when all differences are equal and positive)."""
    d = np.asarray(a, float) - np.asarray(b, float)
    sd = float(np.std(d, ddof=1)) if d.size > 1 else 0.0
    m = float(np.mean(d))
    scale = max(float(np.max(np.abs(a))), float(np.max(np.abs(b))), 1e-300)
    if abs(m) <= 1e-12 * scale:  # no difference at all (e.g. the fit stayed at the nominal value)
        return 0.0
    if sd <= 1e-15 * abs(m):
        return float(np.sign(m) * np.inf)
    return m / (sd / np.sqrt(d.size))


def jackknife_se(folds: np.ndarray) -> np.ndarray:
    """Delete-one-fold jackknife standard error (P,) of fold estimates (K, P)."""
    k = folds.shape[0]
    dev = folds - folds.mean(0)
    return np.sqrt((k - 1) / k * np.sum(dev**2, 0))


def interval(full: np.ndarray, fold_estimates: np.ndarray, cov: np.ndarray, n_blocks: int, se_model: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """95 % interval (P, 2) and its standard error (P,): the larger of the block-robust sandwich
    and the delete-one-fold jackknife, and the baseline's own error ``se_model`` (P,) in quadrature (docs/theory/diagnosis.md)."""
    se_j = jackknife_se(fold_estimates)
    se_s = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    se = np.where(np.isfinite(se_s), np.maximum(se_s, se_j), se_j)
    if se_model is not None:
        se = np.sqrt(se**2 + se_model**2)
    q = t_quantile(n_blocks)
    return np.stack([full - q * se, full + q * se], -1), se


def min_active_blocks(n_blocks: int, level: float = 0.95) -> int:
    """The fewest blocks an effect must act in for the one-sided ``level`` bound of the blocked
    bootstrap gain (:func:`gain_test`) to exceed zero: a replicate that
    draws none of the k blocks shows no gain, which happens with probability (1 - k/B)^B, and
    that must be below 1 - level (3 of 40 blocks: 4.4 %; 2 of 40: 12.9 %)."""
    for k in range(1, n_blocks + 1):
        if (1.0 - k / n_blocks) ** n_blocks < 1.0 - level:
            return k
    return n_blocks


def too_few_blocks(before_sq: np.ndarray, after_sq: np.ndarray, block: np.ndarray,
                    min_gain: float) -> tuple[int, int, int] | None:
    """(blocks that show the gain, blocks, the fewest that could establish it) when fewer blocks
    than :func:`min_active_blocks` gain at least ``min_gain`` of their own error, else None."""
    ids, inv = np.unique(block, return_inverse=True)
    b = np.bincount(inv, weights=before_sq, minlength=ids.size)
    a = np.bincount(inv, weights=after_sq, minlength=ids.size)
    gain = 1.0 - np.sqrt(a / np.where(b > 0, b, 1.0))
    k, need = int(np.sum(gain >= min_gain)), min_active_blocks(ids.size)
    return (k, int(ids.size), need) if 0 < k < need else None


__all__ = ["pos_rmse", "contiguous_folds", "boot_counts", "sample_blocks", "GainTest", "gain_test", "difference_test",
           "cluster_sandwich", "t_quantile", "paired_t", "jackknife_se", "interval", "min_active_blocks",
           "too_few_blocks"]
