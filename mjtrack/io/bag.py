"""ROS 2 bags (sqlite3 or mcap) as drive logs, read with ``rosbags`` (pure Python, no ROS).

Topics used (found by message type when not named):

* ``nav_msgs/msg/Odometry`` -> pose ``x, y, yaw`` (and ``z, roll, pitch``) of the geometric
  centre, and the body twist ``vx, vy, wz`` (the message's twist, in the child frame);
* ``geometry_msgs/msg/Twist`` or ``TwistStamped`` (the velocity command) -> track commands
  ``v_left_cmd = v - w T/2``, ``v_right_cmd = v + w T/2`` (T the robot's ``track_gauge``);
* ``sensor_msgs/msg/JointState`` (optional) -> measured track speeds ``v_left, v_right``: the
  mean velocity of the joints whose name contains ``left`` (``right``) [rad/s] times the
  robot's ``sprocket_radius``.

Time base: one row per command message (the command rate); pose, twist and track speeds are
linearly interpolated to the command times (yaw unwrapped first); commands before the first
or after the last odometry message are dropped. Times are the messages' header stamps when
every topic used carries one (non-zero), else the bag's receive times for all topics (never
a mix of clocks). ``t`` starts at 0 at the first row; the column ``stamp`` keeps the absolute
time [s].
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mjtrack.errors import InputError
from mjtrack.io.logs import DriveLog
from mjtrack.io.robot import Robot

ODOM = ("nav_msgs/msg/Odometry",)
CMD = ("geometry_msgs/msg/Twist", "geometry_msgs/msg/TwistStamped")
JOINTS = ("sensor_msgs/msg/JointState",)


@dataclass
class _Series:
    stamp: list[int]  # [ns]
    recv: list[int]  # [ns]
    values: list[tuple[float, ...]]

    def times(self, use_stamp: bool, origin: int) -> np.ndarray:
        """Times [s] after ``origin`` [ns] (integer nanoseconds until the subtraction: exact)."""
        return np.array([(ns - origin) * 1e-9 for ns in (self.stamp if use_stamp else self.recv)])


def _pick(topics: dict[str, str], given: str | None, types: tuple[str, ...], what: str, option: str,
          path: Path, *, required: bool) -> str | None:
    listing = ", ".join(f"{t} ({m})" for t, m in sorted(topics.items())) or "none"
    if given is not None:
        if given not in topics:
            raise InputError(f"{path}: {option}={given!r}: no such topic; the bag has: {listing}")
        if topics[given] not in types:
            raise InputError(f"{path}: {option}={given!r} is a {topics[given]}, expected {' or '.join(types)}")
        return given
    found = sorted(t for t, m in topics.items() if m in types)
    if len(found) > 1:
        raise InputError(f"{path}: several {what} topics ({', '.join(found)}); choose one with {option}=TOPIC")
    if not found:
        if required:
            raise InputError(f"{path}: no {what} topic ({' or '.join(types)}); the bag has: {listing}")
        return None
    return found[0]


def _stamp(msg) -> int:
    return int(msg.header.stamp.sec) * 1_000_000_000 + int(msg.header.stamp.nanosec)


def _yaw_pitch_roll(q) -> tuple[float, float, float]:
    w, x, y, z = q.w, q.x, q.y, q.z
    yaw = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    pitch = math.asin(max(-1.0, min(1.0, 2 * (w * y - z * x))))
    roll = math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    return yaw, pitch, roll


def read_bag(
    path: str | os.PathLike,
    robot: Robot,
    *,
    odom: str | None = None,
    cmd: str | None = None,
    joints: str | None = None,
) -> DriveLog:
    """A ROS 2 bag (folder or ``.mcap``/``.db3`` file) as a :class:`DriveLog` (see the module
    docstring). Missing or ambiguous topics raise :class:`InputError` listing the bag's topics."""
    from rosbags.highlevel import AnyReader, AnyReaderError
    from rosbags.typesys import Stores, get_typestore

    path = Path(path)
    if not path.exists():
        raise InputError(f"{path}: no such bag")
    target = path.parent if path.is_file() and path.suffix == ".db3" else path
    series: dict[str, _Series] = {}
    try:
        with AnyReader([target], default_typestore=get_typestore(Stores.ROS2_HUMBLE)) as reader:
            topics = {c.topic: c.msgtype for c in reader.connections}
            chosen = {
                "odom": _pick(topics, odom, ODOM, "odometry", "odom", path, required=True),
                "cmd": _pick(topics, cmd, CMD, "velocity command", "cmd", path, required=True),
                "joints": _pick(topics, joints, JOINTS, "joint state", "joints", path, required=False),
            }
            wanted = {t: k for k, t in chosen.items() if t is not None}
            series = {k: _Series([], [], []) for k in wanted.values()}
            names: list[str] | None = None
            conns = [c for c in reader.connections if c.topic in wanted]
            for conn, recv_ns, raw in reader.messages(connections=conns):
                kind = wanted[conn.topic]
                msg = reader.deserialize(raw, conn.msgtype)
                s = series[kind]
                s.recv.append(int(recv_ns))
                s.stamp.append(_stamp(msg) if hasattr(msg, "header") else 0)
                if kind == "odom":
                    p, tw = msg.pose.pose.position, msg.twist.twist
                    yaw, pitch, roll = _yaw_pitch_roll(msg.pose.pose.orientation)
                    s.values.append((p.x, p.y, yaw, p.z, roll, pitch, tw.linear.x, tw.linear.y, tw.angular.z))
                elif kind == "cmd":
                    tw = msg.twist if hasattr(msg, "header") else msg
                    s.values.append((tw.linear.x, tw.angular.z))
                else:
                    names = list(msg.name)
                    s.values.append(_track_joint_speeds(names, msg.velocity, path, conn.topic))
    except AnyReaderError as exc:
        raise InputError(f"{path}: cannot read as a ROS 2 bag ({exc})") from None
    except InputError:
        raise
    except Exception as exc:  # corrupt storage or messages rosbags cannot decode
        raise InputError(f"{path}: cannot read as a ROS 2 bag ({type(exc).__name__}: {exc})") from None
    return _to_log(series, robot, path)


def _track_joint_speeds(names: list[str], velocity, path: Path, topic: str) -> tuple[float, float]:
    vel = np.asarray(velocity, dtype=float)
    if len(vel) != len(names):
        return (math.nan, math.nan)
    out = []
    for side in ("left", "right"):
        idx = [i for i, n in enumerate(names) if side in n.lower()]
        if not idx:
            raise InputError(f"{path}: {topic}: no joint name contains '{side}' (joints: {', '.join(names)}); "
                             "name the sprocket joints ..._left/..._right or leave out the joints topic")
        out.append(float(np.mean(vel[idx])))
    return out[0], out[1]


def _to_log(series: dict[str, _Series], robot: Robot, path: Path) -> DriveLog:
    use_stamp = all(min(s.stamp, default=0) > 0 for s in series.values())
    odom, cmd = series["odom"], series["cmd"]
    if len(odom.values) < 2 or not cmd.values:
        raise InputError(f"{path}: need at least 2 odometry and 1 command messages, "
                         f"got {len(odom.values)} and {len(cmd.values)}")
    origin = min((s.stamp if use_stamp else s.recv)[0] for s in series.values() if s.values)
    t_odom, odom_v = _sorted_unique(odom.times(use_stamp, origin), np.asarray(odom.values, dtype=float))
    t_cmd, cmd_v = _sorted_unique(cmd.times(use_stamp, origin), np.asarray(cmd.values, dtype=float))
    keep = (t_cmd >= t_odom[0]) & (t_cmd <= t_odom[-1])
    if not keep.any():
        raise InputError(f"{path}: no command message falls inside the odometry time span "
                         f"({t_odom[0]:.3f}..{t_odom[-1]:.3f} s)")
    t, cmd_v = t_cmd[keep], cmd_v[keep]
    odom_v[:, 2] = np.unwrap(odom_v[:, 2])
    at = {name: np.interp(t, t_odom, odom_v[:, j])
          for j, name in enumerate(("x", "y", "yaw", "z", "roll", "pitch", "vx", "vy", "wz"))}
    half = robot.track_gauge / 2
    cols = {
        "t": t - t[0],
        "v_left_cmd": cmd_v[:, 0] - cmd_v[:, 1] * half,
        "v_right_cmd": cmd_v[:, 0] + cmd_v[:, 1] * half,
        "x": at["x"], "y": at["y"], "yaw": at["yaw"],
    }
    if "joints" in series and len(series["joints"].values) >= 2:
        tj, jv = _sorted_unique(series["joints"].times(use_stamp, origin), np.asarray(series["joints"].values, float))
        inside = (t >= tj[0]) & (t <= tj[-1])
        for j, name in enumerate(("v_left", "v_right")):
            cols[name] = np.where(inside, np.interp(t, tj, jv[:, j]) * robot.sprocket_radius, np.nan)
    cols.update(vx=at["vx"], vy=at["vy"], wz=at["wz"], z=at["z"], roll=at["roll"], pitch=at["pitch"], stamp=t + origin * 1e-9)
    return DriveLog.from_columns(cols, source=str(path))


def _sorted_unique(t: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Messages in time order, the last of equal times kept."""
    order = np.argsort(t, kind="stable")
    t, v = t[order], v[order]
    last = np.append(t[1:] != t[:-1], True)
    return t[last], v[last]
