"""Calibration of the MuJoCo robot to a measured log (``mjtrack calibrate``)."""
