"""Measurement noise added to a simulated drive log, so that a log made to test calibrate or
diagnose carries the noise of a real robot's sensors.

The noise is a post-process of the clean log: independent, zero-mean Gaussian white noise on
each measured channel, one standard deviation per channel (:class:`LogNoise`):

* ``pose_std`` [m] on ``x`` and ``y`` (a localisation: lidar ICP, motion capture, GNSS),
* ``yaw_std`` [rad] on ``yaw``,
* ``track_speed_std`` [m/s] on the measured track speeds ``v_left``, ``v_right`` (encoders),
* ``velocity_std`` [m/s] on the body velocity ``vx``, ``vy``,
* ``yaw_rate_std`` [rad/s] on ``wz`` (a gyro).

The commands, the time and the terrain columns (``z``, ``roll``, ``pitch``) are left as they are.
The noise comes from its own stream of ``numpy.random.default_rng`` seeded with ``(seed,
NOISE_STREAM)``, drawn for every channel in the order above whether its deviation is zero or not:
the same seed gives the same bytes, and changing one channel's deviation leaves the others'
noise unchanged.

Presets (:data:`PRESETS`): ``none``, and ``realistic``, the levels of the three real DRIVE logs
this project is checked against (Marmotte, Husky, Warthog; 20 Hz lidar-ICP poses, sprocket
encoders, a gyro), measured by :func:`measured_noise`: the robust standard deviation of each
channel's second difference inside windows of constant command, / sqrt(6), which is what white
noise of that deviation gives while the smooth motion contributes little at 20 Hz. Per channel
the preset takes the middle of the three logs, to one significant digit (the Warthog's encoders
are quantised: its track speeds measure 0). No log measures the body velocity; its noise is set
to the track speeds' (a velocity from wheel odometry).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

from mjtrack.errors import InputError
from mjtrack.io.logs import DriveLog

NOISE_STREAM = 0x6E6F6973  # second seed word of the noise stream: the scenario's own seed words stay apart

#: channel -> (log columns it applies to, unit, largest accepted value)
CHANNELS: dict[str, tuple[tuple[str, ...], str, float]] = {
    "pose_std": (("x", "y"), "m", 10.0),
    "yaw_std": (("yaw",), "rad", math.pi),
    "track_speed_std": (("v_left", "v_right"), "m/s", 10.0),
    "velocity_std": (("vx", "vy"), "m/s", 10.0),
    "yaw_rate_std": (("wz",), "rad/s", 10.0),
}


@dataclass(frozen=True)
class LogNoise:
    """Standard deviations of the white measurement noise of each channel (0: none).

    Attributes:
        pose_std: on ``x``, ``y`` [m].
        yaw_std: on ``yaw`` [rad].
        track_speed_std: on ``v_left``, ``v_right`` [m/s].
        velocity_std: on ``vx``, ``vy`` [m/s].
        yaw_rate_std: on ``wz`` [rad/s].
        preset: the preset these values started from (``"none"`` when built from values alone).
    """

    pose_std: float = 0.0
    yaw_std: float = 0.0
    track_speed_std: float = 0.0
    velocity_std: float = 0.0
    yaw_rate_std: float = 0.0
    preset: str = "none"

    def __post_init__(self) -> None:
        for name, (_, unit, high) in CHANNELS.items():
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0.0 <= value <= high:
                raise InputError(f"noise: {name} must be a number in [0, {high:g}] {unit}, got {value!r}")
            object.__setattr__(self, name, float(value))

    @property
    def is_none(self) -> bool:
        """True when every deviation is zero."""
        return all(getattr(self, name) == 0.0 for name in CHANNELS)

    def to_dict(self) -> dict[str, Any]:
        return {"preset": self.preset, **{name: getattr(self, name) for name in CHANNELS}}


#: name -> :class:`LogNoise`: ``none``, and ``realistic``, the middle of the levels the three real
#: DRIVE logs measure per channel (module docstring)
PRESETS: dict[str, LogNoise] = {
    "none": LogNoise(),
    # the middle of the three DRIVE logs per channel (module docstring)
    "realistic": LogNoise(pose_std=0.01, yaw_std=0.04, track_speed_std=0.02, velocity_std=0.02,
                          yaw_rate_std=0.03, preset="realistic"),
}


def log_noise(spec: "str | Mapping[str, float] | LogNoise | None") -> LogNoise:
    """A :class:`LogNoise` from a preset name, ``"PRESET,name=value,..."`` (a preset with some
    channels changed; the preset may be left out: ``"pose_std=0.02"`` starts from none), a mapping
    ``{"preset": ..., "pose_std": ...}``, or a LogNoise; None is no noise. InputError on a bad one."""
    if spec is None:
        return PRESETS["none"]
    if isinstance(spec, LogNoise):
        return spec
    if isinstance(spec, str):
        items: dict[str, Any] = {}
        for i, part in enumerate(p.strip() for p in spec.split(",")):
            if "=" not in part:
                if i != 0:
                    raise InputError(f"noise {spec!r}: the preset comes first; then name=value pairs")
                items["preset"] = part
                continue
            name, _, text = part.partition("=")
            try:
                items[name.strip()] = float(text)
            except ValueError:
                raise InputError(f"noise {spec!r}: {name.strip()} = {text!r} is not a number") from None
        spec = items
    if not isinstance(spec, Mapping):
        raise InputError(f"noise must be a preset name, a mapping or a LogNoise, got {type(spec).__name__}")
    preset = spec.get("preset", "none")
    if preset not in PRESETS:
        raise InputError(f"noise: unknown preset {preset!r}; presets: {', '.join(PRESETS)}")
    unknown = sorted(set(spec) - set(CHANNELS) - {"preset"})
    if unknown:
        raise InputError(f"noise: unknown channel(s) {', '.join(unknown)}; channels: {', '.join(CHANNELS)}")
    changes = {name: spec[name] for name in CHANNELS if name in spec}
    return dataclasses.replace(PRESETS[preset], **changes)


def add_noise(log: DriveLog, noise: "str | Mapping[str, float] | LogNoise | None", *, seed: int = 0) -> DriveLog:
    """``log`` with the measurement noise ``noise`` (:func:`log_noise`) added to its measured
    channels (those it has; the others are skipped), seeded by ``seed`` (module docstring)."""
    noise = log_noise(noise)
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or not 0 <= int(seed) < 2**32:
        raise InputError(f"noise: seed must be a whole number in [0, 2^32), got {seed!r}")
    if noise.is_none:
        return log
    rng = np.random.default_rng([int(seed), NOISE_STREAM])
    changes = {}
    for name, (columns, _, _) in CHANNELS.items():
        std = getattr(noise, name)
        for column in columns:
            draw = rng.standard_normal(log.n_samples)  # drawn for every channel: the streams stay aligned
            clean = getattr(log, column)
            if clean is not None and std > 0:
                changes[column] = clean + std * draw
    return dataclasses.replace(log, **changes)


def measured_noise(log: DriveLog, columns: "tuple[str, ...] | None" = None) -> dict[str, float]:
    """White-noise deviation of each column, measured from the log itself: 1.4826 MAD of the
    second difference over the rows inside one segment where the commands stay constant, / sqrt(6)
    (the second difference of white noise of deviation s has deviation s sqrt(6); the MAD leaves
    out the few rows where the motion itself changes). Columns the log lacks are left out; a
    column with fewer than 10 usable differences is NaN."""
    columns = columns or tuple(c for names, _, _ in CHANNELS.values() for c in names)
    out = {}
    for column in columns:
        values = getattr(log, column, None)
        if values is None:
            values = log.extra.get(column)
        if values is None:
            continue
        diffs = []
        for s in log.segment_slices():
            v = np.asarray(values[s], dtype=float)
            if column == "yaw":
                v = np.unwrap(v)
            d2 = v[2:] - 2 * v[1:-1] + v[:-2]
            cmd_l, cmd_r = log.v_left_cmd[s], log.v_right_cmd[s]
            steady = (cmd_l[2:] == cmd_l[:-2]) & (cmd_r[2:] == cmd_r[:-2])
            diffs.append(d2[steady])
        d = np.concatenate(diffs) if diffs else np.empty(0)
        d = d[np.isfinite(d)]
        out[column] = (float(1.4826 * np.median(np.abs(d - np.median(d))) / math.sqrt(6))
                       if d.size >= 10 else math.nan)
    return out


def with_noise_record(robot, noise: LogNoise, *, seed: int):
    """``robot`` (the description written beside a log) recording the noise the log carries under
    its key ``noise`` (with the seed), or without that key when the log is clean (a description
    read from a noisy log's JSON must not pass its record on to a clean log)."""
    extra = {k: v for k, v in robot.extra.items() if k != "noise"}
    if not noise.is_none:
        extra["noise"] = {**noise.to_dict(), "seed": int(seed)}
    return dataclasses.replace(robot, extra=extra)
