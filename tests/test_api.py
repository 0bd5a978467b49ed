"""The public Python API (mjtrack.api, re-exported by mjtrack): its docstring examples run and
print what they say, and each function gives what its command gives."""

from __future__ import annotations

import doctest
import json

import numpy as np
import pytest

import mjtrack
import mjtrack.api as api
from mjtrack.errors import InputError
from mjtrack.io.logs import read_log
from support.cli import run_cli

EXAMPLES = [t for t in doctest.DocTestFinder().find(api) if t.examples]


def test_every_public_function_has_an_example():
    public = {name for name in dir(api) if not name.startswith("_") and callable(getattr(api, name))
              and getattr(api, name).__module__ == api.__name__}
    assert public == {t.name.rsplit(".", 1)[1] for t in EXAMPLES}
    for name in public:
        assert getattr(mjtrack, name) is getattr(api, name), name  # re-exported


@pytest.mark.parametrize("example", EXAMPLES, ids=lambda t: t.name.rsplit(".", 1)[1])
def test_docstring_example(example):
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS)
    result = runner.run(example, out=lambda text: print(text, end=""))
    assert result.failed == 0, f"{example.name}: {result.failed} of {result.attempted} examples failed (output above)"


def test_simulate_log_is_the_simulate_command(tmp_path):
    out = tmp_path / "run.csv"
    res = run_cli(["simulate", "--scenario", "random_steps", "--duration", "3", "--seed", "4", "--log-rate", "20",
                   "--mass", "30", "--out", str(out), "-q"])
    assert res.rc == 0, res.err
    log = api.simulate_log(mjtrack.Robot(mass=30.0), scenario="random_steps", duration=3.0, seed=4, log_rate=20.0)
    assert log == read_log(out)


def test_commands_as_arrays_or_csv_give_one_log(tmp_path):
    t = np.array([0.0, 0.5, 1.0])
    vl, vr = np.array([0.2, 0.4, -0.3]), np.array([0.2, 0.6, 0.3])
    path = tmp_path / "cmd.csv"
    rows = zip(t.tolist(), vl.tolist(), vr.tolist())
    path.write_text("t,v_left_cmd,v_right_cmd\n" + "".join(f"{a},{b},{c}\n" for a, b, c in rows))
    robot = mjtrack.Robot()
    a = api.simulate_log(robot, commands=(t, vl, vr), log_rate=20.0)
    b = api.simulate_log(robot, commands=path, log_rate=20.0)
    assert a == b and a.t[-1] == pytest.approx(2.0)  # default duration: last command + 1 s


@pytest.mark.parametrize("kwargs, match", [
    ({}, "exactly one of scenario and commands"),
    ({"scenario": "circle", "commands": ([0.0], [0.1], [0.1])}, "exactly one"),
    ({"commands": ([0.0, 0.0], [0.1, 0.1], [0.1, 0.1])}, "increase strictly"),
    ({"commands": ([0.0, 1.0], [0.1], [0.1, 0.2])}, "one length"),
    ({"commands": ([0.0, 1.0], [0.1, np.nan], [0.1, 0.2])}, "finite"),
    ({"scenario": "no_such"}, "unknown scenario"),
    ({"scenario": "straight", "terrain": "incline:x"}, "incline"),
])
def test_simulate_log_refuses_bad_input(kwargs, match):
    with pytest.raises(InputError, match=match):
        api.simulate_log(mjtrack.Robot(), **kwargs)


def test_log_icrs_needs_the_twist_and_the_track_speeds():
    log = api.simulate_log(mjtrack.Robot(), scenario="pivot", duration=1.0)
    bare = mjtrack.DriveLog(t=log.t, v_left_cmd=log.v_left_cmd, v_right_cmd=log.v_right_cmd, x=log.x, y=log.y,
                            yaw=log.yaw, source="bare.csv")
    with pytest.raises(InputError, match="bare.csv: ICRs need"):
        api.log_icrs(bare)


def test_the_two_steady_states_are_different_functions_on_one_robot():
    """mujoco_steady_state is the MuJoCo robot (mjtrack steady), coulomb_steady_state the
    rigid-track reference; on the default robot in a gentle turn they agree to the fidelity
    grid's bound (0.05 T/2), so the names cannot have been swapped for the same solver."""
    robot = mjtrack.Robot()
    mj = api.mujoco_steady_state(robot, 0.3, 0.6)
    ref = api.coulomb_steady_state(robot, 0.3, 0.6)
    assert type(mj).__module__ == "mjtrack.sim.steady" and type(ref).__module__ == "mjtrack.models.coulomb"
    assert abs(mj.y_l - ref.y_l) < 0.05 * robot.track_gauge / 2
    assert abs(mj.y_r - ref.y_r) < 0.05 * robot.track_gauge / 2
    res = run_cli(["steady", "--v-left", "0.3", "--v-right", "0.6", "--json"])
    assert res.rc == 0, res.err
    assert json.loads(res.out)["y_l"] == mj.y_l


def _documented_parameters(function) -> list[tuple[str, str]]:
    """(name, text) of each parameter entry of a docstring as the docs render it (napoleon's
    Google-style parser, which gives ``a, b: text`` one entry per name with the same text)."""
    import inspect
    import re

    from sphinx.ext.napoleon import Config
    from sphinx.ext.napoleon.docstring import GoogleDocstring

    text = str(GoogleDocstring(inspect.getdoc(function), Config(napoleon_use_param=True)))
    entries = re.findall(r"^:param ([^:\s]+):(.*(?:\n {2,}.*)*)", text, re.MULTILINE)
    return [(name, " ".join(body.split())) for name, body in entries]


@pytest.mark.parametrize("name", sorted(n for n in dir(api) if not n.startswith("_")
                                        and callable(getattr(api, n)) and getattr(api, n).__module__ == api.__name__))
def test_every_parameter_has_its_own_docstring_entry(name):
    import inspect

    function = getattr(api, name)
    entries = _documented_parameters(function)
    assert [n for n, _ in entries] == list(inspect.signature(function).parameters)  # each, in order
    texts = [t for _, t in entries]
    assert all(texts) and len(set(texts)) == len(texts), entries  # none empty, none shared


def test_the_parameter_check_sees_a_shared_entry():
    def f(a, b):
        """Do.

        Args:
            a, b: two things in one text.
        """

    entries = _documented_parameters(f)
    assert [n for n, _ in entries] == ["a", "b"] and entries[0][1] == entries[1][1]
