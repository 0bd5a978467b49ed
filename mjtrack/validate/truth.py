"""The truths a validation compares the models with, and the noisy measurements the filters see.

Two truths (the two columns of the report):

* ``log`` — a drive log (a MuJoCo rollout, or any log): the logged poses and twist are the
  truth. MuJoCo logs are noise-free.
* ``mpp`` — the MPP analytic truth (thesis 4.2): the *same* commands driven through the MPP
  model (2.9) with known constant slips (default s_L = 0.2, s_R = 0, α = 15°, the thesis's
  4.2 values), integrated exactly (SE(2) steps). The filters must recover these parameters.

Noise decision (documented in the report). The predictions are always scored against the
noise-free truth; the *filters* see the truth plus seeded Gaussian measurement noise
(:class:`Noise`, default "realistic": σ = 1 cm on x, y, 0.5° on yaw, 0.02 m/s on vx, vy,
0.01 rad/s on wz — an RTK-GNSS/IMU-class sensor; ``scale = 0`` feeds them the truth). The
filters' measurement covariance is the default noise whatever the scale, so the same
filter runs on clean and noisy data. A real log with its own noise is used as it is
(``scale = 0``): its noise then reaches the filters and the scoring alike.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from mjtrack.errors import InputError
from mjtrack.estimation.common import twist_from_poses
from mjtrack.estimation.consistency import command_stretches
from mjtrack.io.logs import DriveLog
from mjtrack.io.robot import Robot
from mjtrack.models import MPP, integrate

MPP_TRUTH = {"s_left": 0.2, "s_right": 0.0, "alpha": math.radians(15.0)}  # thesis 4.2


@dataclass(frozen=True)
class Noise:
    """Measurement noise fed to the filters: standard deviations (``*_std``) times ``scale``.

    pose_std: (x [m], y [m], yaw [rad]); twist_std: (vx [m/s], vy [m/s], wz [rad/s]).
    """

    scale: float = 1.0
    pose_std: tuple[float, float, float] = (0.01, 0.01, math.radians(0.5))
    twist_std: tuple[float, float, float] = (0.02, 0.02, 0.01)

    def __post_init__(self):
        if not (math.isfinite(self.scale) and self.scale >= 0):
            raise InputError(f"noise scale must be a finite number >= 0, got {self.scale!r}")
        for name in ("pose_std", "twist_std"):
            v = getattr(self, name)
            if len(v) != 3 or not all(math.isfinite(x) and x > 0 for x in v):
                raise InputError(f"noise {name} must be three positive numbers, got {v!r}")

    def to_dict(self) -> dict:
        return {"scale": self.scale, "pose_std": list(self.pose_std), "twist_std": list(self.twist_std),
                "pose_std_applied": [self.scale * s for s in self.pose_std],
                "twist_std_applied": [self.scale * s for s in self.twist_std]}


@dataclass(frozen=True, eq=False)
class Case:
    """One truth with its filter inputs. Arrays (N,) or (N, 3), SI units.

    Attributes:
        name: ``"log"`` or ``"mpp"``; title: words for the report.
        t: times [s]; v_left, v_right: track speeds driving the models [m/s].
        pose: true poses (x, y, yaw) [m, m, rad], yaw continuous per segment.
        twist: true body twist (vx, vy, wz) [m/s, m/s, rad/s].
        pose_meas, twist_meas: what the filters measure (truth + noise).
        segments: segment id per sample (predictions and filters never cross a boundary).
        truth_params: the MPP parameters of an analytic truth (None for a log).
        stretch: (N,) id of the constant-command stretch of each sample (a new id at every change
            of the commanded speeds and every segment), or None.
        noise_free: whether ``pose``/``twist`` are a noise-free truth (a simulation) — only then
            can a filter's parameter error be scored (a measured log carries its own noise).
    """

    name: str
    title: str
    t: np.ndarray
    v_left: np.ndarray
    v_right: np.ndarray
    pose: np.ndarray
    twist: np.ndarray
    pose_meas: np.ndarray
    twist_meas: np.ndarray
    segments: np.ndarray
    truth_params: dict | None = None
    info: dict = field(default_factory=dict)
    stretch: np.ndarray | None = None
    noise_free: bool = True

    def __post_init__(self):
        n = self.t.shape[0]
        for key in ("v_left", "v_right", "segments"):
            if getattr(self, key).shape != (n,):
                raise InputError(f"case {self.name}: {key} has shape {getattr(self, key).shape}, expected ({n},)")
        for key in ("pose", "twist", "pose_meas", "twist_meas"):
            if getattr(self, key).shape != (n, 3):
                raise InputError(f"case {self.name}: {key} has shape {getattr(self, key).shape}, expected ({n}, 3)")
        if n < 3:
            raise InputError(f"case {self.name}: at least 3 samples needed, got {n}")

    def segment_slices(self) -> list[slice]:
        cuts = np.flatnonzero(np.diff(self.segments) != 0) + 1
        bounds = [0, *cuts.tolist(), self.t.size]
        return [slice(a, b) for a, b in zip(bounds[:-1], bounds[1:])]


def _noisy(pose: np.ndarray, twist: np.ndarray, noise: Noise, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Truth + seeded Gaussian noise (pose noise drawn first, then twist)."""
    if noise.scale == 0:
        return pose.copy(), twist.copy()
    rng = np.random.default_rng(seed)
    pose_m = pose + rng.normal(size=pose.shape) * noise.scale * np.asarray(noise.pose_std)
    twist_m = twist + rng.normal(size=twist.shape) * noise.scale * np.asarray(noise.twist_std)
    return pose_m, twist_m


def estimate_noise(case: Case) -> Noise:
    """Measurement noise of a measured log's ``pose_meas``/``twist_meas`` (for the filters' R).

    Pose: over a sample period the true motion changes the second difference of a pose by
    about a·Δt² (≈ 2.6 mm at 1 m/s² and 20 Hz), white noise of std σ by √6·σ; so σ is taken
    as the robust std (1.4826 × median absolute deviation) of the second differences within
    each segment, over √6. Twist: a twist differenced from poses has std √2·σ_pose/Δt; a logged
    twist, the robust std of its first differences over √2 (an upper bound: it includes the
    true change over one step). Floors: 1 mm, 0.05°, 1 mm/s, 1 mrad/s.
    """
    d2, d1, dts = [], [], []
    for sl in case.segment_slices():
        if sl.stop - sl.start >= 3:
            d2.append(np.diff(case.pose_meas[sl], 2, axis=0))
            d1.append(np.diff(case.twist_meas[sl], axis=0))
            dts.append(np.diff(case.t[sl]))
    if not d2:
        return Noise()
    rstd = lambda a: 1.4826 * np.median(np.abs(a - np.median(a, 0)), 0)  # noqa: E731
    pose = np.maximum(rstd(np.concatenate(d2)) / math.sqrt(6), [1e-3, 1e-3, math.radians(0.05)])
    if case.info.get("twist_from") == "differenced poses":
        dt = float(np.median(np.concatenate(dts)))
        twist = math.sqrt(2) * pose / dt
    else:
        twist = rstd(np.concatenate(d1)) / math.sqrt(2)
    twist = np.maximum(twist, [1e-3, 1e-3, 1e-3])
    return Noise(scale=0.0, pose_std=tuple(map(float, pose)), twist_std=tuple(map(float, twist)))


def resolve_speeds(log: DriveLog, speeds: str) -> str:
    """``"auto"`` is ``"measured"`` when the log has measured track speeds, else ``"cmd"``."""
    if speeds not in ("auto", "cmd", "measured"):
        raise InputError(f"speeds must be 'auto', 'cmd' or 'measured', got {speeds!r}")
    if speeds == "auto":
        return "measured" if log.has_track_speeds else "cmd"
    return speeds


def case_from_log(log: DriveLog, *, speeds: str = "auto", noise: Noise = Noise(), seed: int = 0,
                  title: str = "MuJoCo rollout", noise_free: bool = True) -> Case:
    """The ``log`` case of a drive log (``title`` names it in the report: a MuJoCo rollout or a measured log).

    ``speeds="measured"`` drives the models with the logged track speeds, ``"cmd"`` with the
    commanded ones, ``"auto"`` (default) with the measured ones when the log has them. The
    kinematic models relate the *actual* track speeds to the body motion; commanded speeds
    also carry the drives' response (the MuJoCo servo is torque-limited, so a step command
    takes a few tenths of a second to reach the track), which no kinematic model describes
    and which, measured on the demo rollout, dominates the filters' ICR error.
    Without twist columns the twist is differenced from the poses
    (:func:`~mjtrack.estimation.common.twist_from_poses`, last row repeated).
    ``noise_free``: the log is a simulation (False for a measured log: no parameter NEES).
    """
    speeds = resolve_speeds(log, speeds)
    if speeds == "measured" and not log.has_track_speeds:
        raise InputError(f"{log.source or 'drive log'}: no measured track speeds (columns 'v_left', 'v_right')")
    n = log.n_samples
    seg = np.zeros(n, dtype=int) if log.window is None else np.asarray(log.window)
    t = np.asarray(log.t, float)
    pose = np.stack([log.x, log.y, log.yaw], -1).astype(float)
    twist = np.empty((n, 3))
    for sl in log.segment_slices():
        pose[sl, 2] = np.unwrap(pose[sl, 2])
        if sl.stop - sl.start < 2:
            raise InputError(f"{log.source or 'drive log'}: segment at row {sl.start + 2} has fewer than 2 samples")
        if log.has_twist:
            twist[sl] = np.stack([log.vx[sl], log.vy[sl], log.wz[sl]], -1)
        else:
            tw = twist_from_poses(t[sl], pose[sl])
            twist[sl] = np.vstack([tw, tw[-1:]])
    if not np.all(np.isfinite(pose)) or not np.all(np.isfinite(twist)):
        raise InputError(f"{log.source or 'drive log'}: poses or twist contain NaN; validate needs complete rows")
    vl, vr = (log.v_left_cmd, log.v_right_cmd) if speeds == "cmd" else (log.v_left, log.v_right)
    pose_m, twist_m = _noisy(pose, twist, noise, seed)
    stretch = command_stretches(t, log.v_left_cmd, log.v_right_cmd, seg)
    return Case("log", title, t, np.asarray(vl, float), np.asarray(vr, float), pose, twist, pose_m, twist_m,
                seg, None, {"twist_from": "log columns" if log.has_twist else "differenced poses",
                            "speeds": speeds}, stretch, noise_free)


def mpp_case(like: Case, robot: Robot, *, params: dict | None = None, noise: Noise = Noise(),
             seed: int = 0) -> Case:
    """The ``mpp`` analytic truth on the commands of ``like`` (same times, speeds, segments, start poses)."""
    params = dict(MPP_TRUTH if params is None else params)
    model = MPP(robot.track_gauge, params["s_left"], params["s_right"], params["alpha"])
    twist = np.broadcast_to(model.twist(like.v_left, like.v_right), like.pose.shape).copy()
    pose = np.empty_like(like.pose)
    for sl in like.segment_slices():
        pose[sl] = integrate(model, like.pose[sl][0], like.t[sl], like.v_left[sl], like.v_right[sl])
    pose_m, twist_m = _noisy(pose, twist, noise, seed + 1)
    return Case("mpp", "MPP analytic truth", like.t, like.v_left, like.v_right, pose, twist, pose_m, twist_m,
                like.segments, params, {"model": "MPP (2.9), exact SE(2) integration"}, like.stretch, True)
