"""Diagnosis on MuJoCo logs: every hidden effect named, estimated within 25 %, with a held-out gain;
clean logs give "none".

The logs come from the separate MuJoCo GENERATOR (mjtrack/testing/mujoco_effects.py): the robot of
mjtrack.sim with one effect of diagnosis.json's vocabulary hidden, pose noise 1 cm / 0.3 deg at 20 Hz,
pose only or with the simulated track speeds. The diagnosis gets the log and the nominal robot
only. The default run checks a few effects on 120 s logs; the full matrix (every effect x
{pose only, with speeds} + clean) is ``-m slow``. Known failures would be strict xfails with the
measured reason (none at present; ``benchmarks/diagnose_mujoco_effects.py`` prints the whole table).
"""

from __future__ import annotations

import ast
import math
from pathlib import Path

import numpy as np
import pytest

from mjtrack.diagnose import diagnose
from mjtrack.io.robot import G
from mjtrack.sim.rollout import hold_commands
from mjtrack.testing import mujoco_effects
from mjtrack.testing.effect_names import VOCABULARY_NAME, generator_name, vocabulary_params
from mjtrack.testing.mujoco_effects import DRIVES, HIDDEN, LOG_DT, ROBOT, apply_input, commands, make_log, slope_gravity

DURATION = 120.0  # [s] per log: 2400 samples, 5 folds of 2 s windows; ~1.5 s to simulate, ~2 s to diagnose
SEED = 11
REL = 0.25  # the requirement: estimate within +-25 %


def _named(effect: str, *, speeds: bool, seed: int = SEED, duration: float = DURATION):
    log, robot = make_log(generator_name(effect), seed=seed, duration=duration, speeds=speeds)
    d = diagnose(log, robot, baseline="surrogate", max_effects=1)
    r = next(x for x in d.results if x.effect.name == effect)
    top = d.findings[0] if d.findings else None
    assert r.passed and (d.cause == effect or effect in top.tied_with), (
        f"{effect}: cause {d.cause}, findings {[x.effect.name for x in d.findings]}; {r.why}")
    est = dict(zip(r.effect.params, r.estimate))
    truth = vocabulary_params(HIDDEN[generator_name(effect)].params)
    for name, value in truth.items():
        if effect == "slope":  # a component: within REL of the slope's size
            assert abs(est[name] - value) < REL * math.hypot(*truth.values()), name
        else:
            assert est[name] == pytest.approx(value, rel=REL), name
    assert r.relative > 0 and r.after < r.before  # positive held-out gain
    if speeds and r.effect.kind == "input":  # the measured track speeds confirm an actuator cause
        assert r.speed_after < 0.5 * r.speed_before
    return d


def _clean(*, speeds: bool, seed: int = SEED, duration: float = DURATION):
    log, robot = make_log(None, seed=seed, duration=duration, speeds=speeds)
    d = diagnose(log, robot, baseline="surrogate")
    assert d.cause == "none", [r.why for r in d.findings]
    return d


# -- default run: a few effects ---------------------------------------------------------------
@pytest.mark.parametrize("effect,speeds", [("cg_x", False), ("slope", False), ("mu_ratio", True),
                                           ("friction_scale", False),
                                           ("drive_lag", True), ("drive_delay", True), ("drive_speed_limit", False),
                                           ("track_speed_scale", False)])
def test_hidden_effect_named_on_mujoco_log(effect, speeds):
    _named(effect, speeds=speeds)


def test_clean_mujoco_log_with_track_speeds_gives_none():
    _clean(speeds=True)


# -- full matrix ------------------------------------------------------------------------------
# (effect, speeds) -> why it fails, measured by benchmarks/diagnose_mujoco_effects.py; empty since the
# baseline's transient models the yaw (surrogate.friction_limited): the clean pose-only logs (an actuator
# lag was fitted to the slow turn entry), friction_scale (pose only: cause actuator_lag; with speeds
# estimated +27 %) and cg_y with speeds (mu_ratio 4 % better) were strict xfails before.
KNOWN: dict[tuple[str, bool], str] = {}
CLEAN_KNOWN: dict[bool, str] = {}


def _matrix():
    # the surrogate's vocabulary, as benchmarks/diagnose_mujoco_effects.py runs it: the MuJoCo-only
    # grounds (kind "model", e.g. ground_anisotropy) are not effects of the surrogate baseline
    # (they need --baseline mujoco: tests/test_diagnose_mujoco_baseline.py); listing them here made the
    # slow matrix fail with StopIteration once the anisotropic ground was added
    for effect in (VOCABULARY_NAME.get(name, name) for name, h in HIDDEN.items() if h.kind != "model"):
        for speeds in (False, True):
            why = KNOWN.get((effect, speeds))
            marks = [pytest.mark.xfail(strict=True, reason=why)] if why else []
            yield pytest.param(effect, speeds, marks=marks, id=f"{effect}-{'speeds' if speeds else 'pose'}")


@pytest.mark.slow
@pytest.mark.parametrize("effect,speeds", list(_matrix()))
def test_every_hidden_effect_on_mujoco_logs(effect, speeds):
    _named(effect, speeds=speeds)


@pytest.mark.slow
@pytest.mark.parametrize("speeds", [pytest.param(s, marks=[pytest.mark.xfail(strict=True, reason=CLEAN_KNOWN[s])]
                                                 if s in CLEAN_KNOWN else [], id="speeds" if s else "pose")
                                    for s in (False, True)])
@pytest.mark.parametrize("seed", [11, 12])
def test_clean_mujoco_logs_give_none(speeds, seed):
    _clean(speeds=speeds, seed=seed)


# -- the generator itself ---------------------------------------------------------------------
def test_generator_is_seeded_pose_only_and_keeps_the_commands():
    a, robot = make_log("track_speed_scale", seed=3, duration=6.0)
    b, _ = make_log("track_speed_scale", seed=3, duration=6.0)
    assert a == b and robot == ROBOT
    assert a.v_left is None and a.v_right is None and a.vx is None  # pose only: no speeds, no twist
    t, vl, vr = commands(np.random.default_rng(3), 6.0)
    np.testing.assert_array_equal(a.v_left_cmd, vl)  # the log keeps the commanded speeds
    c, _ = make_log("track_speed_scale", seed=3, duration=6.0, speeds=True)
    moving = np.abs(c.v_left_cmd) > 0.1
    # measured speeds are the simulation's: 0.85 x the command once settled (0.01 m/s noise)
    ratio = np.median(c.v_left[1:][moving[:-1]] / c.v_left_cmd[:-1][moving[:-1]])
    assert ratio == pytest.approx(0.85, abs=0.02)


def test_commands_turn_both_ways_within_the_speed_range():
    t, vl, vr = commands(np.random.default_rng(0), 300.0)
    assert np.max(np.abs([vl, vr])) <= 0.8
    turn = (vr - vl) / np.maximum(np.abs(vl) + np.abs(vr), 1e-9)
    assert np.mean(turn > 0.2) > 0.2 and np.mean(turn < -0.2) > 0.2 and np.mean(np.abs(turn) < 1e-9) > 0.05
    assert np.mean(vl + vr < 0) > 0.1  # backwards too


def test_input_transforms_are_exact():
    dt = DRIVES.timestep
    t = np.array([0.0, 1.0])
    steps = hold_commands(t, np.array([0.0, 0.5]), np.array([0.0, -0.4]), timestep=dt, duration=3.0)
    lag = apply_input(steps, HIDDEN["actuator_lag"], dt)
    k = np.arange(steps.shape[0])
    tau = HIDDEN["actuator_lag"].params["actuator_lag"]
    # held step at t = 1 s: y(t) = V (1 - exp(-(t - 1)/tau)), exact at the step boundaries
    expect = 0.5 * -np.expm1(-np.clip(k * dt - 1.0, 0, None) / tau)
    np.testing.assert_allclose(lag[:, 0], expect, atol=1e-12)
    delay = apply_input(steps, HIDDEN["command_delay"], dt)
    shift = int(round(0.2 / dt))
    np.testing.assert_array_equal(delay[shift:], steps[:-shift])
    assert np.all(delay[:shift] == 0)
    assert np.max(np.abs(apply_input(steps, HIDDEN["speed_limit"], dt))) == pytest.approx(0.4)
    np.testing.assert_allclose(apply_input(steps, HIDDEN["track_speed_scale"], dt), 0.85 * steps)


def test_slope_gravity_points_downhill():
    g = slope_gravity(np.radians(8.0), 0.8)
    assert np.linalg.norm(g) == pytest.approx(G)
    uphill = np.array([np.cos(0.8), np.sin(0.8), 0.0])
    assert g @ uphill == pytest.approx(-G * np.sin(np.radians(8.0)))
    assert g[2] == pytest.approx(-G * np.cos(np.radians(8.0)))


def test_generator_shares_nothing_with_the_diagnosis():
    tree = ast.parse(Path(mujoco_effects.__file__).read_text())
    imported = {n.module for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)}
    imported |= {a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names}
    assert imported and not any(m.startswith("mjtrack.diagnose") for m in imported)
    assert not any(a.name == "diagnose" for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) for a in n.names)


# -- the baseline's friction-limited transient (the fix these logs called for) ----------------
def test_accel_limited_ramp_closed_form():
    """A step of D at rate a: the per-step means of the exact ramp, dead time D / (2a), and the
    speed is at its target again after D / a; a segment start resets to the target."""
    from mjtrack.diagnose.surrogate import accel_limited

    h, a, D = LOG_DT, 7.848, 0.9
    u = np.r_[np.zeros(10), np.full(20, D), np.full(10, -D)]
    starts = np.zeros(u.size, bool)
    starts[0] = True
    y = accel_limited(u, np.full(u.size, h), a, starts)
    fine = np.linspace(0, u.size * h, u.size * 2000, endpoint=False)  # exact ramp, averaged per step
    ramp = np.clip(a * (fine - 10 * h), 0, D)
    ramp = np.where(fine >= 30 * h, np.maximum(D - a * (fine - 30 * h), -D), ramp)
    np.testing.assert_allclose(y, ramp.reshape(u.size, -1).mean(1), atol=1e-3)
    assert np.sum(u[10:30] - y[10:30]) * h / D == pytest.approx(D / (2 * a), rel=1e-3)
    starts[30] = True  # a new segment starts in steady motion: no ramp
    np.testing.assert_array_equal(accel_limited(u, np.full(u.size, h), a, starts)[30:], u[30:])
