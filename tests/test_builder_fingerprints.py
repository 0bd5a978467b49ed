"""The robot builders make bit-identical models from the same inputs (tests/support/builder_fingerprints.py).

A model-change detector: 13 cases (3 robots, both track models, flat / incline / step / height
field, ground models, roller couplings, surfacevel element variants) compiled and rolled out for
150 steps; every MjModel field group, the robot spec's XML and the (qpos, qvel) of every step are
compared by hash with ``tests/data/builder_fingerprints.json``, built with the stored SimConfig
fields (a changed default elsewhere does not show here). Checked sensitive: a 1e-10 m change of
the chassis box height changes every case. After an *intended* model change, regenerate with
``python tests/support/builder_fingerprints.py --write`` and say why in the commit.
"""

from __future__ import annotations

import json

import mujoco
import pytest

from support.builder_fingerprints import STORE, current, differences


def test_models_and_rollouts_unchanged():
    stored = json.loads(STORE.read_text())
    versions = {case.get("mujoco") for case in stored.values()}
    if versions != {mujoco.__version__}:  # another MuJoCo compiles and steps differently by design
        pytest.skip(f"fingerprints stored with mujoco {sorted(map(str, versions))}, running {mujoco.__version__}")
    diff = differences(stored, current(stored))
    assert not diff, "robot models changed:\n" + "\n".join(diff)
