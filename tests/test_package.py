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


def test_one_version_everywhere():
    """The package, its metadata, the docs and the changelog's newest release name one version."""
    import re
    import tomllib
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    pyproject = tomllib.loads((root / "pyproject.toml").read_text())["project"]["version"]
    conf = (root / "docs" / "conf.py").read_text()
    assert "release = mjtrack.__version__" in conf  # the docs take the package's number
    newest = re.search(r"^## (\S+)", (root / "docs" / "changelog.md").read_text(), re.MULTILINE).group(1)
    assert pyproject == mjtrack.__version__ == newest == "0.3.0"
    assert "unreleased" not in (root / "docs" / "changelog.md").read_text().split("\n## ", 2)[1].splitlines()[0]
