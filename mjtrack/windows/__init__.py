"""Windows of a drive log, without MuJoCo: their definition, the rules that screen them, the log
transforms that choose what drives them, the window parameters and the tables their errors are
binned into.

Modules by job: ``define`` (:class:`WindowSet`, :func:`make_windows`, start states, errors at
the horizon), ``screen`` (windows the ground cannot explain), ``transforms`` (commanded or
measured drive), ``params`` (what a window simulation may vary, a robot's values of them),
``bins`` (turn ratio, window means, binned errors). The MuJoCo window simulator that uses them is
:mod:`mjtrack.sim.windows`. Import order: define -> screen; transforms, params, bins stand alone.
"""

from mjtrack.windows.bins import BinTable as BinTable
from mjtrack.windows.bins import bin_errors as bin_errors
from mjtrack.windows.bins import turn_ratio as turn_ratio
from mjtrack.windows.bins import window_means as window_means
from mjtrack.windows.define import WARMUP_S as WARMUP_S
from mjtrack.windows.define import WindowSet as WindowSet
from mjtrack.windows.define import make_windows as make_windows
from mjtrack.windows.define import measured_window_poses as measured_window_poses
from mjtrack.windows.define import start_speeds as start_speeds
from mjtrack.windows.define import start_twists as start_twists
from mjtrack.windows.define import window_errors as window_errors
from mjtrack.windows.params import COMMAND_PARAMS as COMMAND_PARAMS
from mjtrack.windows.params import DRIVE_DEFAULTS as DRIVE_DEFAULTS
from mjtrack.windows.params import GEOMETRY_PARAMS as GEOMETRY_PARAMS
from mjtrack.windows.params import MODEL_PARAMS as MODEL_PARAMS
from mjtrack.windows.params import WINDOW_PARAMS as WINDOW_PARAMS
from mjtrack.windows.params import drive_params as drive_params
from mjtrack.windows.params import geometry_robot as geometry_robot
from mjtrack.windows.params import robot_params as robot_params
from mjtrack.windows.params import slope_of as slope_of
from mjtrack.windows.screen import AGAINST_WHY as AGAINST_WHY
from mjtrack.windows.screen import STUCK_WHY as STUCK_WHY
from mjtrack.windows.screen import contradicting_windows as contradicting_windows
from mjtrack.windows.screen import left_out_counts as left_out_counts
from mjtrack.windows.screen import stuck_windows as stuck_windows
from mjtrack.windows.screen import without_contradicting as without_contradicting
from mjtrack.windows.transforms import LOGGED_COMMANDS as LOGGED_COMMANDS
from mjtrack.windows.transforms import commanded_log as commanded_log
from mjtrack.windows.transforms import measured_drive_log as measured_drive_log

__all__ = [
    "AGAINST_WHY", "COMMAND_PARAMS", "DRIVE_DEFAULTS", "GEOMETRY_PARAMS", "LOGGED_COMMANDS", "MODEL_PARAMS",
    "STUCK_WHY", "WARMUP_S", "WINDOW_PARAMS", "BinTable", "WindowSet", "bin_errors", "commanded_log",
    "contradicting_windows", "drive_params", "geometry_robot", "left_out_counts", "make_windows",
    "measured_drive_log", "measured_window_poses", "robot_params", "slope_of", "start_speeds", "start_twists",
    "stuck_windows", "turn_ratio", "window_errors", "window_means", "without_contradicting",
]
