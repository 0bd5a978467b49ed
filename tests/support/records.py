"""Drive logs with a record the ground cannot explain in one window, for the tests of the windows
left out.

    from support.records import with_backward_window, with_held_window

    bad, (s, e) = with_backward_window(log, start_row=80, end_row=120)
    held, (s, e) = with_held_window(log, start_row=80, end_row=120)

``with_backward_window``: the rows ``start_row .. end_row`` become a window in which both tracks
drive forwards at a constant speed (commands, and measured speeds where the log has them) while
the poses move backwards along the start heading at another constant speed, as a localisation that
flipped would record it; the rows after the window are shifted so that the log continues from
there as before. ``with_held_window``: in those rows the tracks spin in opposite directions at a
constant speed while the poses stay where the window starts, as a robot caught on an obstacle
would record it. Written here, with no code of :mod:`mjtrack.windows.screen`, which finds such
windows.
"""

from __future__ import annotations

import numpy as np

from mjtrack.io.logs import DriveLog


def _rows(lg: DriveLog, start_row: int, end_row: int) -> tuple[int, int]:
    s, e = int(start_row), int(end_row)
    if not 0 <= s < e < lg.n_samples:
        raise ValueError(f"rows {s}..{e} are not inside the log's {lg.n_samples}")
    return s, e


def _rewritten(lg: DriveLog, s: int, e: int, poses: dict, left: float, right: float) -> DriveLog:
    """``lg`` with the pose columns ``poses`` and, on rows s .. e - 1, the track columns (commands,
    and measured speeds where the log has them) at ``left`` and ``right`` [m/s]."""
    changes = dict(poses)
    for name, v in (("v_left_cmd", left), ("v_right_cmd", right), ("v_left", left), ("v_right", right)):
        col = getattr(lg, name)
        if col is not None:
            col = col.copy()
            col[s:e] = v
            changes[name] = col
    return lg.replace(**changes)


def with_backward_window(lg: DriveLog, start_row: int, end_row: int, *, track_speed: float = 0.6,
                         body_speed: float = 0.8) -> tuple[DriveLog, tuple[int, int]]:
    """``lg`` with rows ``start_row .. end_row`` (inclusive) rewritten as the module docstring says;
    returns the new log and the row range."""
    s, e = _rows(lg, start_row, end_row)
    t = lg.t - lg.t[s]
    heading = float(lg.yaw[s])
    x, y, yaw = lg.x.copy(), lg.y.copy(), lg.yaw.copy()
    x[s:e + 1] = lg.x[s] - body_speed * t[s:e + 1] * np.cos(heading)
    y[s:e + 1] = lg.y[s] - body_speed * t[s:e + 1] * np.sin(heading)
    yaw[s:e] = heading  # the last row keeps its own heading: the log goes on from there
    x[e + 1:] += x[e] - lg.x[e]
    y[e + 1:] += y[e] - lg.y[e]
    return _rewritten(lg, s, e, {"x": x, "y": y, "yaw": yaw}, track_speed, track_speed), (s, e)


def with_held_window(lg: DriveLog, start_row: int, end_row: int, *, track_speed: float = 0.8
                     ) -> tuple[DriveLog, tuple[int, int]]:
    """``lg`` with rows ``start_row .. end_row`` (inclusive) rewritten as the module docstring says;
    returns the new log and the row range."""
    s, e = _rows(lg, start_row, end_row)
    x, y, yaw = lg.x.copy(), lg.y.copy(), lg.yaw.copy()
    x[s:e + 1], y[s:e + 1], yaw[s:e + 1] = lg.x[s], lg.y[s], lg.yaw[s]
    x[e + 1:] += x[e] - lg.x[e]  # the log goes on from where the robot was held
    y[e + 1:] += y[e] - lg.y[e]
    yaw[e + 1:] += yaw[e] - lg.yaw[e]
    return _rewritten(lg, s, e, {"x": x, "y": y, "yaw": yaw}, -track_speed, track_speed), (s, e)
