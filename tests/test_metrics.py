import numpy as np
import pytest

from mjtrack.errors import InputError
from mjtrack.metrics import horizon_errors
from mjtrack.models import MPP, Nominal, integrate

T = 0.4


def _log(rng, n=600, dt=0.05):
    t = np.arange(n) * dt
    steps = np.repeat(rng.uniform(-0.8, 0.8, (n // 40 + 1, 2)), 40, axis=0)[:n]
    return t, steps[:, 0], steps[:, 1]


def test_true_model_has_zero_error(rng):
    t, vl, vr = _log(rng)
    truth = MPP(T, 0.1, 0.05, 0.1)
    poses = integrate(truth, [1.0, -2.0, 0.4], t, vl, vr)
    for h in (0.5, 2.0, 5.0):
        err = horizon_errors(truth, t, vl, vr, poses, h)
        assert err.pos_err.size > 0
        assert np.max(err.pos_err) < 1e-10 and np.max(np.abs(err.yaw_err)) < 1e-10


def test_matches_direct_integration_from_each_start(rng):
    t, vl, vr = _log(rng, 200)
    truth = MPP(T, 0.2, 0.0, 0.2)
    poses = integrate(truth, np.zeros(3), t, vl, vr)
    err = horizon_errors(Nominal(T), t, vl, vr, poses, 1.0, stride=7)
    for s, e, pred in zip(err.start, err.end, err.predicted):
        direct = integrate(Nominal(T), poses[s], t[s : e + 1], vl[s : e + 1], vr[s : e + 1])[-1]
        assert np.allclose(pred, direct, atol=1e-10)
    assert err.pos_rmse > 0.01  # the nominal model is wrong on slipping truth


def test_segments_are_not_crossed(rng):
    t, vl, vr = _log(rng, 100)
    poses = integrate(Nominal(T), np.zeros(3), t, vl, vr)
    seg = np.repeat([0, 1], 50)
    err = horizon_errors(Nominal(T), t, vl, vr, poses, 1.0, segments=seg)
    assert np.all(seg[err.start] == seg[err.end])
    short = horizon_errors(Nominal(T), t, vl, vr, poses, 100.0)
    assert short.pos_err.size == 0 and np.isnan(short.pos_rmse)


def test_bad_input():
    with pytest.raises(InputError, match="shape"):
        horizon_errors(Nominal(T), [0, 1], [0, 0], [0, 0], np.zeros((3, 3)), 1.0)
    with pytest.raises(InputError, match="horizon"):
        horizon_errors(Nominal(T), [0, 1], [0, 0], [0, 0], np.zeros((2, 3)), 0.0)
