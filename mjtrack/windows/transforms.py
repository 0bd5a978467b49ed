"""Log transforms of the window layer: which speeds drive a window's robot.

:func:`measured_drive_log` drives the robot by its measured track speeds (the drive's own
response taken from the log); :func:`commanded_log` gives back the logged commands, which say
what the robot was asked to do (e.g. which windows are steady turns).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from mjtrack.errors import InputError
from mjtrack.io.logs import DriveLog

LOGGED_COMMANDS = ("logged_v_left_cmd", "logged_v_right_cmd")  # where measured_drive_log keeps the commands


def measured_drive_log(lg: DriveLog, name: str) -> DriveLog:
    """The log with its measured track speeds in place of the commands (a track without a measured
    speed on a row keeps its command there); InputError when it has no measured speeds. A log it
    made already is returned as it is."""
    if LOGGED_COMMANDS[0] in lg.extra:
        return lg
    if lg.v_left is None or lg.v_right is None:
        raise InputError(f"{name}: driving by the measured speeds needs the measured track speeds (v_left, v_right)")
    ok = np.isfinite(lg.v_left) & np.isfinite(lg.v_right)
    if ok.mean() < 0.5:  # mostly commands: that is the commanded calibration, mislabelled
        raise InputError(f"{name}: measured track speeds on only {100 * ok.mean():.0f} % of the rows; "
                         f"driving by the measured speeds needs them on most rows")
    return dataclasses.replace(lg, v_left_cmd=np.where(np.isfinite(lg.v_left), lg.v_left, lg.v_left_cmd),
                               v_right_cmd=np.where(np.isfinite(lg.v_right), lg.v_right, lg.v_right_cmd),
                               extra={**lg.extra, LOGGED_COMMANDS[0]: lg.v_left_cmd,
                                      LOGGED_COMMANDS[1]: lg.v_right_cmd})


def commanded_log(lg: DriveLog) -> DriveLog:
    """The log with its logged commands (undoes :func:`measured_drive_log`): which windows are
    steady turns is a property of the commands."""
    if LOGGED_COMMANDS[0] not in lg.extra:
        return lg
    return dataclasses.replace(lg, v_left_cmd=lg.extra[LOGGED_COMMANDS[0]], v_right_cmd=lg.extra[LOGGED_COMMANDS[1]])
