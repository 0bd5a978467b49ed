"""The generator of the diagnosis tests' synthetic logs (:mod:`mjtrack.testing.diagnose_logs`,
physics in :mod:`mjtrack.testing.diagnose_physics`) checked against closed forms and, as an
outside reference only, against the library's Coulomb solver (a different discretisation: they
agree to the few per cent the two discretisations differ by, not exactly).
"""

from __future__ import annotations

import numpy as np
import pytest

from mjtrack.testing.diagnose_logs import ROBOT, make_log
from mjtrack.testing.diagnose_physics import H, simulate, track_speeds


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
