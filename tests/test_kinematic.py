import numpy as np
import pytest

from mjtrack.errors import InputError
from mjtrack.geometry import se2_step
from mjtrack.icr import icr_from_twist, virtual_robot_from_twist
from mjtrack.models import MICR, MODELS, MPP, MVIR, Nominal, integrate

T = 0.4


def _speeds(rng, n=300):
    vl, vr = rng.uniform(-1.5, 1.5, (2, n))
    return vl, vr


def test_registry_has_all_models():
    assert set(MODELS) == {"nominal", "MPP", "MICR", "MVIR"}


def test_nominal_equation_2_1():
    tw = Nominal(T).twist(0.3, 0.5)
    assert np.allclose(tw, [0.4, 0.0, 0.5])


@pytest.mark.parametrize(
    "model", [MPP(T), MPP(T, 0.0, 0.0, 0.0), MICR.nominal(T), MVIR.nominal(T)], ids=lambda m: m.name
)
def test_zero_slip_models_reduce_to_nominal(model, rng):
    vl, vr = _speeds(rng)
    assert np.allclose(model.twist(vl, vr), Nominal(T).twist(vl, vr), atol=1e-15)


def test_mpp_first_row_divides_by_two_not_gauge():
    # the printed (2.9) has /T in the first row; with T != 2 that would not reduce to (2.1)
    assert np.isclose(MPP(T, 0.1, 0.2, 0.0).twist(1.0, 1.0)[0], (0.9 + 0.8) / 2)


def test_mpp_alpha_sign_convention():
    # x_c = -vy/wz = vx tan(alpha)/wz. For a forward left turn, alpha > 0 moves the no-slip line
    # forward and pushes the centre to the outside (right) of the turn, as the thesis says.
    alpha = np.deg2rad(10)
    tw = MPP(T, 0.0, 0.0, alpha).twist(0.3, 0.6)
    icr = icr_from_twist(*tw, 0.3, 0.6)
    assert icr.x_c > 0 and tw[1] < 0
    assert np.isclose(icr.x_c, tw[0] * np.tan(alpha) / tw[2])
    # For a right turn the same alpha moves the no-slip line backwards: a physical forward shift
    # (e.g. a centre of gravity ahead of the centre) needs alpha with the sign of vx*wz.
    tw = MPP(T, 0.0, 0.0, alpha).twist(0.6, 0.3)
    assert icr_from_twist(*tw, 0.6, 0.3).x_c < 0
    tw = MPP(T, 0.0, 0.0, -alpha).twist(0.6, 0.3)
    assert icr_from_twist(*tw, 0.6, 0.3).x_c > 0 and tw[1] > 0  # outside of a right turn is left


def test_micr_mvir_reproduce_mpp_twist(rng):
    vl, vr = _speeds(rng)
    sl, sr = rng.uniform(-0.3, 0.5, (2, vl.size))
    alpha = rng.uniform(-0.4, 0.4, vl.size)
    truth = MPP(T, sl, sr, alpha).twist(vl, vr)
    ok = np.abs(truth[:, 2]) > 1e-3
    icr = icr_from_twist(*truth[ok].T, vl[ok], vr[ok])
    assert np.allclose(MICR(icr.y_l, icr.y_r, icr.x_c).twist(vl[ok], vr[ok]), truth[ok], atol=1e-12)
    vir = virtual_robot_from_twist(*truth[ok].T, vl[ok], vr[ok])
    assert np.allclose(MVIR(vir.x_o, vir.y_o, vir.track).twist(vl[ok], vr[ok]), truth[ok], atol=1e-12)


def _fd_jacobian(model, vl, vr, eps=1e-6):
    p = model.params
    cols = []
    for i in range(p.shape[-1]):
        dp = np.zeros_like(p)
        dp[..., i] = eps
        cols.append((model.with_params(p + dp).twist(vl, vr) - model.with_params(p - dp).twist(vl, vr)) / (2 * eps))
    return np.stack(cols, -1)


@pytest.mark.parametrize(
    "model",
    [Nominal(0.45), MPP(T, 0.12, -0.05, 0.2), MICR(0.26, -0.31, 0.04), MVIR(0.03, -0.02, 0.55)],
    ids=lambda m: m.name,
)
def test_twist_jacobian_matches_finite_differences(model, rng):
    vl, vr = _speeds(rng, 50)
    analytic = model.twist_jacobian(vl, vr)
    assert analytic.shape == (50, 3, len(model.param_names))
    assert np.allclose(analytic, _fd_jacobian(model, vl, vr), rtol=1e-6, atol=1e-8)


def test_with_params_round_trip():
    m = MPP(T, 0.1, 0.2, 0.3)
    assert m.with_params(m.params) == m
    with pytest.raises(InputError, match="expected 3 parameters"):
        m.with_params([0.1, 0.2])


def test_bad_parameters_refused():
    with pytest.raises(InputError, match="track_gauge"):
        Nominal(-1.0)
    with pytest.raises(InputError, match="alpha"):
        MPP(T, alpha=2.0)


def test_integrate_constant_command_is_circle():
    t = np.linspace(0.0, 2 * np.pi / 0.5, 1001)
    vl, vr = np.full(t.size, 0.4), np.full(t.size, 0.6)  # vx = 0.5, wz = 0.5 -> radius 1
    poses = integrate(Nominal(T), np.zeros(3), t, vl, vr)
    assert np.allclose(poses[-1], [0.0, 0.0, 2 * np.pi], atol=1e-12)
    assert np.allclose(np.hypot(poses[:, 0], poses[:, 1] - 1.0), 1.0, atol=1e-12)


def test_integrate_exact_matches_stepwise_and_euler_converges(rng):
    n = 400
    t = np.cumsum(rng.uniform(0.005, 0.02, n))
    vl, vr = rng.uniform(-1, 1, (2, n))
    model = MPP(T, rng.uniform(0, 0.3, n), 0.1, rng.uniform(-0.2, 0.2, n))  # time-varying parameters
    poses = integrate(model, [1.0, 2.0, 0.3], t, vl, vr)
    tw = model.twist(vl, vr)
    p = np.array([1.0, 2.0, 0.3])
    for k in range(n - 1):
        p = se2_step(p, tw[k], t[k + 1] - t[k])
    assert np.allclose(poses[-1], p, atol=1e-12)
    euler = integrate(model, [1.0, 2.0, 0.3], t, vl, vr, method="euler")
    assert np.max(np.abs(euler - poses)) < 0.05  # first-order method, steps ~1 cm


def test_integrate_rejects_bad_time():
    with pytest.raises(InputError, match="strictly increasing"):
        integrate(Nominal(T), np.zeros(3), [0.0, 1.0, 1.0], [1, 1, 1], [1, 1, 1])
    with pytest.raises(InputError, match="method"):
        integrate(Nominal(T), np.zeros(3), [0.0, 1.0], [1, 1], [1, 1], method="rk4")
