"""What calibrate's default drive input chooses from a log, and the MuJoCo robot's own wheel-speed
error against the measured track speeds (constructed logs and simulated speeds, the expected
numbers worked out by hand)."""

from __future__ import annotations

import dataclasses

import numpy as np

from mjtrack.calibrate.result import wheel_speed_rms
from mjtrack.calibrate.run import auto_drive_input
from mjtrack.io.logs import DriveLog
from mjtrack.io.robot import Robot
from mjtrack.windows import WindowSet


def _log(n=40, measured=None):
    t = np.arange(n) * 0.05
    z = np.zeros(n)
    lg = DriveLog(t=t, v_left_cmd=z + 0.5, v_right_cmd=z + 0.8, x=0.6 * t, y=z, yaw=z)
    if measured is not None:
        lg = dataclasses.replace(lg, v_left=measured[0], v_right=measured[1])
    return lg


def _turn_capped(n=80):
    """Straight runs ramped to 2 m/s and reached, then spins commanded up to a half difference of
    1 m/s whose measured half difference stops at 0.4 m/s."""
    straight = np.linspace(0.0, 2.0, n // 2)
    half_cmd = np.linspace(0.0, 1.0, n - n // 2)
    half = np.minimum(half_cmd, 0.4)
    return dataclasses.replace(_log(n), v_left_cmd=np.r_[straight, -half_cmd], v_right_cmd=np.r_[straight, half_cmd],
                               v_left=np.r_[straight, -half], v_right=np.r_[straight, half])


def test_auto_fits_the_drivetrain_only_to_measured_speeds_that_show_a_capping_controller():
    robot = Robot(track_gauge=0.4)
    assert auto_drive_input(_log(), robot, None)[0] == "commanded"
    copies = _log(measured=(np.full(40, 0.5), np.full(40, 0.8)))
    mode, why = auto_drive_input(copies, robot, None)
    assert mode == "commanded" and "copies" in why
    # slower than commanded, but every command reached in proportion: lag, delay and speed scale
    # describe it, and the pose fit has them
    slow = _log(measured=(np.full(40, 0.45), np.full(40, 0.72)))  # 0.9 times each command
    mode, why = auto_drive_input(slow, robot, None)
    assert mode == "commanded" and "0.0667 m/s RMS" in why  # sqrt((0.05^2 + 0.08^2) / 2) = 0.0667
    assert "no speed controller capping" in why
    # commands ramping to 2 m/s, both sides held at 1 m/s above 1 m/s: the drives saturate
    n = 80
    ramp = np.linspace(0.0, 2.0, n)
    capped = dataclasses.replace(_log(n), v_left_cmd=ramp, v_right_cmd=ramp, v_left=np.minimum(ramp, 1.0),
                                 v_right=np.minimum(ramp, 1.0))
    mode, why = auto_drive_input(capped, robot, None)
    assert mode == "fitted" and "saturate" in why and "never exceed 1 / 1 m/s" in why
    # a user who names the drive's timing wants it fitted to the poses
    assert auto_drive_input(capped, robot, "mu,drive_lag")[0] == "commanded"
    assert auto_drive_input(capped, robot, ["mu", "cg_x"])[0] == "fitted"
    # straight runs to 2 m/s, reached, then spins commanded to 1 m/s half difference, the half
    # difference held at 0.4 m/s: each side's speed within reach, the controller caps the turn
    mode, why = auto_drive_input(_turn_capped(), robot, None)
    assert mode == "fitted" and "caps the turn" in why and "never exceeds 0.4 m/s" in why and "saturate" not in why
    # measured speeds on a few rows only: none to fit
    sparse = _log(measured=(np.where(np.arange(40) < 5, 0.45, np.nan), np.full(40, 0.7)))
    assert auto_drive_input(sparse, robot, None)[0] == "commanded"


def test_wheel_speed_rms_compares_the_simulated_rows_after_each_windows_start():
    n = 40
    meas = (np.linspace(0.0, 1.0, n), np.linspace(1.0, 0.0, n))
    lg = _log(n, measured=meas)
    ws = WindowSet(starts=np.array([0, 20]), ends=np.array([19, 39]), segment=np.zeros(2, int), horizon_s=1.0)
    sim = np.full((2, 20, 2), np.nan)
    for j, s in enumerate((0, 20)):
        sim[j, :, 0] = meas[0][s:s + 20] + 0.1  # left 0.1 m/s fast on every row
        sim[j, :, 1] = meas[1][s:s + 20] * 1.2  # right: 1.2 times the measured
        sim[j, 0] = 99.0  # the start row is the measured state: never scored
    (same,) = wheel_speed_rms(lg, ws, [(sim, 1.0)], np.zeros(2, bool))
    rows = np.r_[1:20, 21:40]
    assert abs(same["left"] - 0.1) < 1e-12
    assert abs(same["right"] - np.sqrt(np.mean((0.2 * meas[1][rows]) ** 2))) < 1e-12
    # over a speed scale (an effective rolling radius): the right side then matches, the left does not
    (scaled,) = wheel_speed_rms(lg, ws, [(sim, 1.2)], np.zeros(2, bool))
    assert scaled["right"] < 1e-12
    assert abs(scaled["left"] - np.sqrt(np.mean(((meas[0][rows] + 0.1) / 1.2 - meas[0][rows]) ** 2))) < 1e-12
    # a skipped (diverged) window is left out; no measured speeds: no answer
    sim[1] = 50.0
    (kept,) = wheel_speed_rms(lg, ws, [(sim, 1.0)], np.array([False, True]))
    assert abs(kept["left"] - 0.1) < 1e-12
    assert wheel_speed_rms(_log(n), ws, [(sim, 1.0)], np.zeros(2, bool)) is None


def test_drive_caps_names_each_cap_the_measured_speeds_show_with_the_fitted_limit_beside():
    from mjtrack.calibrate.result import drive_caps

    n = 80
    ramp = np.linspace(0.0, 2.0, n)
    # sides and mean speed reached in full, the half difference held at 0.4 m/s: the turn is capped
    text = drive_caps(_turn_capped(), {"drive_turn_limit": 0.41})
    assert text.startswith("its speed controller caps the turn") and "fitted limit 0.41 m/s" in text
    assert "saturate" not in text and "mean speed" not in text
    # straight runs capped at 1 m/s: each side and the mean speed
    capped = dataclasses.replace(_log(n), v_left_cmd=ramp, v_right_cmd=ramp, v_left=np.minimum(ramp, 1.0),
                                 v_right=np.minimum(ramp, 1.0))
    text = drive_caps(capped)
    assert "its drives saturate" in text and "caps the mean speed" in text and "caps the turn" not in text
    assert drive_caps(_log()) == ""  # no measured speeds: nothing to say


def test_the_batterys_logs_are_calibrated_from_their_commands_by_default():
    """The battery's drives follow their commands through a lag, a delay and a speed scale, which the
    commanded path's candidates describe exactly: the default drive input must not send them through
    a drivetrain fitted to the simulated speeds (the calibration page's battery under other drive
    inputs measures what that costs)."""
    from mjtrack.testing.battery import GEOMETRIES, case, described_robot, make_log

    for geometry in GEOMETRIES:
        for change in ("clean", "lag_delay", "track_speed_scale"):
            c = case(geometry, change)
            mode, why = auto_drive_input(make_log(c, duration=20.0, seed=11), described_robot(c), None)
            assert mode == "commanded" and "no speed controller capping" in why, (c.name, why)
