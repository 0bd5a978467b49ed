"""Windowed fit of the MuJoCo robot to a drive log, through ``mujoco.sysid``.

The residual of a parameter vector is, for every window of the log (each simulated from its
measured start state by :func:`mjtrack.sim.windows.simulate_windows`), the predicted minus the
measured pose at ``CHECKPOINTS`` fractions of the window (position in the start frame [m], yaw
times ``yaw_length`` [m]), divided by sqrt(number of windows) so that the cost is a mean. A
window whose simulation blew up gets ``DIVERGED_RESIDUAL`` in every component. Windows start
with hidden states warmed up over the log's own past where their segment allows
(:data:`mjtrack.windows.WARMUP_S`).

What ``mujoco.sysid`` does here: the parameters are a ``sysid.ParameterDict`` (in units of each
parameter's typical change, so one finite-difference step suits all), ``sysid.optimize`` runs
``mujoco.minimize.least_squares`` (Levenberg-Marquardt with box bounds) on a *vectorised* residual:
its finite-difference Jacobian asks for all n perturbed points at once, and they run as one batch
of n x M windows through ``mujoco.rollout`` on threads (taken once, then updated from each step by
Broyden's secant rule, :class:`SecantJacobian`); the intervals are
``sysid.calculate_intervals`` on the final Jacobian. What sysid could not do: its own residual
builder (``build_residual_fn`` / ``sysid_rollout``) rolls out whole recorded sequences from one
initial state, with parameters applied by recompiling an ``MjSpec``; it has no notion of many
windows restarted from measured states with moving tracks, of per-world model fields without a
rebuild, or of parameters that act on the commands (delay, scale). Those live in
:mod:`mjtrack.sim.windows`; sysid receives them as one residual function.

Multi-start: before the descent, a few starting points that differ in the parameter that most
changes the turning resistance (contact length or the ground's parameter) and the drive lag are
evaluated in one batch; the descent starts from the best.
"""

from __future__ import annotations

import dataclasses
import io
import logging
import time
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from mjtrack.calibrate.params import ParamSpec, specs_for, window_params
from mjtrack.geometry import relative_pose
from mjtrack.io.logs import DriveLog
from mjtrack.sim.windows import WindowSim, simulate_windows
from mjtrack.windows.define import DIVERGED_ERROR, WARMUP_S, WindowSet, measured_window_poses

log = logging.getLogger(__name__)

CHECKPOINTS = (0.25, 0.5, 0.75, 1.0)  # fractions of a window at which the pose error counts
DIVERGED_RESIDUAL = DIVERGED_ERROR  # [m] residual of a window whose simulation blew up (its score's error)
FD_EPS = 0.05  # finite-difference step in units of a parameter's typical change (ParamSpec.scale)
# Levenberg-Marquardt damping after a rejected step (mujoco.minimize.least_squares). Its defaults
# (mu from 0 to 1e-6, then x1.26 per rejection) suit cheap residuals; here one residual is a pass
# over every window, and on the Marmotte log the first Gauss-Newton step (a near-degenerate
# direction: cg_y against a short contact) was rejected 30 times in a row, each rejection a full
# pass, while mu crept up to 1e-3. Damping of 1e-3 of the scaled Hessian's order (the cost is a
# mean over windows in m^2, parameters in units of their typical change) and x10 per rejection
# (the classic Levenberg-Marquardt factor) reach it in 2-3 passes. benchmarks/bench_calibrate.py.
LM_MU_MIN = 1e-3
LM_MU_FACTOR = 10.0
#: share of the predicted reduction of the cost a step must reach for the secant Jacobian to be
#: kept (:class:`SecantJacobian`); below it the slope has changed more than one update can follow
SECANT_TRUST = 0.25
#: the multi-start's screen: every start costed on this many of the windows (evenly spread), the
#: SCREEN_KEEP cheapest then on all of them (the descent starts from the best of those); a start
#: that loses on a third of the log does not win on the whole of it (benchmarks/bench_calibrate.py)
SCREEN_WINDOWS = 10
SCREEN_KEEP = 3
KEPT_RESIDUALS = 64  # parameter vectors whose residuals an objective keeps (Objective.residuals; a few kB each)


@dataclass
class Objective:
    """Residuals of parameter vectors on a log's windows (a vectorised function for sysid)."""

    sim: WindowSim
    log: DriveLog
    windows: WindowSet
    names: list[str]
    specs: dict[str, ParamSpec]
    yaw_length: float
    nthread: int = 2
    warmup_s: float = WARMUP_S
    #: called with the number of windows just simulated (after each rollout chunk)
    progress: Callable[[int], None] | None = None
    #: window parameters held at these values besides ``names`` (the turn stage's refit holds the
    #: turn candidates it found)
    held: dict[str, float] = field(default_factory=dict)
    evaluations: int = 0
    seconds: float = 0.0
    _meas: np.ndarray = field(init=False, repr=False)
    _idx: np.ndarray = field(init=False, repr=False)
    _kept: dict = field(init=False, repr=False, default_factory=dict)

    def __post_init__(self) -> None:
        self._meas = measured_window_poses(self.log, self.windows)
        n = self.windows.ends - self.windows.starts
        self._idx = np.stack([np.round(f * n).astype(int) for f in CHECKPOINTS], -1)  # (M, C)

    @property
    def rows_per_window(self) -> int:
        """Residual components of one window (checkpoints x (along, across, yaw))."""
        return 3 * len(CHECKPOINTS)

    @property
    def scales(self) -> np.ndarray:
        return np.array([self.specs[n].scale for n in self.names])

    def params_of(self, z: np.ndarray) -> dict[str, float]:
        """Physical parameter values of a scaled vector z (n,)."""
        return {n: float(v) for n, v in zip(self.names, np.asarray(z, float) * self.scales)}

    def residuals(self, Z: np.ndarray) -> np.ndarray:
        """Residuals (R, k) of k scaled parameter vectors Z (n, k); (R,) for one vector (n,).

        The last few vectors' residuals are kept: the optimiser evaluates its start point that
        :func:`fit` has just costed, and its last iterate again where :func:`central_jacobian`
        starts; each is a pass over every window, and the same vector gives the same bytes."""
        Z = np.asarray(Z, float)
        one = Z.ndim == 1
        Z2 = Z[:, None] if one else Z
        keys = [Z2[:, j].tobytes() for j in range(Z2.shape[1])]
        todo = [j for j, k in enumerate(keys) if k not in self._kept]
        if todo:
            variants = [window_params({**self.params_of(Z2[:, j]), **self.held}, self.sim.robot) for j in todo]
            R = self.residuals_of(variants)
            for i, j in enumerate(todo):
                self._kept[keys[j]] = R[:, i].copy()
            while len(self._kept) > KEPT_RESIDUALS:
                self._kept.pop(next(iter(self._kept)))
        out = np.stack([self._kept[k] for k in keys], -1)
        return out[:, 0] if one else out

    def residuals_of(self, variants: list[dict], *, one: bool = False, sim: WindowSim | None = None,
                     warmup_s: float | None = None) -> np.ndarray:
        """Residuals (R, P) of P window-parameter dicts (optionally on another simulator or warm-up)."""
        t0 = time.perf_counter()
        res = simulate_windows(sim or self.sim, self.log, self.windows, variants, nthread=self.nthread,
                               warmup_s=self.warmup_s if warmup_s is None else warmup_s,
                               progress=windows_done(self.progress))
        self.seconds += time.perf_counter() - t0
        self.evaluations += len(variants)
        R = self._residuals(res.poses, res.diverged)
        return R[:, 0] if one else R

    def _residuals(self, poses: np.ndarray, diverged: np.ndarray) -> np.ndarray:
        P, M = poses.shape[:2]
        rows = np.arange(M)[:, None]
        pred = poses[:, rows, self._idx]  # (P, M, C, 3)
        meas = self._meas[rows, self._idx]  # (M, C, 3)
        start = self._meas[:, 0][:, None]  # (M, 1, 3)
        d = relative_pose(start[None], pred) - relative_pose(start, meas)[None]
        d[..., 2] = (pred[..., 2] - meas[..., 2]) * self.yaw_length
        d[diverged] = DIVERGED_RESIDUAL
        d = np.nan_to_num(d, nan=DIVERGED_RESIDUAL)
        return (d.reshape(P, -1) / np.sqrt(M)).T

    def on(self, index: np.ndarray) -> "Objective":
        """The same objective on the windows ``index`` of these (its cost a mean over them)."""
        return dataclasses.replace(self, windows=self.windows.subset(index), evaluations=0, seconds=0.0)

    def cost(self, Z: np.ndarray) -> np.ndarray:
        """Mean squared residual per window of each column of Z (n, k): (k,)."""
        R = self.residuals(Z if np.ndim(Z) == 2 else np.asarray(Z)[:, None])
        return np.sum(R ** 2, axis=0)


@dataclass
class FitResult:
    """Fitted values, the starts tried, the optimiser's trace, and the final Jacobian and residuals.

    ``jac``: (R, n) derivative of the residuals with respect to the *scaled* parameters (units of
    each parameter's typical change, :attr:`ParamSpec.scale`); ``resid``: (R,) residuals at the
    fitted values; both feed :mod:`mjtrack.calibrate.identify`."""

    names: list[str]
    values: dict[str, float]
    start: dict[str, float]
    starts_tried: list[tuple[dict[str, float], float]]
    cost_start: float
    cost_final: float
    iterations: int
    evaluations: int
    seconds: float
    sim_seconds: float
    method: str
    jac: np.ndarray | None
    resid: np.ndarray


def _multistart(obj: Objective, z0: np.ndarray) -> tuple[np.ndarray, list[tuple[dict[str, float], float]]]:
    """A few starts differing in the turning-resistance and lag parameters, each moved off its
    bounds as the descent will move it, screened in one batch on :data:`SCREEN_WINDOWS` windows,
    the cheapest :data:`SCREEN_KEEP` costed on every window (the costs returned: over every window,
    NaN for a start the screen left out)."""
    Z = np.stack([_off_bounds(obj, z) for z in start_points(obj.names, obj.specs, z0)], -1)
    M = len(obj.windows)
    costs = np.full(Z.shape[1], np.nan)
    best = np.arange(Z.shape[1])
    if multistart_passes(Z.shape[1], M) < Z.shape[1]:
        screen = obj.on(np.unique(np.round(np.linspace(0, M - 1, SCREEN_WINDOWS)).astype(int)))
        screened = screen.cost(Z)
        obj.seconds += screen.seconds
        obj.evaluations += -(-screen.evaluations * len(screen.windows) // M)  # in passes over every window
        best = np.argsort(screened, kind="stable")[:SCREEN_KEEP]
    costs[best] = obj.cost(Z[:, best])
    tried = [(obj.params_of(Z[:, j]), float(costs[j])) for j in range(Z.shape[1])]
    return Z[:, int(best[np.argmin(costs[best])])], tried


def multistart_passes(starts: int, windows: int) -> float:
    """Passes over ``windows`` fit windows that :func:`_multistart` of ``starts`` starts costs."""
    if starts > SCREEN_KEEP and windows >= 3 * SCREEN_WINDOWS:
        return starts * SCREEN_WINDOWS / windows + SCREEN_KEEP
    return starts


def _off_bounds(obj: Objective, z: np.ndarray) -> np.ndarray:
    """The scaled point ``z`` inside the bounds and moved off them as :func:`fit` moves its start
    (``sysid.ParameterDict.move_off_bounds``): the start costed is then the one the descent takes."""
    import mujoco.sysid as sysid

    pdict = sysid.ParameterDict()
    for n, v, s in zip(obj.names, z, obj.scales):
        lo, hi = obj.specs[n].lo / s, obj.specs[n].hi / s
        pdict.add(sysid.Parameter(n, float(np.clip(v, lo, hi)), lo, hi))
    pdict.move_off_bounds()
    return pdict.as_vector().copy()


def start_points(names: list[str], specs: dict[str, ParamSpec], z0: np.ndarray) -> list[np.ndarray]:
    """The scaled starting points (n,) the multi-start tries from ``z0`` (the first)."""
    cands = [z0.copy()]
    turn = [n for n in ("track_length", "wheelbase", "lateral_ratio", "span") if n in names]
    grid = {"track_length": (0.3, 0.5, 0.8), "wheelbase": (0.3, 0.6, 1.1), "lateral_ratio": (0.4, 0.7, 1.0),
            "span": (0.4, 0.7, 1.0)}
    for n in turn[:1]:
        i = names.index(n)
        for v in grid[n]:
            z = z0.copy()
            z[i] = v / specs[n].scale
            cands.append(z)
    # each start also with a drive lag of 0.3 s and with a dead time of 0.2 s: the cost is not convex
    # in either (a 0.15 s dead time was fitted as 0.03 s from a start at 0 with the track length
    # from 0.6 m, and as 0.150 s from 0.1 s; tests/test_calibrate.py)
    for name, value in (("drive_lag", 0.3), ("drive_delay", 0.2)):
        if name in names:
            i = names.index(name)
            for z in list(cands):
                zz = z.copy()
                zz[i] = value / specs[name].scale
                cands.append(zz)
    return cands


class SecantJacobian:
    """The Jacobian for ``mujoco.minimize.least_squares``: a forward difference of :data:`FD_EPS`
    (n + 1 points in one batch, as the optimiser's own) at the first iterate, then Broyden's
    rank-one secant update from each accepted step (no rollout at all), and a fresh forward
    difference whenever the last step fell short of what the updated Jacobian predicted (actual
    reduction of the cost below :data:`SECANT_TRUST` of the predicted one).

    Why: a forward-difference Jacobian costs n rollouts of every fit window per iteration, ten
    times the step itself with the default candidates; near the optimum the steps are small and
    the slope hardly changes from one iterate to the next. The update keeps the Jacobian exact along
    the step just taken; the directions it has not explored keep the last difference's slope. The
    fit's verdicts never rest on it: its end point is checked by :func:`central_jacobian`, and
    :mod:`mjtrack.calibrate.run` fits again where that says the optimum is still ahead."""

    def __init__(self, residuals: Callable[[np.ndarray], np.ndarray], eps: float, bounds: list[np.ndarray]) -> None:
        self.residuals, self.eps, self.bounds = residuals, float(eps), bounds
        self.J: np.ndarray | None = None
        self.x: np.ndarray | None = None
        self.r: np.ndarray | None = None
        self.differences = 0  # forward differences taken
        self.updates = 0  # secant updates

    def __call__(self, x: np.ndarray, r: np.ndarray) -> np.ndarray:
        from mujoco.minimize import jacobian_fd

        x = np.asarray(x, float).reshape(-1, 1)
        r = np.asarray(r, float).reshape(-1)
        fresh = self.J is None
        if not fresh:
            dx = (x - self.x)[:, 0]
            pred = self.r + self.J @ dx
            want = float(self.r @ self.r - pred @ pred)
            got = float(self.r @ self.r - r @ r)
            fresh = not (want > 0 and got >= SECANT_TRUST * want) or not float(dx @ dx) > 0
        if fresh:
            J, _ = jacobian_fd(self.residuals, x, r.reshape(-1, 1), np.float64(self.eps), 0, self.bounds)
            self.J = np.asarray(J, float)
            self.differences += 1
        else:
            self.J = self.J + np.outer((r - self.r) - self.J @ dx, dx) / float(dx @ dx)
            self.updates += 1
        self.x, self.r = x.copy(), r.copy()
        return self.J.copy()


def fit(obj: Objective, start: dict[str, float], *, max_iter: int = 8, multistart: bool = True,
        on_iter: Callable[[int, float], None] | None = None, mu_min: float | None = None,
        mu_factor: float | None = None, broyden: bool = True, final_jacobian: bool = True) -> FitResult:
    """Fit ``obj.names`` from ``start`` (physical values); see the module docstring.
    ``mu_min`` / ``mu_factor``: Levenberg-Marquardt damping (default :data:`LM_MU_MIN`,
    :data:`LM_MU_FACTOR`, read at call time); ``broyden``: the optimiser's Jacobian by
    :class:`SecantJacobian` (else a forward difference at every iterate); ``final_jacobian``: the
    central differences at the end point (False where the caller linearises a larger set of
    parameters there anyway: ``jac`` is then None)."""
    import mujoco.sysid as sysid

    t0 = time.perf_counter()
    evals0, sim0 = obj.evaluations, obj.seconds
    specs = obj.specs
    scales = obj.scales
    z0 = np.array([start[n] for n in obj.names]) / scales
    tried: list[tuple[dict[str, float], float]] = []
    if multistart and len(obj.names) > 1:
        z0, tried = _multistart(obj, z0)
    pdict = sysid.ParameterDict()
    for n, z, s in zip(obj.names, z0, scales):
        pdict.add(sysid.Parameter(n, z, specs[n].lo / s, specs[n].hi / s))
    pdict.move_off_bounds()
    z_start = pdict.as_vector().copy()
    cost_start = float(obj.cost(z_start)[0])
    iters = []

    def residual_fn(x, params):
        return [obj.residuals(x)], None, None

    def callback(trace):
        iters.append(trace[-1].objective)
        if on_iter is not None:
            on_iter(len(trace), float(trace[-1].objective))

    lo, hi = pdict.get_bounds()
    jacobian = None if not broyden else SecantJacobian(obj.residuals, FD_EPS, [lo.reshape(-1, 1), hi.reshape(-1, 1)])
    opt, result = sysid.optimize(pdict, residual_fn, optimizer="mujoco", verbose=False, max_iters=max_iter,
                                 eps=FD_EPS, iter_callback=callback, output=io.StringIO(), jacobian=jacobian,
                                 mu_min=LM_MU_MIN if mu_min is None else mu_min,
                                 mu_factor=LM_MU_FACTOR if mu_factor is None else mu_factor)
    z = opt.as_vector()
    r, J = central_jacobian(obj, z) if final_jacobian else (obj.residuals(z), None)
    return FitResult(names=list(obj.names), values=obj.params_of(z),
                     start={n: float(v) for n, v in obj.params_of(z_start).items()},
                     starts_tried=tried, cost_start=cost_start, cost_final=float(np.sum(r ** 2)),
                     iterations=len(iters), evaluations=obj.evaluations - evals0, seconds=time.perf_counter() - t0,
                     sim_seconds=obj.seconds - sim0, jac=J, resid=np.asarray(r, float),
                     method="mujoco.sysid.optimize (mujoco.minimize.least_squares, vectorised finite differences"
                            + (" updated by Broyden's secant rule)" if broyden else ")"))


def central_jacobian(obj: Objective, z: np.ndarray, central: np.ndarray | None = None
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Residuals (R,) at the scaled point z (n,) and their Jacobian (R, n) by central differences
    of each parameter's resolution (one-sided at a bound, and where ``central`` (n,) is False:
    a secant towards the interior), all points in one batch.

    The optimiser's own Jacobian is a forward difference of :data:`FD_EPS`, possibly from an
    earlier iterate; intervals and the convergence check need the slope at the fitted point, over
    the change that matters. Infinitesimal steps mislead twice here: a dead time acts through the
    commands held over whole time steps, so the residuals are only piecewise smooth in it (a forward
    step of half a time step across a kink gave a 16 times too steep derivative and a gradient of
    the wrong sign); and a drive lag or a dead time well below the 5 ms step hardly shows (at
    lag 0.1 ms the residuals did not change at all, at 1 ms a thousandth of what 5 ms does), so a
    derivative at zero calls a lag the log pins to a few milliseconds undetermined.

    A window whose simulation blew up at any of the points (:data:`DIVERGED_RESIDUAL` in every
    component there) gets a zero row: the difference of its residuals measures the step across the
    simulator's stable range, not the log's slope. Left in, such a row (a window that diverged at the
    fitted point and not a step away, or the other way round) dwarfed the real ones in its cluster's
    score: on the Marmotte log, calibrated from its shipped description, the two windows the guard
    added as diverged widened every interval past what matters, and nothing was kept."""
    n = z.size
    lo = np.array([obj.specs[k].lo for k in obj.names]) / obj.scales
    hi = np.array([obj.specs[k].hi for k in obj.names]) / obj.scales
    h = np.array([obj.specs[k].resolution for k in obj.names]) / obj.scales
    central = np.ones(n, bool) if central is None else np.asarray(central, bool)
    plus, minus = np.minimum(z + h, hi), np.maximum(z - h, lo)
    cols, pairs = [z], []
    for i in range(n):
        a, b = plus[i], minus[i]
        if not central[i]:  # one side only: the one with room
            a, b = (plus[i], z[i]) if plus[i] - z[i] >= z[i] - minus[i] else (z[i], minus[i])
        idx = []
        for v in (a, b):
            if v == z[i]:
                idx.append(0)
            else:
                zz = z.copy()
                zz[i] = v
                cols.append(zz)
                idx.append(len(cols) - 1)
        pairs.append((idx[0], idx[1], a - b))
    R = obj.residuals(np.stack(cols, -1))
    J = np.stack([(R[:, ia] - R[:, ib]) / max(d, 1e-300) for ia, ib, d in pairs], -1)
    per = obj.rows_per_window
    windows = R.reshape(-1, per, R.shape[1])
    blew_up = np.any(np.all(windows == DIVERGED_RESIDUAL / np.sqrt(windows.shape[0]), axis=1), axis=1)
    J[np.repeat(blew_up, per)] = 0.0
    return R[:, 0], J


def objective(sim: WindowSim, log_: DriveLog, windows: WindowSet, names: list[str], *, nthread: int = 2,
              warmup_s: float = WARMUP_S, progress: Callable[[int], None] | None = None,
              held: dict[str, float] | None = None) -> Objective:
    """The objective of ``names`` on ``log_``'s windows for the robot of ``sim`` (``progress``:
    called with the number of windows just simulated; ``held``: parameters held at these values)."""
    robot = sim.robot
    return Objective(sim=sim, log=log_, windows=windows, names=list(names), specs=specs_for(robot),
                     yaw_length=robot.track_gauge / 2, nthread=nthread, warmup_s=warmup_s, progress=progress,
                     held=dict(held or {}))


def windows_done(step: Callable[[int], None] | None) -> Callable[[int, int], None] | None:
    """:func:`simulate_windows`' progress callback (windows done so far in the call, of all) as
    increments for ``step`` (windows just done); None for None."""
    if step is None:
        return None
    last = [0]

    def cb(done: int, total: int) -> None:
        step(done - last[0])
        last[0] = done
    return cb
