"""GENERATOR of synthetic drive logs with hidden effects, for the diagnosis tests.

The physics is :mod:`diagnose_physics` (tests/diagnose_physics.py): an independent rigid-body
simulation with its own contact discretisation (Gauss-Legendre grids, regularised Coulomb
friction, plane-pressure load transfer) and its own integrator; it shares no code with
``mjtrack.models.coulomb`` nor with the diagnosis surrogate, so the diagnosis tests check the
physics, not the fit. This module keeps the interface the diagnosis tests use (an effect name,
or a tuple of names, with the magnitudes of ``HIDDEN``).

The tests at the bottom check the generator itself against closed forms and, as an outside
reference only, against the library's Coulomb solver (a different discretisation: they agree
to the few per cent the two discretisations differ by, not exactly).
"""

from __future__ import annotations

import numpy as np
import pytest
from diagnose_physics import (GEOMETRIES, H, SPEED_STD, XY_STD, YAW_STD, commands, simulate,  # noqa: F401
                              track_speeds)
from diagnose_physics import make_log as make_physics_log

from mjtrack.io.logs import DriveLog
from mjtrack.io.robot import Robot

ROBOT = GEOMETRIES["small"][0]  # the nominal robot of the synthetic logs (full description)

HIDDEN = {  # effect -> its parameters in the synthetic logs
    "cg_offset_x": {"cg_offset_x": 0.06},
    "cg_offset_y": {"cg_offset_y": -0.05},
    "friction_scale": {"friction_scale": 0.35},
    "friction_asymmetry": {"friction_asymmetry": 0.6},
    "track_speed_scale": {"track_speed_scale": 0.85},
    "actuator_lag": {"actuator_lag": 0.3},
    "command_delay": {"command_delay": 0.25},
    "speed_limit": {"speed_limit": 0.6},
    "slope": {"slope": 0.12, "slope_direction": 0.8},
    "yaw_rate_limit": {"yaw_rate_limit": 1.5},
}


def make_log(effect: str | tuple | None, *, seed: int = 0, duration: float = 240.0, dt: float = 0.05,
             speeds: bool = False, turning: bool = True, geometry: str = "small",
             layout: str = "continuous") -> tuple[DriveLog, Robot]:
    """A log of the nominal robot with ``effect`` hidden (None = clean; a tuple = several
    effects at once); returns (log, nominal robot)."""
    names = effect if isinstance(effect, tuple) else (effect,)
    params = {k: v for n in names if n for k, v in HIDDEN[n].items()}
    return make_physics_log(params, geometry=geometry, seed=seed, duration=duration, rate=1.0 / dt, speeds=speeds,
                            turning=turning, layout=layout)


# -- tests of the generator itself --------------------------------------------------------
def test_generator_is_seeded():
    a, _ = make_log("cg_offset_x", seed=3, duration=10.0)
    b, _ = make_log("cg_offset_x", seed=3, duration=10.0)
    c, _ = make_log("cg_offset_x", seed=4, duration=10.0)
    assert a == b and a != c


def _steady(vl, vr, robot=ROBOT, kind="tracks", seconds=3.0, **kw):
    t = np.arange(0.0, seconds, H)
    _, tw = simulate(robot, kind, t, np.tile([vl, vr], (t.size, 1)), mu=kw.pop("mu", (robot.mu, robot.mu)), **kw)
    return tw[-1]


def test_straight_driving_follows_the_tracks_and_starts_at_mu_g():
    tw = _steady(0.5, 0.5)
    np.testing.assert_allclose(tw, [0.5, 0.0, 0.0], atol=2e-3)
    # a step 0 -> 1 m/s: the body can only accelerate at mu g (closed form), until it catches up
    t = np.arange(0.0, 0.1, H)
    v = np.tile([1.0, 1.0], (t.size, 1))
    v[0] = 0.0
    _, tw = simulate(ROBOT, "tracks", t, v, mu=(ROBOT.mu, ROBOT.mu))
    accel = np.diff(tw[:, 0])[3:10] / H
    np.testing.assert_allclose(accel, ROBOT.mu * 9.81, rtol=0.05)  # regularised Coulomb: ~mu g while sliding


def test_turn_agrees_with_an_outside_coulomb_reference():
    """The library's rigid-track Coulomb steady state (another discretisation, another solver)
    as an outside reference: the yaw rate and speed agree within 3 %."""
    from mjtrack.models import coulomb

    for vl, vr in ((0.2, 0.7), (-0.4, 0.4), (0.6, 0.0)):
        tw = _steady(vl, vr)
        ref = coulomb.steady_state(ROBOT, vl, vr).twist
        assert tw[2] == pytest.approx(ref[2], rel=0.03)
        assert tw[0] == pytest.approx(ref[0], abs=0.03 * max(abs(vl), abs(vr)))


def test_input_effects_act_on_the_track_speeds():
    t = np.arange(0.0, 4.0, 0.05)
    cl = np.where(t < 1.0, 0.0, 1.0)
    cr = np.where(t < 1.0, 0.0, -1.0)
    tf = np.arange(0.0, 4.0, H)
    v = track_speeds(tf, t, cl, cr, {"actuator_lag": 0.2}, 0.4)
    k = np.searchsorted(tf, 1.2 + 1e-9)  # one time constant after the step
    assert v[k, 0] == pytest.approx(1 - np.exp(-1), abs=0.02)
    v = track_speeds(tf, t, cl, cr, {"yaw_rate_limit": 1.5}, 0.4)
    assert np.max(np.abs(v[:, 1] - v[:, 0])) / 0.4 == pytest.approx(1.5)
    v = track_speeds(tf, t, cl, cr, {"command_delay": 0.3}, 0.4)
    assert v[np.searchsorted(tf, 1.25), 0] == 0.0 and v[np.searchsorted(tf, 1.35), 0] == 1.0


def test_drive_layout_has_short_windows():
    log, _ = make_log(None, seed=1, duration=20.0, layout="drive")
    seg = log.segment_slices()
    assert len(seg) == 10 and all(s.stop - s.start == 39 for s in seg)
