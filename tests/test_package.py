import subprocess
import sys

import mjtrack


def test_public_api_names():
    for name in ("Robot", "DriveLog", "read_log", "write_log", "read_robot", "write_robot", "read_log_with_robot",
                 "Nominal", "MPP", "MICR", "MVIR", "integrate", "icr_from_twist", "twist_from_icr", "MjtrackError",
                 "InputError", "__version__", "simulate_log", "log_icrs", "mujoco_steady_state",
                 "coulomb_steady_state", "validate_models", "diagnose_log", "calibrate_robot"):
        assert hasattr(mjtrack, name), name


def test_importing_the_package_does_not_load_mujoco():
    code = "import sys, mjtrack; print('mujoco' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "False"
