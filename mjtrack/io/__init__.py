"""Input and output: drive logs (CONTRACTS.md §1), robot descriptions (§2), atomic files."""

from mjtrack.io.logs import DriveLog as DriveLog
from mjtrack.io.logs import read_log as read_log
from mjtrack.io.logs import read_log_with_robot as read_log_with_robot
from mjtrack.io.logs import write_log as write_log
from mjtrack.io.robot import Robot as Robot
from mjtrack.io.robot import read_robot as read_robot
from mjtrack.io.robot import write_robot as write_robot
