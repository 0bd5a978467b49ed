"""import-bag and export: bags written here with rosbags' own writer, from a closed-form drive.

The generator shares no code with mjtrack.io.bag: poses come from the closed-form circle
x = R sin(w t), y = R (1 - cos(w t)), yaw = w t, messages are built and serialised by rosbags.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from mjtrack.cli import main
from mjtrack.io.logs import read_log

rosbags = pytest.importorskip("rosbags")
from rosbags.rosbag2 import StoragePlugin, Writer  # noqa: E402
from rosbags.typesys import Stores, get_typestore  # noqa: E402

TS = get_typestore(Stores.ROS2_HUMBLE)
T0 = 1_700_000_000  # [s] absolute start stamp, as a real robot's clock gives
V, W = 0.8, 0.4  # [m/s], [rad/s] the commanded and driven twist
GAUGE, RS = 0.5, 0.1


def _pose(t):
    return V / W * np.sin(W * t), V / W * (1 - np.cos(W * t)), W * t


def _header(t, frame="odom"):
    ns = T0 * 1_000_000_000 + int(round(t * 1e9))  # integer nanoseconds: no float rounding at 1.7e9 s
    sec, nsec = divmod(ns, 1_000_000_000)
    return TS.types["std_msgs/msg/Header"](stamp=TS.types["builtin_interfaces/msg/Time"](sec=sec, nanosec=nsec),
                                           frame_id=frame)


def _vec(x=0.0, y=0.0, z=0.0):
    return TS.types["geometry_msgs/msg/Vector3"](x=x, y=y, z=z)


def write_bag(path, *, storage=StoragePlugin.SQLITE3, stamped=True, with_odom=True, duration=4.0):
    m = TS.types
    with Writer(path, version=9, storage_plugin=storage) as w:
        c_odom = w.add_connection("/odom", "nav_msgs/msg/Odometry", typestore=TS) if with_odom else None
        c_cmd = w.add_connection("/cmd_vel", "geometry_msgs/msg/TwistStamped" if stamped else
                                 "geometry_msgs/msg/Twist", typestore=TS)
        c_js = w.add_connection("/joint_states", "sensor_msgs/msg/JointState", typestore=TS)
        c_x = w.add_connection("/chatter", "std_msgs/msg/String", typestore=TS)
        events = []
        for k in range(int(duration * 100) + 1):  # odometry 100 Hz
            t = k / 100
            x, y, yaw = _pose(t)
            q = m["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2))
            pose = m["geometry_msgs/msg/PoseWithCovariance"](
                pose=m["geometry_msgs/msg/Pose"](position=m["geometry_msgs/msg/Point"](x=x, y=y, z=0.0),
                                                 orientation=q), covariance=np.zeros(36))
            twist = m["geometry_msgs/msg/TwistWithCovariance"](
                twist=m["geometry_msgs/msg/Twist"](linear=_vec(V), angular=_vec(z=W)), covariance=np.zeros(36))
            msg = m["nav_msgs/msg/Odometry"](header=_header(t), child_frame_id="base_link", pose=pose, twist=twist)
            if c_odom is not None:
                events.append((t, c_odom, TS.serialize_cdr(msg, "nav_msgs/msg/Odometry")))
        for k in range(int(duration * 20)):  # commands 20 Hz, starting at 0.025 s
            t = 0.025 + k / 20
            tw = m["geometry_msgs/msg/Twist"](linear=_vec(V), angular=_vec(z=W))
            if stamped:
                msg, typ = m["geometry_msgs/msg/TwistStamped"](header=_header(t, "base_link"), twist=tw), \
                    "geometry_msgs/msg/TwistStamped"
            else:
                msg, typ = tw, "geometry_msgs/msg/Twist"
            events.append((t, c_cmd, TS.serialize_cdr(msg, typ)))
        for k in range(int(duration * 50) + 1):  # joints 50 Hz: sprocket speeds of v -/+ w T/2
            t = k / 50
            vl, vr = (V - W * GAUGE / 2) / RS, (V + W * GAUGE / 2) / RS
            msg = m["sensor_msgs/msg/JointState"](header=_header(t), name=["sprocket_left", "sprocket_right"],
                                                  position=np.zeros(2), velocity=np.array([vl, vr]),
                                                  effort=np.zeros(0))
            events.append((t, c_js, TS.serialize_cdr(msg, "sensor_msgs/msg/JointState")))
        events.append((0.5, c_x, TS.serialize_cdr(m["std_msgs/msg/String"](data="hi"), "std_msgs/msg/String")))
        for t, c, raw in sorted(events, key=lambda e: e[0]):
            w.write(c, T0 * 1_000_000_000 + int(round(t * 1e9)), raw)


@pytest.mark.parametrize("storage", [StoragePlugin.SQLITE3, StoragePlugin.MCAP], ids=["sqlite3", "mcap"])
@pytest.mark.parametrize("stamped", [True, False], ids=["TwistStamped", "Twist"])
def test_import_bag_matches_the_drive(tmp_path, storage, stamped):
    bag = tmp_path / "bag"
    write_bag(bag, storage=storage, stamped=stamped)
    out = tmp_path / "log.csv"
    assert main(["import-bag", str(bag), "--track-gauge", str(GAUGE), "--out", str(out)]) == 0
    log = read_log(out)
    assert log.n_samples == 80  # every command lies inside the odometry span 0..4 s (the last at 3.975 s)
    np.testing.assert_allclose(log.extra["stamp"] - T0, 0.025 + np.arange(80) / 20, atol=1e-6)  # float64 at 1.7e9 s
    t_abs = 0.025 + log.t
    np.testing.assert_allclose(log.t, np.arange(80) / 20, atol=1e-9)
    x, y, yaw = _pose(t_abs)
    np.testing.assert_allclose(log.x, x, atol=1e-3)
    np.testing.assert_allclose(log.y, y, atol=1e-3)
    np.testing.assert_allclose(log.yaw, yaw, atol=1e-3)
    np.testing.assert_allclose(log.v_left_cmd, V - W * GAUGE / 2, atol=1e-12)
    np.testing.assert_allclose(log.v_right_cmd, V + W * GAUGE / 2, atol=1e-12)
    # joint velocities x sprocket radius (default robot: 0.06 m, as written to LOG.json)
    np.testing.assert_allclose(log.v_left, (V - W * GAUGE / 2) / RS * 0.06, atol=1e-9)
    np.testing.assert_allclose(log.wz, W, atol=1e-12)
    assert (tmp_path / "log.json").exists()


def test_bag_without_odometry_is_refused_with_its_topics(tmp_path, capsys):
    bag = tmp_path / "bag"
    write_bag(bag, with_odom=False, duration=0.5)
    out = tmp_path / "log.csv"
    assert main(["import-bag", str(bag), "--track-gauge", "0.5", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert "no odometry topic" in err and "/cmd_vel" in err and "/chatter (std_msgs/msg/String)" in err
    assert not out.exists()


def test_import_bag_refuses_a_wrong_topic_and_a_non_bag(tmp_path, capsys):
    bag = tmp_path / "bag"
    write_bag(bag, duration=0.5)
    out = tmp_path / "log.csv"
    assert main(["import-bag", str(bag), "--track-gauge", "0.5", "--odom", "/chatter", "--out", str(out)]) == 2
    assert "expected nav_msgs/msg/Odometry" in capsys.readouterr().err
    junk = tmp_path / "junk.mcap"
    junk.write_bytes(b"not a bag at all")
    assert main(["import-bag", str(junk), "--track-gauge", "0.5", "--out", str(out)]) == 2
    assert "cannot read as a ROS 2 bag" in capsys.readouterr().err
    assert not out.exists()


def test_export_tum_round_trip(tmp_path):
    from mjtrack.io.logs import DriveLog, write_log

    t = np.linspace(0, 2, 21)
    yaw = 0.3 * t - 3.0
    log = DriveLog.from_columns({"t": t, "v_left_cmd": 0 * t, "v_right_cmd": 0 * t, "x": np.cos(t), "y": t,
                                 "yaw": yaw, "z": 0.1 * t, "pitch": 0.05 + 0 * t, "roll": -0.02 + 0 * t})
    write_log(log, tmp_path / "a.csv")
    assert main(["export", str(tmp_path / "a.csv"), "--format", "tum", "--out", str(tmp_path / "a.tum")]) == 0
    rows = np.loadtxt(tmp_path / "a.tum")
    assert rows.shape == (21, 8)
    np.testing.assert_array_equal(rows[:, :4], np.column_stack([t, np.cos(t), t, 0.1 * t]))
    # independent check: the quaternion rotates body x onto (cos yaw cos pitch, sin yaw cos pitch, -sin pitch)
    qx, qy, qz, qw = rows[:, 4:].T
    bx = np.stack([1 - 2 * (qy**2 + qz**2), 2 * (qx * qy + qw * qz), 2 * (qx * qz - qw * qy)], axis=1)
    np.testing.assert_allclose(bx, np.column_stack([np.cos(yaw) * np.cos(0.05), np.sin(yaw) * np.cos(0.05),
                                                    -np.sin(0.05) + 0 * t]), atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(rows[:, 4:], axis=1), 1, atol=1e-12)
