"""Input and output: drive logs, robot descriptions, atomic files (formats: docs/reference/formats/)."""

from mjtrack.io.logs import DriveLog as DriveLog
from mjtrack.io.logs import read_log as read_log
from mjtrack.io.logs import read_log_with_robot as read_log_with_robot
from mjtrack.io.logs import write_log as write_log
from mjtrack.io.robot import Robot as Robot
from mjtrack.io.robot import read_robot as read_robot
from mjtrack.io.robot import write_robot as write_robot
