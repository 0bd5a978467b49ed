"""Import a ROS 2 bag (sqlite3 folder or .mcap) as a drive log, without ROS installed.

Odometry (nav_msgs/Odometry) gives the pose x, y, yaw (and z, roll, pitch) and the body twist
vx, vy, wz; the velocity command (geometry_msgs/Twist or TwistStamped: v, w) gives the track
commands v_left_cmd = v - w T/2 and v_right_cmd = v + w T/2, with T the robot's track_gauge;
joint states (sensor_msgs/JointState, optional) give the measured track speeds: the mean
velocity of the joints named *left* / *right* times the robot's sprocket_radius. Topics are
found by message type unless named. One row per command message; the other topics are
interpolated to the command times. A bag without odometry or commands is refused with the
list of its topics. Writes LOG.csv and the robot as LOG.json beside it.
"""

from __future__ import annotations

import argparse

from mjtrack.commands._common import (add_force_option, add_robot_options, check_out_file, check_overwrite,
                                      command_inputs, robot_from_args)

HELP = "import a ROS 2 bag (odometry, velocity commands, joint states) as a drive log CSV"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("bag", metavar="BAG", help="ROS 2 bag: its folder (sqlite3 or mcap) or an .mcap file")
    parser.add_argument("--out", metavar="LOG.csv", required=True, help="output drive log (LOG.json written beside it)")
    parser.add_argument("--odom", metavar="TOPIC", default=None, help="odometry topic (default: the one nav_msgs/Odometry topic)")
    parser.add_argument("--cmd", metavar="TOPIC", default=None,
                        help="velocity command topic (default: the one Twist or TwistStamped topic)")
    parser.add_argument("--joints", metavar="TOPIC", default=None,
                        help="joint state topic for measured track speeds (default: the one JointState topic, if any)")
    add_robot_options(parser)
    add_force_option(parser)


def run(args: argparse.Namespace) -> int:
    from mjtrack.errors import InputError
    from mjtrack.io.bag import read_bag
    from mjtrack.io.logs import robot_path_for, write_log
    from mjtrack.io.robot import write_robot

    if args.robot is None and args.track_gauge is None:
        raise InputError("import-bag needs the robot's track gauge: --robot FILE or --track-gauge M")
    robot = robot_from_args(args)  # an error in the robot file before a clash of output names
    inputs = command_inputs(args)
    out = check_out_file(args.out, suffixes=[".csv"], inputs=inputs)
    check_overwrite([out, robot_path_for(out)], args.force, inputs)
    log = read_bag(args.bag, robot, odom=args.odom, cmd=args.cmd, joints=args.joints)
    write_log(log, out)
    write_robot(robot, robot_path_for(out))
    print(f"{out}: {log.n_samples} rows over {log.duration:.3f} s")
    return 0
