"""The Coulomb rollout's transients against the independent rigid-body generator.

mjtrack/testing/diagnose_physics.py integrates the same kind of body with its own code (linearly implicit
Euler, its own plane-pressure loads lagged one step, regularised Coulomb). With its step and
regularisation small (5e-5 s, 1e-4 m/s) its lags vanish, and on the same body — four contacts at
(+-0.25, +-0.275) m (the rollout's two midpoints per side of a 1.0 m line), 50 kg, the same yaw
inertia, cg 0.2 m high — both must give the same yaw response after a step of the track speeds.
Measured by the equivalent dead time int (w_end - w)/(w_end - w_0) dt over 1 s from the step.
With one fixed-point step of the load transfer per evaluation (``load_iterations=1``) the rollout is 8 % too
slow on a turn entry from straight driving (0.0701 vs 0.0649 s); converged, within 0.1 %.
"""

from __future__ import annotations

import numpy as np
import pytest

from mjtrack.models import coulomb
from mjtrack.testing import diagnose_physics as phys

V, DUR = 0.5, 1.0
ROBOT, KIND = phys.GEOMETRIES["wheeled"]  # 4 wheels at (+-WHEELBASE/2, +-T/2)
BODY = ROBOT.replace(track_length=2 * phys.WHEELBASE)  # two midpoints per side at +-0.25 m
INERTIA = ROBOT.mass * (ROBOT.track_length**2 + ROBOT.track_gauge**2) / 12  # the generator's


def _dead(t, w):
    d = (w[-1] - w) / (w[-1] - w[0])
    return float(np.sum(0.5 * (d[1:] + d[:-1]) * np.diff(t)))


def _generator(u0, u1, monkeypatch):
    monkeypatch.setattr(phys, "H", 5e-5)
    monkeypatch.setattr(phys, "EPS", 1e-4)
    h = phys.H
    pre, n = int(round(0.5 / h)), int(round(DUR / h))
    u = V * np.r_[np.tile(u0, (pre, 1)), np.tile(u1, (n, 1))]
    _, tw = phys.simulate(ROBOT, KIND, np.arange(u.shape[0]) * h, u, mu=(ROBOT.mu, ROBOT.mu))
    w = np.r_[tw[pre - 1, 2], tw[pre:, 2]]  # tw[k]: after step k; the new command acts in step pre
    return _dead(np.arange(w.size) * h, w)


def _rollout(u0, u1, **kw):
    vl0, vr0 = V * u0[0], V * u0[1]
    tw0 = (vl0, 0.0, 0.0) if vl0 == vr0 else tuple(coulomb.steady_state(BODY, vl0, vr0, n_points=2).twist)
    t = np.arange(0.0, DUR + 5e-4, 1e-3)
    r = coulomb.rollout(BODY, t, V * u1[0], V * u1[1], twist0=tw0, n_points=2, inertia=INERTIA, **kw)
    return _dead(t, r.twist[:, 2])


def test_the_same_body_gives_the_same_contact_points():
    x, y, _ = coulomb.normal_loads(BODY, n_points=2)
    np.testing.assert_allclose(np.sort(np.abs(x)), [0.25] * 4)
    np.testing.assert_allclose(np.abs(y), [ROBOT.track_gauge / 2] * 4)


@pytest.mark.parametrize("u0, u1", [((1.0, 1.0), (1.0, 0.0)), ((1.0, 0.0), (0.0, 1.0))])
def test_rollout_transient_matches_the_independent_generator(u0, u1, monkeypatch):
    """Turn entry from straight driving and a turn reversal (load transfer on both sides)."""
    gen = _generator(u0, u1, monkeypatch)
    roll = _rollout(u0, u1)
    assert roll == pytest.approx(gen, rel=0.01), (roll, gen)  # measured within 0.1 %
    if u0 == (1.0, 1.0):  # the one-step load transfer is off by more than 5 %
        assert abs(_rollout(u0, u1, load_iterations=1) / gen - 1) > 0.05


def test_spin_start_from_rest_has_the_closed_form_first_instant():
    """At 0+ of a spin from rest every contact slides along x at V: wdot = (T/2) mu m g / I."""
    t = np.array([0.0, 1e-6])
    r = coulomb.rollout(BODY, t, -V, V, n_points=2, inertia=INERTIA)
    wdot = r.twist[1, 2] / 1e-6
    assert wdot == pytest.approx(ROBOT.track_gauge / 2 * ROBOT.mu * ROBOT.mass * coulomb.G / INERTIA, rel=1e-3)
